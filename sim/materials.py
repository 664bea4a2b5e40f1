"""Silicon: thermal expansion α(T), thermal strain ε(T), Young's modulus E(T).

References
----------
Okada & Tokumaru, J. Appl. Phys. 56, 314 (1984): α(T) = (3.725·{1 − exp[−5.88e-3 (T − 124)]}
+ 5.548e-4·T) × 1e-6 /K, T in K, valid 120–1500 K, data scatter ±2e-7 /K.
Gysin et al., Phys. Rev. B 69, 045403 (2004), Wachtman form: E(T) = E0 − B·T·exp(−T0/T),
E0 = 167.5 GPa, B = 15.8 MPa/K, T0 = 317 K. docs/physics.md §1.2, §1.3, §2.4.
"""

from __future__ import annotations

import numpy as np

OKADA_VALID_K = (120.0, 1500.0)
_A1, _C, _T1, _A2 = 3.725e-6, 5.88e-3, 124.0, 5.548e-10  # Okada & Tokumaru constants (per K)
GYSIN_E0_PA, GYSIN_B_PA_PER_K, GYSIN_T0_K = 167.5e9, 15.8e6, 317.0
KELVIN = 273.15


def _check_range(temperature_k: np.ndarray) -> np.ndarray:
    t = np.asarray(temperature_k, float)
    lo, hi = OKADA_VALID_K
    if np.any(t < lo) or np.any(t > hi) or not np.all(np.isfinite(t)):
        bad = t[(t < lo) | (t > hi) | ~np.isfinite(t)].ravel()[0]
        raise ValueError(f"silicon CTE (Okada & Tokumaru 1984) is valid for {lo:g}-{hi:g} K; got {bad:g} K")
    return t


def silicon_cte_per_k(temperature_k: np.ndarray | float) -> np.ndarray:
    """Linear thermal-expansion coefficient α(T) of silicon [1/K].

    α(293.15 K) = 2.510e-6, α(323 K) = 2.749e-6 (not the paper's 2.5e-6).

    Parameters
    ----------
    temperature_k : float or ndarray
        Temperature [K], within 120–1500 K.

    Returns
    -------
    ndarray
        α(T) [1/K].

    Raises
    ------
    ValueError
        A temperature outside 120–1500 K or not finite.

    References
    ----------
    Okada & Tokumaru, J. Appl. Phys. 56, 314 (1984).
    """
    t = _check_range(temperature_k)
    return _A1 * (1.0 - np.exp(-_C * (t - _T1))) + _A2 * t


def _cte_antiderivative(t: np.ndarray) -> np.ndarray:
    return _A1 * (t + np.exp(-_C * (t - _T1)) / _C) + 0.5 * _A2 * t * t


def silicon_thermal_strain(temperature_k: np.ndarray | float, reference_k: float = 298.15) -> np.ndarray:
    """Thermal strain ε(T) = ∫_{T_ref}^{T} α dT′ [1], exact integral of the Okada formula.

    ε(−20 °C) = −1.056e-4 and ε(50 °C) = +6.63e-5 relative to 25 °C (docs/physics.md §1.2).

    Parameters
    ----------
    temperature_k : float or ndarray
        Temperature [K], within 120–1500 K.
    reference_k : float
        Strain-free reference temperature [K].

    Returns
    -------
    ndarray
        Thermal strain ε [1].

    References
    ----------
    Okada & Tokumaru, J. Appl. Phys. 56, 314 (1984), integrated analytically.
    """
    t = _check_range(temperature_k)
    _check_range(reference_k)
    return _cte_antiderivative(t) - _cte_antiderivative(np.asarray(reference_k, float))


def cte_polynomial_orders(
    t_low_k: float = 240.0, t_high_k: float = 340.0, step_k: float = 1.0, orders=range(1, 7)
) -> list[dict]:
    """Least-squares polynomial fits of α(T) over a range: RMSE and maximum error per order.

    Reproduces the paper's Figure 3 (240–340 K). The order-2 RMSE is ≈ 9.3e-10 /K on a 1 K grid;
    the paper's 2.39e-9 /K is the quadratic's maximum error (docs/physics.md §2.4).

    Parameters
    ----------
    t_low_k, t_high_k : float
        Temperature range of the fit [K].
    step_k : float
        Grid step [K].
    orders : iterable of int
        Polynomial orders to fit.

    Returns
    -------
    list of dict
        Per order: ``order``, ``rmse_per_k`` [1/K] and ``max_abs_error_per_k`` [1/K].

    References
    ----------
    Qi et al. (2022), Micromachines 13, 2156, Fig. 3; α(T) of Okada & Tokumaru (1984).
    """
    t = np.arange(t_low_k, t_high_k + step_k / 2, step_k)
    alpha = silicon_cte_per_k(t)
    x = (t - t.mean()) / (t.max() - t.min())  # centred and scaled: a well-conditioned fit
    rows = []
    for order in orders:
        coef = np.polynomial.polynomial.polyfit(x, alpha, order)
        err = np.polynomial.polynomial.polyval(x, coef) - alpha
        rows.append({"order": int(order), "rmse_per_k": float(np.sqrt(np.mean(err**2))),
                     "max_abs_error_per_k": float(np.max(np.abs(err)))})
    return rows


def silicon_youngs_modulus_pa(temperature_k: np.ndarray | float) -> np.ndarray:
    """Young's modulus E(T) [Pa], Wachtman form with the Gysin et al. (2004) parameters.

    E(T) = E0 − B·T·exp(−T0/T); E(25 °C) = 165.9 GPa; TCE₁ = −67.9 ppm/K there.

    Parameters
    ----------
    temperature_k : float or ndarray
        Temperature [K], > 0.

    Returns
    -------
    ndarray
        E(T) [Pa].

    References
    ----------
    Gysin et al., Phys. Rev. B 69, 045403 (2004) (Wachtman form).
    """
    t = np.asarray(temperature_k, float)
    if np.any(t <= 0):
        raise ValueError(f"temperature must be > 0 K, got {t.min():g} K")
    return GYSIN_E0_PA - GYSIN_B_PA_PER_K * t * np.exp(-GYSIN_T0_K / t)


def youngs_modulus_tc(temperature_k: float = 298.15) -> tuple[float, float]:
    """First and second temperature coefficients of E at T: (E′/E [1/K], E″/(2E) [1/K²]).

    Analytic derivatives of the Wachtman form; at 25 °C: −67.9 ppm/K and −62 ppb/K².

    Parameters
    ----------
    temperature_k : float
        Temperature [K].

    Returns
    -------
    tce1 : float
        E′/E [1/K].
    tce2 : float
        E″/(2E) [1/K²].

    References
    ----------
    Derivatives of the Wachtman form with the Gysin et al. (2004) parameters.
    """
    t = float(temperature_k)
    e = float(silicon_youngs_modulus_pa(t))
    x = np.exp(-GYSIN_T0_K / t)
    d1 = -GYSIN_B_PA_PER_K * x * (1.0 + GYSIN_T0_K / t)
    d2 = -GYSIN_B_PA_PER_K * x * GYSIN_T0_K**2 / t**3
    return d1 / e, d2 / (2.0 * e)
