"""Is a fitted compensation physically plausible? Flags that keep an implausible fit off a vehicle.

A fit can be numerically fine and physically absurd: a time constant that ran to its search
bound, a level of −4 g on a board that was still, an offset slope of 50 mg/°C where the part's
datasheet says 0.8. Each is a sign that the fit absorbed something other than temperature drift
(motion, a crash, a flip, a gap). A flagged method is not recommended and not exported without
``--force``.

The limits are *far outside* the part's typical figure — ``FAR`` times it — because a datasheet's
typical TCOff or TCSo is a spread over devices, not a bound on one device: real parts reach a few
times the typical value, not ten.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from twin.calibration.models import AXES
from twin.errors import TwinError

FAR = 10.0  # "far outside" = this many times the part's typical figure
# a still accelerometer reads gravity's projection (|a| ≤ 1 g) plus its zero-g offset (tens of mg):
# a fitted level beyond this is not a level the sensor could have had at rest
MAX_LEVEL_G = 1.2
TAU_BOUND_MARGIN = 0.01  # a time constant within 1 % of its search bound is "on the bound"
DEFAULT_PART = "IIS328DQ"


@dataclass(frozen=True)
class PlausibilityLimits:
    """What a still IMU's thermal calibration may plausibly hold.

    Attributes
    ----------
    tcoff_mg_per_c : float
        Largest offset slope |d offset / dT| accepted [mg/°C].
    tcso_ppm_per_c : float
        Largest scale-factor tempco |TCSo| accepted [ppm/°C].
    tau_max_s : float
        Upper search bound of the lag time constants [s]; a fit on it is flagged.
    source : str
        Where the limits come from (part and factor), for the message.
    """

    tcoff_mg_per_c: float
    tcso_ppm_per_c: float
    tau_max_s: float
    source: str


def limits_for_part(part_name: str = DEFAULT_PART, tau_max_s: float = 600.0) -> PlausibilityLimits:
    """Limits ``FAR`` × the part's typical TCOff and TCSo (``twin parts`` lists them).

    Parameters
    ----------
    part_name : str
        A part ``twin parts`` lists, with datasheet TCOff and TCSo.
    tau_max_s : float
        Upper search bound of the lag time constants [s].

    Returns
    -------
    PlausibilityLimits
        The limits [mg/°C, ppm/°C, s] and their source.
    """
    from twin.parts import load_part

    part = load_part(part_name)
    if not {"tcoff_mg_per_c", "tcso_pct_per_c"} <= set(part.figures):
        raise TwinError(f"--part {part_name}: the part gives no datasheet TCOff and TCSo; expected a part that "
                        "does (twin parts lists them)")
    tcoff = float(part.figures["tcoff_mg_per_c"].value)
    tcso_ppm = float(part.figures["tcso_pct_per_c"].value) * 1e4  # %/°C → ppm/°C
    return PlausibilityLimits(FAR * tcoff, FAR * tcso_ppm, float(tau_max_s),
                              f"{FAR:g}× the {part.name} typical TCOff {tcoff:g} mg/°C and TCSo {tcso_ppm:g} ppm/°C")


def static_curve_mg(correction_g, data: dict, span_c: tuple[float, float], n: int = 64) -> tuple[np.ndarray, np.ndarray]:
    """(temperatures [°C], correction [mg] (n, 3)) of a method held at each temperature long enough
    for every lag to settle: the static offset curve the fit claims.

    Parameters
    ----------
    correction_g : callable
        ``correction_g(data, time_s, temperature_c) → (n, 3) g``.
    data : dict
        The method as the document stores it.
    span_c : (float, float)
        Temperature span [°C].
    n : int
        Temperatures evaluated.

    Returns
    -------
    (temperature_c, curve_mg) : (n,) ndarray, (n, 3) ndarray
        Temperatures [°C] and the settled correction [mg].
    """
    temperature_c = np.linspace(span_c[0], span_c[1], n)
    settled_time_s = np.arange(n) * 1e7  # ≫ any τ: the lags equal T and the rate term vanishes
    if data.get("kind") == "ComposedCompensator":  # effects of time alone (aging, warm-up) are no curve in T
        from twin.calibration.composed import reads_temperature

        data = {**data, "axes": [{**ax, "effects": [e for e in ax["effects"] if reads_temperature(e["name"])]}
                                 for ax in data["axes"]]}
    return temperature_c, np.asarray(correction_g(data, settled_time_s, temperature_c)) * 1e3


def method_flags(name: str, data: dict, correction_g, span_c: tuple[float, float],
                 limits: PlausibilityLimits) -> list[str]:
    """Why a fitted method (as stored in the calibration document) is implausible; empty if it is not.

    Parameters
    ----------
    name : str
        Method name, for the messages.
    data : dict
        The method as the document stores it (``method_json``).
    correction_g : callable
        ``correction_g(data, time_s, temperature_c) → (n, 3) g`` (``twin.calibration.deploy``).
    span_c : (float, float)
        Calibrated temperature span [°C].
    limits : PlausibilityLimits

    Returns
    -------
    list of str
        One reason per implausible feature (τ [s], level [g], slope [mg/°C]).
    """
    flags = []
    values = [v for key in ("coef_mg", "level_g", "rate_mg_per_c") for v in np.ravel(data.get(key) or [])]
    if not np.all(np.isfinite(np.asarray(values, float))):
        flags.append(f"{name}: non-finite coefficients")
        return flags
    # a die lag on its bound has absorbed something slower than a die (motion, a flip, a drift);
    # a rate term's τ on its bound is a relaxation slower than the search, which the held-out
    # folds judge (twin.calibration.recommend): a note, not a flag (see rate_bound_notes)
    for axis, tau in zip(AXES, data.get("tau_die_s") or []):
        if tau is not None and tau >= (1 - TAU_BOUND_MARGIN) * limits.tau_max_s:
            flags.append(f"{name} {axis}: τ_die {tau:.0f} s is on its {limits.tau_max_s:g} s search bound "
                         "(the data do not fix it)")
    level = np.asarray(data.get("level_g") or (np.asarray(data.get("coef_mg", [[0.0]] * 3))[:, 0] * 1e-3), float)
    for axis, g in zip(AXES, level):
        if abs(g) > MAX_LEVEL_G:
            flags.append(f"{name} {axis}: level {g:+.2f} g; a still accelerometer reads at most about 1 g")
    temperature_c, curve_mg = static_curve_mg(correction_g, data, span_c)
    if not np.all(np.isfinite(curve_mg)):
        return flags + [f"{name}: correction not finite over {span_c[0]:.1f}..{span_c[1]:.1f} °C"]
    peak_g = np.max(np.abs(curve_mg), axis=0) * 1e-3
    for axis, g in zip(AXES, peak_g):
        if g > MAX_LEVEL_G:
            flags.append(f"{name} {axis}: correction up to {g:.3g} g over {span_c[0]:.1f}..{span_c[1]:.1f} °C; a still "
                         "accelerometer reads at most about 1 g")
    slope = np.max(np.abs(np.gradient(curve_mg, temperature_c, axis=0)), axis=0)
    for axis, s in zip(AXES, slope):
        if s > limits.tcoff_mg_per_c:
            flags.append(f"{name} {axis}: offset slope up to {s:.1f} mg/°C, beyond {limits.tcoff_mg_per_c:g} mg/°C "
                         f"({limits.source})")
    return flags


def rate_bound_notes(name: str, data: dict, limits: PlausibilityLimits) -> list[str]:
    """Notes on rate terms whose time constant ran to the search bound: the data do not fix τ_rate.

    Parameters
    ----------
    name : str
        Method name.
    data : dict
        The method as the document stores it.
    limits : PlausibilityLimits
        Holds the search bound ``tau_max_s`` [s].

    Returns
    -------
    list of str
        One note per such axis.
    """
    return [f"{name} {axis}: τ_rate {tau:.0f} s is on its {limits.tau_max_s:g} s search bound: the data do not fix "
            "it, so the rate term stands only as far as the held-out folds that both heat and cool support it"
            for axis, tau in zip(AXES, data.get("tau_rate_s") or [])
            if tau is not None and tau >= (1 - TAU_BOUND_MARGIN) * limits.tau_max_s]


def tcso_flags(orientations: dict, limits: PlausibilityLimits) -> list[str]:
    """Flags on the scale-factor tempcos of a several-orientation calibration (None = not identifiable).

    Parameters
    ----------
    orientations : dict
        The orientation summary (``tcso_ppm_per_c`` per axis [ppm/°C]).
    limits : PlausibilityLimits
        Holds ``tcso_ppm_per_c`` [ppm/°C].

    Returns
    -------
    list of str
        One flag per axis beyond the limit.
    """
    flags = []
    for axis, entry in orientations.get("tcso_ppm_per_c", {}).items():
        value = entry.get("value")
        if value is None or not np.isfinite(value):
            continue  # not identifiable: stated in the orientation notes, nothing to flag
        if abs(value) > limits.tcso_ppm_per_c:
            flags.append(f"orientations {axis}: TCSo {value:+.0f} ppm/°C, beyond ±{limits.tcso_ppm_per_c:g} ppm/°C "
                         f"({limits.source})")
    return flags
