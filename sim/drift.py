"""Minimal drift law: bias and scale factor against die temperature (TCOff, TCSo).

IEEE Std 1293 model-equation form (physics-notes §1.7, §2.5):
``a_out = (1 + s1·ΔT + s2·ΔT²)·a_in + b1·ΔT + b2·ΔT²`` with ΔT = T_die − T_ref.
The effect library wraps these kernels; they stay pure functions of arrays.
"""

from __future__ import annotations

import numpy as np


def bias_tc_g(
    die_c: np.ndarray, tc1_mg_per_c: float, tc2_mg_per_c2: float = 0.0, reference_c: float = 25.0
) -> np.ndarray:
    """Zero-g level change [g]: b1·ΔT + b2·ΔT² (TCOff; the paper's ±0.8 mg/°C, unverified)."""
    dT = np.asarray(die_c, float) - reference_c
    return (tc1_mg_per_c * dT + tc2_mg_per_c2 * dT * dT) * 1e-3


def scale_factor_tc(
    die_c: np.ndarray, tc1_ppm_per_c: float, tc2_ppm_per_c2: float = 0.0, reference_c: float = 25.0
) -> np.ndarray:
    """Relative sensitivity change [1]: s1·ΔT + s2·ΔT² (TCSo; 0.01 %/°C = 100 ppm/°C, recalled).

    The output's drift is this times the applied acceleration.
    """
    dT = np.asarray(die_c, float) - reference_c
    return (tc1_ppm_per_c * dT + tc2_ppm_per_c2 * dT * dT) * 1e-6


def lowpass(x: np.ndarray, dt_s: float, tau_s: float) -> np.ndarray:
    """Causal first-order low-pass LP_τ(x), exact for piecewise-linear x, starting in equilibrium
    at x[0]. ``tau_s = 0`` returns x. (Same discretisation as the thermal chain.)"""
    from sim.thermal import first_order_lag

    return first_order_lag(np.asarray(x, float), dt_s, tau_s)


def maxwell_relaxation(delta_c: np.ndarray, dt_s: float, tau_s: float) -> np.ndarray:
    """Viscoelastic (Maxwell) stress state ΔT − LP_τ(ΔT) [°C]: follows fast changes, relaxes to
    zero over τ at constant temperature (diagnosis-methods §2c; Prony sums add several terms)."""
    d = np.asarray(delta_c, float)
    return d - lowpass(d, dt_s, tau_s)


def smoothed_rate_c_per_s(temperature_c: np.ndarray, dt_s: float, tau_s: float) -> np.ndarray:
    """Rate of change seen through a first-order node: d/dt LP_τ(T) = (T − LP_τ(T)) / τ [°C/s].

    Causal, and needs no numerical differentiation of a noisy signal (diagnosis-methods §2i).
    """
    t = np.asarray(temperature_c, float)
    return (t - lowpass(t, dt_s, tau_s)) / tau_s


def play_operator(x: np.ndarray, half_width: float, initial: float | None = None) -> np.ndarray:
    """Play (backlash) operator: p[k] = clamp(p[k−1], x[k] − r, x[k] + r), p[−1] = ``initial``.

    Rate-independent memory of the input path (Krasnosel'skii & Pokrovskii 1989; the elementary
    hysteron of the Prandtl–Ishlinskii model). Each step is a clamp, clamps compose into clamps,
    and composition is associative, so a log-step parallel prefix scan replaces the recursion:
    about log2(N) vectorised passes, no Python loop per sample.
    """
    x = np.asarray(x, float)
    if x.size == 0:
        return x.copy()
    r = float(half_width)
    if r < 0:
        raise ValueError(f"half_width must be >= 0, got {r}")
    lo, hi = x - r, x + r  # clamp interval of step k
    shift = 1
    while shift < x.size:
        # compose step k (later) with the accumulated map ending at k − shift (earlier);
        # the right-hand sides are evaluated before the in-place assignment.
        l_lo, l_hi = lo[shift:], hi[shift:]
        new_lo = np.minimum(np.maximum(lo[:-shift], l_lo), l_hi)
        hi[shift:] = np.minimum(np.maximum(hi[:-shift], l_lo), l_hi)
        lo[shift:] = new_lo
        shift *= 2
    p0 = x[0] if initial is None else float(initial)
    return np.minimum(np.maximum(p0, lo), hi)


def warmup_shape(time_since_power_on_s: np.ndarray, tau_s: float) -> np.ndarray:
    """exp(−t_on/τ): the transient after each power-on (diagnosis-methods §2g)."""
    return np.exp(-np.asarray(time_since_power_on_s, float) / tau_s)
