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
