"""Comb microstructure of the paper (§2.1, eqs. 9–21): capacitances and thermal drift, in SI.

Dimensions (paper §2.1.3, docs/physics.md §2.5 and §3 rows 3–13):
b overlap length of moving and fixed fingers, e gap between a fixed finger's tip and the moving
plate's long beam, h fixed-finger width, g finger length, u sensing gap, m moving-finger width,
n width of the moving plate's long beam, j structure thickness, i moving-finger length (undefined
in the paper; read as an OCR'd "l"). Lever arms of eq. (15): k1 = i + n/2 + g, k2 = (m + h)/2
(the paper's "k" read as h), k3 = g + n/2.

Capacitances of one finger cell (eq. 10 corrected: the gap is gas, ε = ε0):
C1 = ε0 h j / e, C2 = ε0 b j / (u − Δu), C3 = ε0 b j / (u + Δu), readout C2 − C3 (eq. 3; eq. 14's
sum is even in Δu and not the signal). Δu = a / ω0² through the spring.

Thermal readings (selectable):

* ``P`` paper literal: α(T) itself is used as a strain in eq. (15);
* ``S`` eq. (15) with the thermal strain ε(T) = ∫α dT in place of α: fingers grow, anchors stay;
* ``H`` homogeneous dilation: every length, gaps included, scales by (1 + ε) (monolithic Si on
  Si); spring stiffness fixed;
* ``HE`` H with the spring scaling as k ∝ E(T)·(1 + ε) (k ∝ E w³ t / L³ under dilation).

In P, S and H the spring stiffness is held at its reference value.
"""

from __future__ import annotations

from dataclasses import dataclass, fields

import numpy as np

from sim.materials import KELVIN, silicon_cte_per_k, silicon_thermal_strain, silicon_youngs_modulus_pa

EPSILON_0_F_PER_M = 8.8541878128e-12
STANDARD_GRAVITY_M_PER_S2 = 9.80665
READINGS = ("P", "S", "H", "HE")


class GeometryError(ValueError):
    """A comb geometry that is not physical (non-positive size, or a gap that closes)."""


@dataclass(frozen=True)
class CombGeometry:
    """Comb-cell dimensions [µm] and proof-mass resonance [Hz] (defaults: docs/physics.md §2.5).

    Symbols of the paper's §2.1.3 (see the module docstring).

    Attributes
    ----------
    b_um : float
        Overlap length of moving and fixed fingers [µm].
    e_um : float
        Gap between a fixed finger's tip and the moving plate's long beam [µm].
    h_um : float
        Fixed-finger width [µm].
    g_um : float
        Finger length [µm].
    u_um : float
        Sensing gap [µm].
    m_um : float
        Moving-finger width [µm].
    n_um : float
        Width of the moving plate's long beam [µm].
    j_um : float
        Structure thickness [µm].
    i_um : float
        Moving-finger length [µm].
    resonance_hz : float
        Proof-mass resonance f0 [Hz].
    """

    b_um: float = 100.0
    e_um: float = 5.0
    h_um: float = 3.0
    g_um: float = 110.0
    u_um: float = 2.0
    m_um: float = 3.0
    n_um: float = 15.0
    j_um: float = 15.0
    i_um: float = 110.0
    resonance_hz: float = 3000.0

    def __post_init__(self) -> None:
        for f in fields(self):
            v = getattr(self, f.name)
            if not (np.isfinite(v) and v > 0):
                raise GeometryError(f"geometry.{f.name} must be > 0, got {v}")

    @property
    def k1_um(self) -> float:
        """Lever arm k1 = i + n/2 + g of eq. (15) [µm]."""
        return self.i_um + self.n_um / 2 + self.g_um

    @property
    def k2_um(self) -> float:
        """Lever arm k2 = (m + h)/2 of eq. (15) [µm]."""
        return (self.m_um + self.h_um) / 2

    @property
    def k3_um(self) -> float:
        """Lever arm k3 = g + n/2 of eq. (15) [µm]."""
        return self.g_um + self.n_um / 2


def displacement_m(acceleration_g: np.ndarray | float, resonance_hz: float, stiffness_ratio: np.ndarray | float = 1.0) -> np.ndarray:
    """Proof-mass displacement Δu = a / ω0² [m]; ``stiffness_ratio`` = k(T)/k(T0) (ω0² ∝ k).

    27.6 nm at 1 g and 3 kHz.

    Parameters
    ----------
    acceleration_g : float or ndarray
        Input acceleration a [g].
    resonance_hz : float
        Resonance f0 = ω0/2π at the reference temperature [Hz].
    stiffness_ratio : float or ndarray
        Spring stiffness k(T)/k(T0) [1].

    Returns
    -------
    ndarray
        Δu [m].

    References
    ----------
    Static response of a spring–mass system, Δu = m a / k (standard result).
    """
    w0 = 2 * np.pi * resonance_hz
    return np.asarray(acceleration_g) * STANDARD_GRAVITY_M_PER_S2 / (w0 * w0 * np.asarray(stiffness_ratio))


@dataclass(frozen=True)
class DeformedComb:
    """Dimensions [m] of the comb at one temperature under one reading, and the spring ratio.

    Attributes
    ----------
    b, e, h, j, u : ndarray
        Overlap length, tip gap, fixed-finger width, thickness and sensing gap [m].
    stiffness_ratio : ndarray
        Spring stiffness k(T)/k(T0) [1].
    """

    b: np.ndarray
    e: np.ndarray
    h: np.ndarray
    j: np.ndarray
    u: np.ndarray
    stiffness_ratio: np.ndarray


def deformed(geometry: CombGeometry, temperature_c: np.ndarray | float, reading: str = "S",
             reference_c: float = 25.0) -> DeformedComb:
    """Comb dimensions at ``temperature_c`` under a thermal reading (eq. 15 and its corrections).

    Parameters
    ----------
    geometry : CombGeometry
        Dimensions at the reference temperature [µm].
    temperature_c : float or ndarray
        Temperature [°C].
    reading : {"P", "S", "H", "HE"}
        Thermal reading (see the module docstring).
    reference_c : float
        Reference (strain-free) temperature [°C].

    Returns
    -------
    DeformedComb
        Dimensions [m] and stiffness ratio [1].

    References
    ----------
    Qi et al. (2022), Micromachines 13, 2156, eq. (15); α(T), ε(T) of Okada & Tokumaru (1984);
    E(T) of Gysin et al. (2004); k ∝ E w³ t / L³ for a beam spring (standard beam theory).
    """
    if reading not in READINGS:
        raise ValueError(f"reading must be one of {READINGS}, got {reading!r}")
    t_k = np.asarray(temperature_c, float) + KELVIN
    um = 1e-6
    g = geometry
    if reading in ("P", "S"):
        s = silicon_cte_per_k(t_k) if reading == "P" else silicon_thermal_strain(t_k, reference_c + KELVIN)
        grow = 1.0 + s
        return DeformedComb(b=(g.b_um + s * g.k1_um) * um, e=(g.e_um - s * g.k3_um) * um, h=g.h_um * grow * um,
                            j=g.j_um * grow * um, u=(g.u_um - s * g.k2_um) * um, stiffness_ratio=np.ones_like(s))
    eps = silicon_thermal_strain(t_k, reference_c + KELVIN)
    grow = 1.0 + eps
    if reading == "H":
        k_ratio = np.ones_like(eps)
    else:
        k_ratio = silicon_youngs_modulus_pa(t_k) / silicon_youngs_modulus_pa(reference_c + KELVIN) * grow
    return DeformedComb(b=g.b_um * grow * um, e=g.e_um * grow * um, h=g.h_um * grow * um, j=g.j_um * grow * um,
                        u=g.u_um * grow * um, stiffness_ratio=k_ratio)


def capacitances_f(geometry: CombGeometry, temperature_c, acceleration_g=0.0, reading: str = "S",
                   reference_c: float = 25.0) -> dict[str, np.ndarray]:
    """C1, C2′, C3′ [F] and the differential signal C2′ − C3′ of one finger cell (eqs. 16–19).

    ``C_static`` is C1 + C2 + C3 at zero input (eq. 17).

    Parameters
    ----------
    geometry : CombGeometry
        Dimensions [µm] and resonance [Hz].
    temperature_c : float or ndarray
        Temperature [°C].
    acceleration_g : float or ndarray
        Input acceleration [g].
    reading : {"P", "S", "H", "HE"}
        Thermal reading.
    reference_c : float
        Reference temperature [°C].

    Returns
    -------
    dict of str to ndarray
        ``C1``, ``C2``, ``C3``, ``differential`` and ``C_static`` [F].

    References
    ----------
    Qi et al. (2022), Micromachines 13, 2156, eqs. (10), (16)–(19) (eq. 10 with ε = ε0, see the
    module docstring); parallel-plate capacitance ε0 A / d.
    """
    d = deformed(geometry, temperature_c, reading, reference_c)
    du = displacement_m(acceleration_g, geometry.resonance_hz, d.stiffness_ratio)
    c1 = EPSILON_0_F_PER_M * d.h * d.j / d.e
    c2 = EPSILON_0_F_PER_M * d.b * d.j / (d.u - du)
    c3 = EPSILON_0_F_PER_M * d.b * d.j / (d.u + du)
    c_static = c1 + 2 * EPSILON_0_F_PER_M * d.b * d.j / d.u
    return {"C1": c1, "C2": c2, "C3": c3, "differential": c2 - c3, "C_static": c_static}


def drift_g(geometry: CombGeometry, temperature_c, acceleration_g=1.0, reading: str = "S",
            reference_c: float = 25.0) -> dict[str, np.ndarray]:
    """Thermal drift of the indicated acceleration [g], split into offset and scale-factor parts.

    The readout is calibrated at ``reference_c``: a_ind = a_in·ΔC(T, a_in)/ΔC(T0, a_in) (exact
    inversion of the calibration at the same input). ``offset`` is the indication at zero input
    (zero for this symmetric comb), ``scale_factor`` the rest.

    Parameters
    ----------
    geometry : CombGeometry
        Dimensions [µm] and resonance [Hz].
    temperature_c : float or ndarray
        Temperature [°C].
    acceleration_g : float or ndarray
        Input acceleration a_in [g].
    reading : {"P", "S", "H", "HE"}
        Thermal reading.
    reference_c : float
        Calibration temperature T0 [°C].

    Returns
    -------
    dict of str to ndarray
        ``total``, ``offset`` and ``scale_factor`` drift [g].

    References
    ----------
    Differential signal of Qi et al. (2022), Micromachines 13, 2156, eqs. (16)–(19).
    """
    a = np.asarray(acceleration_g, float)
    sig_t = capacitances_f(geometry, temperature_c, a, reading, reference_c)["differential"]
    sig_0 = capacitances_f(geometry, reference_c, a, reading, reference_c)["differential"]
    with np.errstate(invalid="ignore", divide="ignore"):
        total = np.where(a != 0, a * (sig_t / np.where(sig_0 == 0, 1, sig_0) - 1.0), 0.0)
    zero = capacitances_f(geometry, temperature_c, 0.0, reading, reference_c)["differential"]
    per_g0 = capacitances_f(geometry, reference_c, 1.0, reading, reference_c)["differential"]
    offset = zero / per_g0
    return {"total": total + offset, "offset": offset * np.ones_like(total), "scale_factor": total}


def check_gaps(geometry: CombGeometry, full_scale_g: float = 2.0, reading: str = "S",
               t_low_c: float = -40.0, t_high_c: float = 105.0, reference_c: float = 25.0) -> None:
    """Raise :class:`GeometryError` if a gap closes anywhere in the temperature range.

    The sensing gap must stay open at full-scale travel (u(T) − Δu_FS > 0) and the tip gap
    e(T) > 0; the message names the temperature where a gap would close.

    Parameters
    ----------
    geometry : CombGeometry
        Dimensions [µm] and resonance [Hz].
    full_scale_g : float
        Full-scale input [g].
    reading : {"P", "S", "H", "HE"}
        Thermal reading.
    t_low_c, t_high_c : float
        Temperature range checked [°C].
    reference_c : float
        Reference temperature [°C].

    Raises
    ------
    GeometryError
        A gap closes in the range.
    """
    def margins(t_c: float) -> tuple[float, float]:
        d = deformed(geometry, t_c, reading, reference_c)
        du = displacement_m(full_scale_g, geometry.resonance_hz, d.stiffness_ratio)
        return float(d.u - du), float(d.e)

    temps = np.linspace(t_low_c, t_high_c, 146)
    for idx, name in ((0, "sensing gap u minus full-scale travel"), (1, "finger-tip gap e")):
        values = np.array([margins(t)[idx] for t in temps])
        if np.all(values > 0):
            continue
        if values[0] <= 0 and values[-1] <= 0 and np.all(values <= 0):
            raise GeometryError(f"geometry: the {name} is closed over the whole range {t_low_c:g}..{t_high_c:g} °C "
                                f"({values[0] * 1e6:.3g} µm at {t_low_c:g} °C)")
        k = int(np.argmax(values <= 0))
        lo, hi = (temps[k - 1], temps[k]) if k > 0 else (temps[k], temps[k + 1])
        from scipy.optimize import brentq  # only on this error path: scipy.optimize is slow to import

        t_close = brentq(lambda t: margins(t)[idx], lo, hi) if k > 0 else temps[0]
        raise GeometryError(f"geometry: the {name} closes at {t_close:.1f} °C (reading {reading}, "
                            f"full scale {full_scale_g:g} g)")


def linear_slope_mg_per_c(temperature_c: np.ndarray, drift: np.ndarray) -> tuple[float, float]:
    """Least-squares slope [mg/°C] and curvature [mg/°C²] of a drift curve [g] (quadratic fit).

    Parameters
    ----------
    temperature_c : ndarray
        Temperature [°C].
    drift : ndarray
        Drift [g].

    Returns
    -------
    slope : float
        Slope of a straight-line fit [mg/°C].
    curvature : float
        Quadratic coefficient about 25 °C [mg/°C²].
    """
    c2, c1, _ = np.polyfit(np.asarray(temperature_c) - 25.0, np.asarray(drift) * 1e3, 2)
    return float(np.polyfit(temperature_c, np.asarray(drift) * 1e3, 1)[0]), float(c2)
