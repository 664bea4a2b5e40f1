"""A polynomial in temperature whose order is chosen on held-out data (interleaved time blocks).

The firmware side is the same clamped polynomial PX4 applies (PX4/PX4-Autopilot
src/modules/temperature_compensation/TemperatureCompensation.cpp, ``calc_thermal_offsets_3D``,
there fixed at order 3); here the order is not fixed but picked by cross-validation, and the
result is exported through the JSON and C-header writers. PX4 parameters hold X0..X3 only:
``twin.firmware.px4_params.px4_cal_from_polynomial`` turns a fit of order ≤ 3 into ``TC_A``/``TC_G``
parameters and refuses a higher order rather than dropping its terms.

Folds (:func:`twin.arrays.interleaved_folds`, the project's one fold builder): the record is cut
into ``folds × blocks_per_fold`` contiguous time blocks and block b is held out in fold
``b % folds``. Contiguous blocks keep neighbouring, correlated samples together (random splits
would leak them); interleaving gives every fold the whole temperature programme.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from twin.arrays import interleaved_folds
from twin.firmware.common import (
    ClampedPolynomial,
    FirmwareCalError,
    as_samples,
    as_temperature,
)


@dataclass(frozen=True)
class HeldoutPolynomialFit:
    """Polynomial offset in (T − tref_c), order chosen on held-out blocks.

    Attributes
    ----------
    order : int
        Chosen order (one-standard-error rule on the held-out RMSE).
    coefficients : tuple of tuple of float
        ``coefficients[axis][k]`` in (unit of y)/°C^k, ascending powers of (T − tref_c); fitted on
        all data at the chosen order.
    tref_c, tmin_c, tmax_c : float
        Reference temperature (mid-range) and the fitted span (°C), used for clamping.
    cv_rmse : tuple of float
        Mean held-out RMSE for orders 0..max_order (unit of y).
    cv_rmse_se : tuple of float
        Standard error of that mean over the folds.
    folds, blocks_per_fold : int
        Cross-validation layout (module docstring).
    """

    order: int
    coefficients: tuple[tuple[float, ...], ...]
    tref_c: float
    tmin_c: float
    tmax_c: float
    cv_rmse: tuple[float, ...]
    cv_rmse_se: tuple[float, ...]
    folds: int
    blocks_per_fold: int

    @property
    def polynomial(self) -> ClampedPolynomial:
        """The fit as a clamped polynomial (clamped to the fitted temperature span)."""
        return ClampedPolynomial(self.tmin_c, self.tmax_c, self.tref_c, self.coefficients)

    def offset_m_s2(self, temperature_c) -> np.ndarray:
        """Predicted offset (n, n_axes), in the unit of the fitted y (m/s² for firmware export).

        Parameters
        ----------
        temperature_c : float or array_like
            Temperature [°C], clamped to the fitted span.

        Returns
        -------
        ndarray
            Offset [unit of y].
        """
        return self.polynomial.offset(temperature_c)


def _fit(dt: np.ndarray, y: np.ndarray, order: int) -> np.ndarray:
    """Least-squares coefficients (order + 1, k), ascending powers, on columns scaled to ±1."""
    scale = max(float(np.max(np.abs(dt))), 1e-12)
    vander = np.vander(dt / scale, order + 1, increasing=True)
    coef, *_ = np.linalg.lstsq(vander, y, rcond=None)
    return coef / (scale ** np.arange(order + 1))[:, None]


def fit_polynomial_heldout(time_s, temperature_c, y, *, max_order: int = 5, folds: int = 5,
                           blocks_per_fold: int = 4) -> HeldoutPolynomialFit:
    """Fit y(T) by a polynomial whose order (0..max_order) is chosen on held-out time blocks.

    Parameters
    ----------
    time_s : (n,) array
        Sample times (s); only their order matters.
    temperature_c : (n,) array
        Temperature driving the offset (°C).
    y : (n,) or (n, k) array
        Offset to model (e.g. raw − reference, m/s²), one column per axis.
    max_order : int
        Highest order tried.
    folds, blocks_per_fold : int
        Cross-validation layout (see module docstring).

    Returns
    -------
    HeldoutPolynomialFit
        Chosen order, coefficients [unit of y/°C^k], span [°C] and held-out RMSE [unit of y].

    Notes
    -----
    Each order is scored by the RMSE over all axes on each held-out fold; the chosen order is
    the lowest whose mean is within one standard error of the best (why: a higher order that
    wins by less than the fold-to-fold scatter is fitting noise). Reference: the order choice
    replaces the fixed cubic of PX4 Tools/process_sensor_caldata.py (repo PX4/PX4-Autopilot).
    """
    t = as_temperature(temperature_c)
    time = as_samples(time_s, t.size, "time_s", axes=None)
    yy = as_samples(y, t.size, "y", axes=None)
    y2 = yy.reshape(t.size, -1)
    if folds < 2 or blocks_per_fold < 1 or max_order < 0:
        raise FirmwareCalError(f"need folds ≥ 2, blocks_per_fold ≥ 1, max_order ≥ 0; got {folds}, "
                               f"{blocks_per_fold}, {max_order}")
    if t.size < folds * blocks_per_fold * (max_order + 2):
        raise FirmwareCalError(f"{t.size} samples are too few for {folds}×{blocks_per_fold} blocks "
                               f"at order {max_order}")
    tmin, tmax = float(np.min(t)), float(np.max(t))
    if not tmax > tmin:
        raise FirmwareCalError(f"temperature_c is constant ({tmin:g} °C); nothing to fit")
    tref = 0.5 * (tmin + tmax)
    dt = t - tref
    fold = interleaved_folds(time, folds, blocks_per_fold)
    rmse = np.empty((max_order + 1, folds))
    for order in range(max_order + 1):
        for f in range(folds):
            test = fold == f
            coef = _fit(dt[~test], y2[~test], order)
            pred = np.vander(dt[test], order + 1, increasing=True) @ coef
            rmse[order, f] = float(np.sqrt(np.mean((pred - y2[test]) ** 2)))
    mean = rmse.mean(axis=1)
    se = rmse.std(axis=1, ddof=1) / np.sqrt(folds)
    best = int(np.argmin(mean))
    chosen = int(np.flatnonzero(mean <= mean[best] + se[best])[0])
    coef = _fit(dt, y2, chosen)
    return HeldoutPolynomialFit(chosen, tuple(tuple(float(c) for c in coef[:, a]) for a in range(coef.shape[1])),
                                tref, tmin, tmax, tuple(float(m) for m in mean), tuple(float(s) for s in se),
                                int(folds), int(blocks_per_fold))
