"""The twin the diagnosis builds, as a compensation: a static curve in the die temperature plus the
library's effects, per axis.

Per axis ``a(t) = p(T_die − T_ref) + Σ_effects Σ_k A_k·basis_k(inputs)``, with ``T_die`` from the
``thermal_lag`` effect (the temperature slot) and every other effect evaluated by the effect
library itself (:meth:`twin.effects.Effect.basis`), so the compensation and ``twin compare``
predict with one implementation. The amplitudes enter linearly; the nonlinear parameters (time
constants, widths) are searched on each effect's own grid and refined (variable projection), on
the training rows only, while every stateful effect runs over the whole log.

:func:`composed_drift_g` evaluates a stored model; ``predict``, ``twin apply`` and the
plausibility checks all call it.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
from sklearn.utils.validation import check_is_fitted

from twin.calibration.lag import ThermalLog, as_log, fit_inputs, make_X, validated_log
from twin.calibration.models import AXES, CompensatorBase, poly_columns, to_mg_per_c
from twin.estimation.linalg import fit_bounded_linear
from twin.estimation.problem import amplitude_bounds
from twin.estimation.search import bounded_minimum
from twin.effects import Composition, EffectInputs, get_effect
from twin.errors import TwinError

if TYPE_CHECKING:
    from twin.calibration.validate import ValidationResult

TEMPERATURE_SLOT = "thermal_lag"


def _inputs(log: ThermalLog, applied_g: float) -> EffectInputs:
    t0 = np.empty_like(log.time_s)
    for s in log.segments():
        t0[s] = log.time_s[s.start]
    return EffectInputs(time_s=log.time_s, die_c=log.temperature_c, thermometer_c=log.temperature_c,
                        applied_g=np.full(log.time_s.size, float(applied_g)), run_index=log.run,
                        time_since_power_on_s=log.time_s - t0)


UNIFORM = 0.05  # steps within this fraction of the median: the effects' one-step filters hold as they are


def _on_uniform_clock(log: ThermalLog, evaluate):
    """``evaluate(log) → (n, k)`` on an evenly sampled log, at ``log``'s own rows.

    The effects filter at one step (the median). A log with gaps (rows dropped as motion) or a
    drifting clock is evaluated on a uniform grid at the median step, its temperature linearly
    interpolated — the first-order hold the C header integrates exactly over each measured step —
    and the result read back at the log's times.
    """
    dt = np.diff(log.time_s)
    step = float(np.median(dt)) if dt.size else 1.0
    inside = np.ones(dt.size, bool)
    inside[[s.stop - 1 for s in log.segments()[:-1]]] = False  # a run boundary is no step
    if not np.any(np.abs(dt[inside] - step) > UNIFORM * step):
        return evaluate(log)
    times, temps, runs, spans = [], [], [], []
    for s in log.segments():
        t = log.time_s[s]
        grid = t[0] + step * np.arange(int(np.ceil((t[-1] - t[0]) / step - 1e-9)) + 1)
        spans.append((s, sum(g.size for g in times), grid))
        times.append(grid)
        temps.append(np.interp(grid, t, log.temperature_c[s]))
        runs.append(np.full(grid.size, log.run[s.start]))
    values = evaluate(ThermalLog(np.concatenate(times), np.concatenate(temps), np.concatenate(runs)))
    out = np.empty((log.time_s.size, values.shape[1]))
    for s, start, grid in spans:
        for j in range(values.shape[1]):
            out[s, j] = np.interp(log.time_s[s], grid, values[start:start + grid.size, j])
    return out


def _columns(effects: list, log: ThermalLog, applied_g: float, degree: int, reference_c: float):
    """(n, k) design: powers of (T_die − ref)/10 °C, then each effect's screened amplitude bases [g]."""
    comp = Composition(effects)
    names: list = []

    def design(on: ThermalLog) -> np.ndarray:
        names.clear()
        inputs = comp.with_die_temperature(_inputs(on, applied_g))
        cols = [poly_columns(inputs.die_c - reference_c, degree)]
        for e in comp.drift_effects:
            screened = {p.name for p in e.parameters if p.role == "amplitude" and p.screen}
            for amp, contrib in e.basis(inputs).items():
                if amp in screened:
                    cols.append(np.broadcast_to(contrib.output_g(inputs.applied_g), (on.time_s.size,))[:, None])
                    names.append((e.name, amp))
        return np.column_stack(cols)

    return _on_uniform_clock(log, design), names


def reads_temperature(effect: str) -> bool:
    """Whether an effect reads a temperature (die or thermometer), not time alone.

    Parameters
    ----------
    effect : str
        Registered effect name.

    Returns
    -------
    bool
        True when it reads ``die_c`` or ``thermometer_c``.
    """
    return bool({"die_c", "thermometer_c"} & set(get_effect(effect).reads))


def _make(spec: list[tuple[str, dict]]) -> list:
    return [get_effect(name)({}, **values) for name, values in spec]


def composed_drift_g(axes: list[dict], reference_c: float, time_s, temperature_c, run=None) -> np.ndarray:
    """Modelled drift [g], (n, 3), of a stored composed model, its level removed.

    ``axes[a]``: ``{"coef_mg": [...], "applied_g": g, "effects": [{"name", "values"}, ...]}`` as
    :attr:`ComposedCompensator.axes_` holds it; amplitudes are in the effects' values.

    Parameters
    ----------
    axes : list of dict
        The stored axes.
    reference_c : float
        Expansion point [°C].
    time_s, temperature_c : (n,) array-like
        Sample times [s] and temperatures [°C].
    run : (n,) array-like of int, optional
        Run id per sample.

    Returns
    -------
    (n, 3) ndarray
        Drift [g].
    """
    log = as_log(make_X(time_s, temperature_c, run))

    def drift(on: ThermalLog) -> np.ndarray:
        out = np.empty((on.time_s.size, len(axes)))
        for a, entry in enumerate(axes):
            comp = Composition(_make([(e["name"], e["values"]) for e in entry["effects"]]))
            inputs = comp.with_die_temperature(_inputs(on, entry["applied_g"]))
            coef = np.asarray(entry["coef_mg"], float)
            out[:, a] = (np.polyval(coef[::-1], inputs.die_c - reference_c) - coef[0]) * 1e-3
            for contrib in comp.evaluate(inputs).values():
                out[:, a] += contrib.output_g(inputs.applied_g)
        return out

    return _on_uniform_clock(log, drift)


class ComposedCompensator(CompensatorBase):
    """Static cubic in the die temperature plus library effects, fitted per axis.

    Parameters
    ----------
    effects : tuple of str, or dict axis → tuple of str
        Registered effect names (plugins included once imported) added to every axis, or per axis
        (``{"x": ("stress_relaxation",), "y": ("thermal_gradient",)}``) as ``twin compare`` names them.
    degree : int
        Degree of the static curve in ``T_die − reference_c``.
    reference_c : float
        Expansion point [°C].

    Attributes
    ----------
    n_features_in_ : int
        Columns of ``X`` seen in ``fit`` (2, or 3 with a run id).
    axes_ : list of dict
        Per axis the fitted static coefficients [mg/°C^k], the effects with their fitted values,
        and the training RMS [mg].
    """

    rate_dependent = True

    def __init__(self, effects=("stress_relaxation",), degree: int = 3, reference_c: float = 35.0):
        self.effects = effects
        self.degree = degree
        self.reference_c = reference_c

    def _names(self, axis: str) -> list[str]:
        named = self.effects.get(axis, ()) if isinstance(self.effects, dict) else self.effects
        return [TEMPERATURE_SLOT] + [n for n in dict.fromkeys(named) if n != TEMPERATURE_SLOT]

    def fit(self, X, y, mask=None):
        """Fit each axis on the rows of ``mask``; the effects run over every row of ``X``. Returns self.

        Parameters
        ----------
        X : array-like, (n, 2) or (n, 3)
            ``[time_s, temperature_c]`` [s, °C], optionally with a run id.
        y : (n, 3) array-like
            Readings [g].
        mask : array-like of bool or int, optional
            Rows to fit on.

        Returns
        -------
        ComposedCompensator
            ``self``, fitted.
        """
        log, y, keep = fit_inputs(self, X, y, mask)
        self.axes_ = []
        for a, axis in enumerate(AXES):
            try:
                effects = [get_effect(n)({}) for n in self._names(axis)]
            except TwinError as exc:  # an unknown name: say which axis asked for it
                raise TwinError(f"axis {axis}: {exc}") from None
            applied = float(np.median(y[keep, a]))
            effects, coef, rms = self._fit_axis(effects, log, y[:, a], keep, applied)
            self.axes_.append({"axis": axis, "coef_mg": to_mg_per_c(coef[: self.degree + 1]).tolist(),
                               "applied_g": applied, "train_rms_mg": rms,
                               "effects": [{"name": e.name, "values": {k: float(v) for k, v in e.values.items()}}
                                           for e in effects]})
        return self

    def _fit_axis(self, effects, log, y, keep, applied):
        def solve(effs):
            F, names = _columns(effs, log, applied, self.degree, self.reference_c)
            # the amplitudes stay inside their physical bounds (the effect refuses values outside)
            coef = fit_bounded_linear(F[keep], y[keep], *amplitude_bounds(names, self.degree + 1))
            r = y[keep] - F[keep] @ coef
            return float(r @ r), coef, names

        slots = [(i, p) for i, e in enumerate(effects) for p in e.parameters
                 if p.role == "nonlinear" and p.free and len(p.grid) > 1]
        for _ in range(2 if len(slots) > 1 else 1):  # coordinate search over each effect's own grid
            for i, p in slots:
                # the lower bound too: a log without the effect (a zero lag) must be able to reach it
                grid = sorted(set(p.grid) | {effects[i].values[p.name], p.bounds[0]})
                sse = [solve(_with(effects, i, p.name, v))[0] for v in grid]
                k = int(np.argmin(sse))
                lo, hi = max(grid[max(k - 1, 0)], p.bounds[0], 1e-9), min(grid[min(k + 1, len(grid) - 1)], p.bounds[1])
                best = grid[k]
                if hi > lo:
                    res = bounded_minimum(lambda lv: solve(_with(effects, i, p.name, float(np.exp(lv))))[0],
                                          np.log(lo), np.log(hi), xatol=1e-3)
                    if res.fun <= sse[k]:
                        best = float(np.exp(res.x))
                effects = _with(effects, i, p.name, best)
        sse, coef, names = solve(effects)
        d = self.degree + 1
        lo, hi = amplitude_bounds(names, d)
        for j, (name, amp) in enumerate(names):  # the amplitudes live in the effects, as compare writes them
            i = next(k for k, e in enumerate(effects) if e.name == name)
            effects = _with(effects, i, amp, float(np.clip(coef[d + j], lo[d + j], hi[d + j])))
        return effects, coef, float(np.sqrt(sse / keep.sum()) * 1e3)

    @property
    def coef_mg_(self) -> np.ndarray:
        """Static coefficients a_k [mg/°C^k] per axis, (3, degree + 1), read from ``axes_``."""
        check_is_fitted(self)
        return np.array([e["coef_mg"] for e in self.axes_])

    def predict(self, X) -> np.ndarray:
        """Modelled reading [g], (n, 3): level plus the composed drift.

        Parameters
        ----------
        X : array-like, (n, 2) or (n, 3)
            ``[time_s, temperature_c]`` [s, °C], optionally with a run id.

        Returns
        -------
        (n, 3) ndarray
            Modelled reading [g].
        """
        log = validated_log(self, X, reset=False)
        drift = composed_drift_g(self.axes_, self.reference_c, log.time_s, log.temperature_c, log.run)
        return drift + self.coef_mg_[:, 0] * 1e-3

    def equation(self) -> str:
        """Per axis the static curve and each effect with its fitted values.

        Returns
        -------
        str
            One line per axis (coefficients in mg/°C^k).
        """
        check_is_fitted(self)
        lines = []
        for e in self.axes_:
            terms = ", ".join(f"{x['name']}(" + ", ".join(f"{k}={v:.4g}" for k, v in x["values"].items()
                                                         if k != "reference_c") + ")" for x in e["effects"])
            lines.append(f"{e['axis']}: cubic in T_die about {self.reference_c:g} °C "
                         f"[{', '.join(f'{c:+.4g}' for c in e['coef_mg'])}] mg/°C^k + {terms}")
        return "\n".join(lines)

    def without_c_form(self) -> list[str]:
        """The composed effects the C header cannot run (``twin.firmware.composed_header.SUPPORTED``).

        Returns
        -------
        list of str
            Effect names, sorted.
        """
        from twin.firmware.composed_header import SUPPORTED

        return sorted({x["name"] for e in self.axes_ for x in e["effects"] if x["name"] not in SUPPORTED})

    def drifts_in_time(self) -> list[str]:
        """The composed effects no firmware runs that read no temperature: a drift in time (aging).

        Returns
        -------
        list of str
            Effect names.
        """
        return [n for n in self.without_c_form() if not reads_temperature(n)]

    def effect_names(self) -> dict[str, list[str]]:
        """Per axis the drift effects composed (the temperature slot left out).

        Returns
        -------
        dict of str to list of str
            Axis → effect names.
        """
        return {e["axis"]: [x["name"] for x in e["effects"] if x["name"] != TEMPERATURE_SLOT] for e in self.axes_}


def composed_notes(validation: ValidationResult, fitted: dict) -> tuple[str, ...]:
    """Per composed method and axis: the effects composed and its held-out RMS beside the lag-aware
    twin's, i.e. whether what compare named helps a compensation on data it was not fitted on.

    Parameters
    ----------
    validation : ValidationResult
        The held-out scores.
    fitted : dict
        Method name → fitted estimator.

    Returns
    -------
    tuple of str
        One note per composed method and axis (RMS in mg).
    """
    out = []
    for name, est in fitted.items():
        if not isinstance(est, ComposedCompensator) or name not in validation.methods:
            continue
        mine = validation.rms_mg(name)
        other = validation.rms_mg("twin") if "twin" in validation.methods else None
        missing = est.without_c_form()
        for a, (axis, effects) in enumerate(est.effect_names().items()):
            text = (f"{name} {axis}: {' + '.join(['static cubic', 'die lag'] + effects)} leaves {mine[a]:.2f} mg "
                    "held out")
            if other is not None:
                text += (f", the lag-aware twin {other[a]:.2f} mg: " + ("the composed effects help here" if mine[a] <
                         other[a] else "the composed effects do not improve on the lag and rate term held out"))
            out.append(text + (f"; twin apply --method {name!r} runs it, the C header cannot ({', '.join(missing)})"
                               if missing else f"; twin apply and the C export (--method {name!r}) run it"))
    return tuple(out)


def effects_named_by_compare(doc, source: str) -> dict[int, dict[str, tuple[str, ...]]]:
    """Per IMU instance and axis, the effects a ``twin compare --axes … --json`` result named.

    Parameters
    ----------
    doc : dict
        The parsed JSON.
    source : str
        Where it came from, for messages.

    Returns
    -------
    dict of int to dict of str to tuple of str
        Instance → axis → effect names.

    Raises
    ------
    TwinError
        Naming ``source`` and what was expected, when ``doc`` is not such a result.
    """
    imus = doc.get("imus") if isinstance(doc, dict) else None
    if not isinstance(imus, list) or not imus:
        raise TwinError(f"{source}: no 'imus'; expected the JSON of twin compare … --axes x,y,z --json")
    out = {}
    for k, imu in enumerate(imus):
        axes = imu.get("axes") if isinstance(imu, dict) else None
        instance = imu.get("instance") if isinstance(imu, dict) else None
        if not isinstance(axes, dict) or isinstance(instance, bool) or not isinstance(instance, int):
            raise TwinError(f"{source}: imus[{k}]: expected an 'instance' and per-axis results under 'axes'")
        named = {}
        for axis, result in axes.items():
            selected = result.get("selected") if isinstance(result, dict) else None
            if axis not in AXES or not isinstance(selected, list) or not all(isinstance(n, str) for n in selected):
                raise TwinError(f"{source}: imus[{k}].axes.{axis}: expected an axis x|y|z with a 'selected' list of "
                                "effect names")
            named[axis] = tuple(selected)
        out[instance] = named
    return out


def _with(effects: list, i: int, name: str, value: float) -> list:
    out = list(effects)
    out[i] = out[i].with_values(**{name: value})
    return out
