"""Minimal drift law: bias and scale factor against die temperature (TCOff, TCSo).

IEEE Std 1293 model-equation form (docs/physics.md §1.7, §2.5):
``a_out = (1 + s1·ΔT + s2·ΔT²)·a_in + b1·ΔT + b2·ΔT²`` with ΔT = T_die − T_ref.
The effect library wraps these kernels; they stay pure functions of arrays.
"""

from __future__ import annotations

import math

import numpy as np

from sim import compiled


def bias_tc_g(
    die_c: np.ndarray, tc1_mg_per_c: float, tc2_mg_per_c2: float = 0.0, reference_c: float = 25.0
) -> np.ndarray:
    """Zero-g level change [g]: b1·ΔT + b2·ΔT² (TCOff; the paper's ±0.8 mg/°C, unverified).

    Parameters
    ----------
    die_c : ndarray
        Die temperature [°C].
    tc1_mg_per_c : float
        Linear bias tempco b1 [mg/°C].
    tc2_mg_per_c2 : float
        Quadratic bias tempco b2 [mg/°C²].
    reference_c : float
        Reference temperature T_ref [°C].

    Returns
    -------
    ndarray
        Bias change [g].

    References
    ----------
    IEEE Std 1293 model equation (docs/physics.md §1.7, §2.5).
    """
    dT = np.asarray(die_c, float) - reference_c
    return (tc1_mg_per_c * dT + tc2_mg_per_c2 * dT * dT) * 1e-3


def scale_factor_tc(
    die_c: np.ndarray, tc1_ppm_per_c: float, tc2_ppm_per_c2: float = 0.0, reference_c: float = 25.0
) -> np.ndarray:
    """Relative sensitivity change [1]: s1·ΔT + s2·ΔT² (TCSo; 0.01 %/°C = 100 ppm/°C, recalled).

    The output's drift is this times the applied acceleration.

    Parameters
    ----------
    die_c : ndarray
        Die temperature [°C].
    tc1_ppm_per_c : float
        Linear scale-factor tempco s1 [ppm/°C].
    tc2_ppm_per_c2 : float
        Quadratic scale-factor tempco s2 [ppm/°C²].
    reference_c : float
        Reference temperature T_ref [°C].

    Returns
    -------
    ndarray
        Relative scale-factor change [1].

    References
    ----------
    IEEE Std 1293 model equation (docs/physics.md §1.7, §2.5).
    """
    dT = np.asarray(die_c, float) - reference_c
    return (tc1_ppm_per_c * dT + tc2_ppm_per_c2 * dT * dT) * 1e-6


def lowpass(x: np.ndarray, dt_s: float, tau_s: float) -> np.ndarray:
    """Causal first-order low-pass LP_τ(x) on a uniform time base.

    Exact for piecewise-linear x, starting in equilibrium at x[0]. ``tau_s = 0`` returns x. (Same
    discretisation as the thermal chain, :func:`sim.thermal.first_order_lag`.)

    Parameters
    ----------
    x : ndarray
        Input samples [any unit].
    dt_s : float
        Sample interval [s].
    tau_s : float
        Time constant τ [s], ≥ 0.

    Returns
    -------
    ndarray
        LP_τ(x) [unit of x].

    References
    ----------
    Standard first-order lag τ dy/dt = x − y, discretised exactly with a first-order hold (see any
    control or digital signal processing text).
    """
    from sim.thermal import first_order_lag

    return first_order_lag(np.asarray(x, float), dt_s, tau_s)


def maxwell_relaxation(delta_c: np.ndarray, dt_s: float, tau_s: float) -> np.ndarray:
    """Viscoelastic (Maxwell) stress state ΔT − LP_τ(ΔT) [°C].

    Follows fast changes, relaxes to zero over τ at constant temperature (docs/diagnosis.md §2c;
    Prony sums add several terms).

    Parameters
    ----------
    delta_c : ndarray
        Temperature change ΔT [°C].
    dt_s : float
        Sample interval [s].
    tau_s : float
        Relaxation time τ [s].

    Returns
    -------
    ndarray
        ΔT − LP_τ(ΔT) [°C].

    References
    ----------
    Maxwell element (spring and dashpot in series), docs/diagnosis.md §2c; standard viscoelastic
    model.
    """
    d = np.asarray(delta_c, float)
    return d - lowpass(d, dt_s, tau_s)


def smoothed_rate_c_per_s(temperature_c: np.ndarray, dt_s: float, tau_s: float) -> np.ndarray:
    """Rate of change seen through a first-order node: d/dt LP_τ(T) = (T − LP_τ(T)) / τ [°C/s].

    Causal, and needs no numerical differentiation of a noisy signal (docs/diagnosis.md §2i).

    Parameters
    ----------
    temperature_c : ndarray
        Temperature [°C].
    dt_s : float
        Sample interval [s].
    tau_s : float
        Time constant τ [s], > 0.

    Returns
    -------
    ndarray
        d/dt LP_τ(T) [°C/s].

    References
    ----------
    Follows from the first-order lag τ dy/dt = T − y (standard result); docs/diagnosis.md §2i.
    """
    t = np.asarray(temperature_c, float)
    return (t - lowpass(t, dt_s, tau_s)) / tau_s


def warmup_shape(time_since_power_on_s: np.ndarray, tau_s: float) -> np.ndarray:
    """Warm-up transient exp(−t_on/τ) after each power-on [1] (docs/diagnosis.md §2g).

    Parameters
    ----------
    time_since_power_on_s : ndarray
        Time since the last power-on t_on [s].
    tau_s : float
        Warm-up time constant τ [s].

    Returns
    -------
    ndarray
        exp(−t_on/τ) [1].

    References
    ----------
    Exponential settling, the form of docs/diagnosis.md §2g (a modelling choice, no further
    source).
    """
    return np.exp(-np.asarray(time_since_power_on_s, float) / tau_s)


def lowpass_at(time_s: np.ndarray, x: np.ndarray, tau_s: float) -> np.ndarray:
    """Causal first-order low-pass LP_τ(x) at the given sample times, whose steps may vary.

    Exact for piecewise-linear x (first-order hold), from equilibrium at x[0]: over a step of
    h = Δt/τ, y_n = e·y_{n−1} + b0·x_n + b1·x_{n−1} with e = exp(−h), b0 = 1 − (1 − e)/h,
    b1 = (1 − e)/h − e — the discretisation of :func:`lowpass`, with its coefficients per step
    (a logger's clock jitters: a uniform-step filter on it is wrong by the jitter). Run as
    y_n = y_{n−1} + b0·(x_n − y_{n−1}) + b1·(x_{n−1} − y_{n−1}), so the DC gain is exactly 1.

    Parameters
    ----------
    time_s : ndarray
        Sample times [s], non-decreasing.
    x : ndarray
        Input samples [any unit].
    tau_s : float
        Time constant τ [s], ≥ 0.

    Returns
    -------
    ndarray
        LP_τ(x) [unit of x].

    References
    ----------
    Standard first-order lag with a first-order-hold (ramp-invariant) discretisation; see any
    digital control text.
    """
    t = np.asarray(time_s, float)
    x = np.asarray(x, float)
    if tau_s < 0:
        raise ValueError(f"tau_s must be >= 0, got {tau_s}")
    if tau_s == 0 or x.size < 2:
        return x.copy()
    b0, b1 = _foh_coefficients(np.diff(t) / tau_s)
    out = np.empty_like(x)
    kernel = _lag_kernel() if (_LAG_KERNEL or x.size >= LAG_COMPILED_MIN_SIZE) else None
    if kernel is None:
        y = x[0]
        out[0] = y
        for k in range(1, x.size):
            y = y + b0[k - 1] * (x[k] - y) + b1[k - 1] * (x[k - 1] - y)
            out[k] = y
        return out
    kernel(np.ascontiguousarray(x), b0, b1, out)
    return out


def _foh_coefficients(h: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(b0, b1) of the first-order hold per step h = Δt/τ ≥ 0 (h = 0: the lag does not move).

    b0 = (h − 1 + e^{−h})/h cancels for small h, so there it is the series
    Σ_{k≥2} (−1)^k h^{k−1}/k! (16 terms: truncation < 1e-17 relative for h < 0.5).
    """
    h = np.asarray(h, float)
    with np.errstate(divide="ignore", invalid="ignore"):
        q = np.where(h > 0, -np.expm1(-h) / h, 1.0)  # (1 − e)/h, → 1 as h → 0
    b0 = 1.0 - q
    small = h < 0.5
    if np.any(small):
        hs = h[small]
        series = np.zeros_like(hs)
        for k in range(17, 1, -1):  # Horner on Σ (−1)^k h^{k−1}/k!
            series = series * hs + (-1.0) ** k / math.factorial(k)
        b0[small] = series * hs
    b1 = q - np.exp(-h)
    return b0, b1


LAG_COMPILED_MIN_SIZE = 2_000  # below, a Python loop beats loading the compiled kernel
_LAG_KERNEL: list = []


def _lag_kernel():
    """The numba kernel of the variable-step lag recursion, or None (no numba, TDE_TWIN_NO_NUMBA=1)."""
    if not _LAG_KERNEL:
        _LAG_KERNEL.append(_compile_lag())
    return _LAG_KERNEL[0]


def _compile_lag():
    jit = compiled.njit()
    if jit is None:  # the Python loop gives the same output, slower
        return None

    @jit
    def lag_loop(x, b0, b1, out):  # pragma: no cover - compiled
        y = x[0]
        out[0] = y
        for k in range(1, x.size):
            y = y + b0[k - 1] * (x[k] - y) + b1[k - 1] * (x[k - 1] - y)
            out[k] = y

    return lag_loop
