"""Static temperature compensators (polynomials in the thermometer reading), three axes at once.

Every calibration compensator is a scikit-learn regressor (:class:`CompensatorBase`): ``__init__``
only stores its arguments, ``fit(X, y, mask=None)`` returns ``self``, fitted attributes end in
``_``, and ``sklearn.base.clone`` gives an unfitted copy. ``X`` is (n, 2) ``[time_s,
temperature_c]`` (or (n, 3) with a run id, see :mod:`twin.calibration.lag`), ``y`` is ``accel_g``
(n, 3); ``mask`` selects the rows fitted on (the others still feed the lag filters of the
lag-aware model).

:class:`TemperaturePolynomial` is not :class:`fitting.PolynomialCompensator` (the paper's
benchmark): that one is one output in standardised features of any kind, its order chosen on
interleaved validation blocks; this one is three axes in ``T − reference_c`` alone, each axis'
degree chosen on contiguous held-out blocks, with AR(1)-inflated standard errors in mg/°C^k.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from sklearn.base import BaseEstimator, RegressorMixin
from sklearn.utils.validation import check_is_fitted

from twin.calibration.lag import fit_inputs, validated_log
from twin.calibration.polygram import SCALE_C, PolyGrams  # noqa: F401  (SCALE_C: the design's (ΔT / 10 °C)^k)

AXES = ("x", "y", "z")


@dataclass(frozen=True, eq=False)
class LinearFit:
    """Least squares of one axis: coefficients, standard errors, residual statistics.

    ``stderr`` is inflated by the AR(1) factor √((1 + ρ)/(1 − ρ)) of the residual's lag-1
    autocorrelation ρ, because residuals of real logs are not white.

    Attributes
    ----------
    coef, stderr : (p,) ndarray
        Coefficients and their standard errors [units of ``y`` per design column].
    cov : (p, p) ndarray
        Covariance of ``coef``.
    sse : float
        Residual sum of squares [units of ``y`` squared].
    rho : float
        Lag-1 autocorrelation of the residual (clipped to [0, 0.95]).
    n : int
        Rows fitted.
    """

    coef: np.ndarray
    stderr: np.ndarray
    cov: np.ndarray
    sse: float
    rho: float
    n: int


def ols(F: np.ndarray, y: np.ndarray) -> LinearFit:
    """Ordinary least squares ``y ≈ F·c`` with AR(1)-inflated standard errors.

    Parameters
    ----------
    F : (n, p) ndarray
        Design matrix.
    y : (n,) ndarray
        Observations (one axis).

    Returns
    -------
    LinearFit
        Coefficients, standard errors and residual statistics.
    """
    coef, *_ = np.linalg.lstsq(F, y, rcond=None)
    r = y - F @ coef
    n, p = F.shape
    sse = float(r @ r)
    rho = float(np.clip((r[1:] @ r[:-1]) / max(sse, 1e-300), 0.0, 0.95))
    sigma2 = sse / max(n - p, 1) * (1 + rho) / (1 - rho)
    cov = sigma2 * np.linalg.pinv(F.T @ F)
    return LinearFit(coef, np.sqrt(np.diag(cov)), cov, sse, rho, n)


def poly_columns(delta_c: np.ndarray, degree: int, out: np.ndarray | None = None) -> np.ndarray:
    """Design columns ``(ΔT / 10 °C)^k``, k = 0…degree.

    The powers are built one column at a time, each the previous times ΔT/10 (bit for bit
    ``np.vander(ΔT / 10, degree + 1, increasing=True)``), in column-major order: a fraction of
    vander's time at millions of rows.

    Parameters
    ----------
    delta_c : ndarray
        Temperature minus the reference [°C], (n,).
    degree : int
        Highest power.
    out : (≥ degree + 1, n) ndarray, optional
        Filled in its first degree + 1 rows (a caller adding columns of its own below them).

    Returns
    -------
    (n, degree + 1) ndarray
        The scaled powers [dimensionless] (a view of ``out`` transposed when given).
    """
    x = np.asarray(delta_c, float)
    cols = np.empty((degree + 1, x.size)) if out is None else out[: degree + 1]
    cols[0] = 1.0
    if degree >= 1:
        np.divide(x, SCALE_C, out=cols[1])
    for k in range(2, degree + 1):
        np.multiply(cols[k - 1], cols[1], out=cols[k])
    return cols.T


def to_mg_per_c(coef_scaled_g: np.ndarray) -> np.ndarray:
    """Coefficients of :func:`poly_columns` [g] → mg/°C^k.

    Parameters
    ----------
    coef_scaled_g : ndarray
        Coefficients of the scaled columns [g], powers along the last axis.

    Returns
    -------
    ndarray
        The same coefficients [mg/°C^k].
    """
    k = np.arange(coef_scaled_g.shape[-1])
    return coef_scaled_g * 1e3 / SCALE_C**k


def poly_text(coef_mg: np.ndarray, variable: str) -> str:
    """``a0 + a1·(v) + a2·(v)² …`` with values and units [mg].

    Parameters
    ----------
    coef_mg : ndarray
        Coefficients a_k [mg/°C^k], k = 0…degree.
    variable : str
        Text of the variable, e.g. ``"T − 35 °C"``.

    Returns
    -------
    str
        The polynomial as text.
    """
    sup = {2: "²", 3: "³"}
    terms = [f"{coef_mg[0]:+.4g} mg"]
    for k, c in enumerate(coef_mg[1:], start=1):
        power = sup.get(k, f"^{k}") if k > 1 else ""
        unit = "mg/°C" + (sup.get(k, f"^{k}") if k > 1 else "")
        terms.append(f"{c:+.4g} {unit}·({variable}){power}")
    return " ".join(terms)


class CompensatorBase(RegressorMixin, BaseEstimator):
    """A scikit-learn regressor of the three axes' readings from a thermal log, and its compensation step.

    ``get_params``, ``set_params`` and cloning come from ``BaseEstimator``; ``score`` (R² over the
    three axes) from ``RegressorMixin``.
    """

    rate_dependent = False  # thermal state (a lag, a rate term): validated only by two-direction folds
    row_by_row = False  # a prediction from each row's temperature alone: any subset of rows predicts alike

    def __sklearn_tags__(self):
        tags = super().__sklearn_tags__()
        # three axes at once: y is (n, 3) and the prediction (n, 3), never a single column
        tags.target_tags.multi_output = True
        tags.target_tags.single_output = False
        return tags

    def compensate(self, X, accel_g: np.ndarray) -> np.ndarray:
        """``accel_g`` with the modelled thermal drift removed, keeping the level at the reference.

        Parameters
        ----------
        X : array-like, (n, 2) or (n, 3)
            ``[time_s, temperature_c]`` [s, °C], optionally with a run id.
        accel_g : (n, 3) ndarray
            Readings [g].

        Returns
        -------
        (n, 3) ndarray
            Compensated readings [g].
        """
        check_is_fitted(self)
        level = self.coef_mg_[:, 0] * 1e-3
        return np.asarray(accel_g, float) - (self.predict(X) - level)


class TemperaturePolynomial(CompensatorBase):
    """Per-axis polynomial in ``T − reference_c``; degree chosen on held-out blocks of the training rows.

    Parameters
    ----------
    max_degree : int
        Highest degree tried (degrees 1…max_degree; fixed when ``degree`` is given).
    reference_c : float
        Expansion point [°C].
    n_blocks : int
        Contiguous blocks of the training rows for leave-one-block-out selection; contiguous
        (not interleaved) because neighbouring samples share slow errors.
    degree : int, optional
        Fixed degree for all axes (no selection).

    Attributes
    ----------
    n_features_in_ : int
        Columns of ``X`` seen in ``fit`` (2, or 3 with a run id).
    degree_ : (3,) int array
    coef_mg_ : (3, max degree + 1) array
        a_k [mg/°C^k] about ``reference_c`` (zero-padded above an axis' degree).
    coef_se_mg_ : (3, max degree + 1) array
        Standard errors of ``coef_mg_``.
    cv_rms_mg_ : (3, max_degree) array
        Held-out RMS [mg] per axis and degree (NaN when not selected).
    """

    row_by_row = True

    def __init__(self, max_degree: int = 7, reference_c: float = 35.0, n_blocks: int = 5,
                 degree: int | None = None):
        self.max_degree = max_degree
        self.reference_c = reference_c
        self.n_blocks = n_blocks
        self.degree = degree

    def fit(self, X, y, mask=None):
        """Fit on the rows of ``mask`` (default: all rows with finite ``y``). Returns self.

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
        TemperaturePolynomial
            ``self``, fitted.
        """
        log, y, keep = fit_inputs(self, X, y, mask)
        dT, Y = log.temperature_c[keep] - self.reference_c, y[keep]
        top = self.degree if self.degree is not None else self.max_degree
        cv = np.full((3, top), np.nan)
        # every block of the training rows reduced once (twin.calibration.polygram): each degree
        # and each block left out is then a small solve
        n, nb = dT.size, self.n_blocks if self.degree is None else 1  # np.array_split's blocks
        grams = PolyGrams(dT, Y, top, np.cumsum([0] + [n // nb + 1] * (n % nb) + [n // nb] * (nb - n % nb)))
        if self.degree is None:
            for d in range(1, top + 1):
                cv[:, d - 1] = np.sqrt(grams.held_out_sse(d) / n) * 1e3
            self.degree_ = np.nanargmin(cv, axis=1) + 1
        else:
            self.degree_ = np.full(3, int(self.degree))
        self._fit_degrees(dT, Y, grams)
        self.cv_rms_mg_ = cv
        return self

    def _fit_degrees(self, dT: np.ndarray, Y: np.ndarray, grams: PolyGrams | None = None) -> None:
        width = int(self.degree_.max())
        self.coef_mg_ = np.zeros((3, width + 1))
        self.coef_se_mg_ = np.zeros((3, width + 1))
        grams = grams or PolyGrams(dT, Y, width, [0, dT.size])
        for i, (coef, stderr) in enumerate(grams.fit(self.degree_)):
            d = int(self.degree_[i])
            self.coef_mg_[i, : d + 1] = to_mg_per_c(coef)
            self.coef_se_mg_[i, : d + 1] = to_mg_per_c(stderr)

    def predict(self, X) -> np.ndarray:
        """Modelled reading [g], (n, 3).

        Parameters
        ----------
        X : array-like, (n, 2) or (n, 3)
            ``[time_s, temperature_c]`` [s, °C], optionally with a run id.

        Returns
        -------
        (n, 3) ndarray
            Modelled reading [g].
        """
        dT = validated_log(self, X, reset=False).temperature_c - self.reference_c
        powers = np.empty((self.coef_mg_.shape[1], dT.size))  # np.vander's columns, built column-major
        powers[0] = 1.0
        if powers.shape[0] > 1:
            powers[1] = dT
        for k in range(2, powers.shape[0]):
            np.multiply(powers[k - 1], dT, out=powers[k])
        return powers.T @ self.coef_mg_.T * 1e-3

    def equation(self) -> str:
        """The fitted polynomials with values and units, one line per axis.

        Returns
        -------
        str
            One line per axis, coefficients in mg/°C^k.
        """
        check_is_fitted(self)
        return "\n".join(
            f"{ax}: {poly_text(self.coef_mg_[i, : d + 1], f'T − {self.reference_c:g} °C')}"
            for i, (ax, d) in enumerate(zip(AXES, self.degree_)))


class CubicCompensator(TemperaturePolynomial):
    """The PX4 method: a cubic in ``T − reference_c`` per axis (no selection).

    Parameters
    ----------
    reference_c : float
        Expansion point [°C].
    """

    def __init__(self, reference_c: float = 35.0):
        self.reference_c = reference_c

    def fit(self, X, y, mask=None):
        """Fit the three cubics. Returns self.

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
        CubicCompensator
            ``self``, fitted.
        """
        log, y, keep = fit_inputs(self, X, y, mask)
        self.degree_ = np.full(3, 3)
        self.cv_rms_mg_ = np.full((3, 3), np.nan)
        self._fit_degrees(log.temperature_c[keep] - self.reference_c, y[keep])
        return self
