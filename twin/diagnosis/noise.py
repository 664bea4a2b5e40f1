"""Noise model for the diagnosis: block averaging, AR(p) by Yule–Walker, prewhitening, noise floor.

The IIS328DQ residual carries slow correlated noise (bias instability), so every test statistic
is computed on prewhitened data (docs/diagnosis.md §0, §1 step 3): AR(p) with p chosen by BIC up
to 20, prewhitening per run *without dropping the first samples* (power-on transients live there).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from scipy.signal import lfilter

from twin.arrays import run_slices


@dataclass
class BlockAverager:
    """Means over blocks of ``k`` samples inside each run (a partial last block is kept)."""

    starts: np.ndarray  # first sample of each block
    lengths: np.ndarray
    run_of_block: np.ndarray

    @classmethod
    def build(cls, run_index: np.ndarray, k: int) -> BlockAverager:
        k = max(1, int(k))
        run_index = np.asarray(run_index)
        starts = np.concatenate([np.arange(s.start, s.stop, k) for s in run_slices(run_index)])
        ends = np.r_[starts[1:], run_index.size]
        return cls(starts, ends - starts, run_index[starts])

    def __call__(self, x: np.ndarray) -> np.ndarray:
        x = np.asarray(x, float)
        sums = np.add.reduceat(x, self.starts, axis=0)
        return sums / (self.lengths if x.ndim == 1 else self.lengths[:, None])


@dataclass
class ARModel:
    """x[t] = Σ a_i x[t−i] + e[t], e white with variance ``sigma2``.

    ``partial`` holds the Levinson–Durbin predictors of orders 0..p−1 with their error variances,
    used for the first samples of each run.
    """

    coefficients: np.ndarray
    sigma2: float
    partial: list[tuple[np.ndarray, float]] = field(default_factory=list)

    @property
    def order(self) -> int:
        return int(self.coefficients.size)

    def prewhiten(self, x: np.ndarray, run_index: np.ndarray) -> np.ndarray:
        """Exact AR(p) whitening, run by run, keeping every sample (innovations algorithm).

        From sample p on: e = x − Σ a_i x[t−i]. The first p samples of a run have fewer past
        values: sample t is predicted with the order-t predictor and its error scaled by
        √(σ²_p / σ²_t), so all outputs share one variance. Zero-initialised filtering would leave
        those samples with the full process variance, and a regressor concentrated at run starts
        (a power-on transient) would look significant in pure noise.
        """
        b = np.r_[1.0, -self.coefficients]
        x = np.asarray(x, float)
        out = np.empty_like(x)
        for run in run_slices(run_index):
            a, z = run.start, run.stop
            seg = x[a:z]
            out[a:z] = lfilter(b, [1.0], seg, axis=0)
            for t, (coef, s2) in enumerate(self.partial[: z - a]):
                pred = np.tensordot(coef, seg[t - 1 :: -1][: t], axes=(0, 0)) if t else 0.0
                out[a + t] = (seg[t] - pred) * np.sqrt(self.sigma2 / s2)
        return out


def _autocovariance(x: np.ndarray, run_index: np.ndarray, max_lag: int) -> np.ndarray:
    """Pooled autocovariance over runs (each run demeaned), lags 0..max_lag."""
    acov = np.zeros(max_lag + 1)
    n_total = 0
    for run in run_slices(run_index):
        seg = x[run] - x[run].mean()
        n = seg.size
        if n <= max_lag + 1:
            continue
        f = np.fft.rfft(seg, 2 ** int(np.ceil(np.log2(2 * n))))
        acov += np.fft.irfft(f * np.conj(f))[: max_lag + 1]
        n_total += n
    return acov / max(n_total, 1)


def fit_ar(x: np.ndarray, run_index: np.ndarray, max_order: int = 20) -> ARModel:
    """Yule–Walker AR fit with the order chosen by BIC (n ln σ²_p + p ln n).

    Levinson–Durbin gives the coefficients and innovation variance of every order in one pass
    (Brockwell & Davis, *Time Series: Theory and Methods*, §5.2).
    """
    x = np.asarray(x, float)
    n = x.size
    max_order = int(min(max_order, max(0, n // 10)))
    acov = _autocovariance(x, run_index, max_order)
    if acov[0] <= 0:
        return ARModel(np.zeros(0), float(acov[0]))
    best, best_bic = ARModel(np.zeros(0), float(acov[0])), n * np.log(acov[0])
    a = np.zeros(0)
    s2 = float(acov[0])
    partial = [(a.copy(), s2)]  # order-0 predictor: the mean (zero), error variance = variance
    for p in range(1, max_order + 1):
        k = (acov[p] - a @ acov[p - 1 : 0 : -1]) / s2 if p > 1 else acov[1] / s2
        if abs(k) >= 1:
            break
        a = np.r_[a - k * a[::-1], k]
        s2 *= 1.0 - k * k
        if s2 <= 0:
            break
        bic = n * np.log(s2) + p * np.log(n)
        if bic < best_bic:
            best, best_bic = ARModel(a.copy(), float(s2), list(partial)), bic
        partial.append((a.copy(), s2))
    return best


#: walk filter parameters tried: θ ≈ 1 − √q for a walk-to-white variance ratio q per block
WALK_THETAS = (1.0, 0.995, 0.99, 0.98, 0.96, 0.93, 0.9, 0.85, 0.8, 0.7)


def walk_filter(x: np.ndarray, run_index: np.ndarray, theta: float) -> np.ndarray:
    """(1 − B)/(1 − θB) per run: whitens white noise plus a random walk (the local-level model,
    an ARIMA(0,1,1); Harvey, *Forecasting, Structural Time Series Models and the Kalman Filter*,
    §2.3.2). θ = 1 is the identity; a unit lower-triangular map, so it leaves the likelihood's
    determinant alone and models with different θ compare by their residuals."""
    x = np.asarray(x, float)
    if theta >= 1.0:
        return x
    out = np.empty_like(x)
    for run in run_slices(run_index):
        out[run] = lfilter([1.0, -1.0], [1.0, -theta], x[run], axis=0)
    return out


@dataclass
class WalkARModel:
    """Noise = random walk + AR(p): the walk filter with ``theta`` (1: no walk), then ``ar``."""

    theta: float
    ar: ARModel

    def prewhiten(self, x: np.ndarray, run_index: np.ndarray) -> np.ndarray:
        return self.ar.prewhiten(walk_filter(x, run_index, self.theta), run_index)


def fit_walk_ar(A: np.ndarray, y: np.ndarray, run_index: np.ndarray, max_order: int = 20) -> WalkARModel:
    """The walk + AR noise model of ``y`` about the regression on ``A``, θ chosen by restricted
    (REML) likelihood with a BIC penalty on the walk and the AR order.

    The restricted likelihood counts the regressors' own log det(AᵀΣ⁻¹A) (Harville, *JASA* 72,
    1977, §4), so a trend in ``A`` does not hide the walk that looks like it: a plain likelihood of
    the residual after fitting the trend underestimates the walk exactly when it drifts one way.
    """
    A = np.asarray(A, float).reshape(len(y), -1)
    r_ols = y - A @ np.linalg.lstsq(A, y, rcond=None)[0]
    n, k = A.shape
    best, best_crit = None, np.inf
    for theta in WALK_THETAS:
        ar = fit_ar(walk_filter(r_ols, run_index, theta), run_index, max_order)
        model = WalkARModel(theta, ar)
        Aw, yw = model.prewhiten(A, run_index), model.prewhiten(y, run_index)
        rss = float(np.sum((yw - Aw @ np.linalg.lstsq(Aw, yw, rcond=None)[0]) ** 2))
        sign, logdet = np.linalg.slogdet(Aw.T @ Aw)
        if rss <= 0 or sign <= 0:
            continue
        # the first p innovations of each run have their own variances (ARModel.prewhiten rescales them)
        head = sum(np.log(s2 / ar.sigma2) for run in run_slices(run_index)
                   for _, s2 in ar.partial[: run.stop - run.start]) if ar.sigma2 > 0 else 0.0
        crit = (n - k) * np.log(rss / (n - k)) + head + logdet + (ar.order + (theta < 1)) * np.log(n)
        if crit < best_crit:
            best, best_crit = model, crit
    return best if best is not None else WalkARModel(1.0, fit_ar(r_ols, run_index, max_order))


def white_noise_sigma_from_differences(r: np.ndarray, run_index: np.ndarray) -> float:
    """σ of the white part of a residual from its first differences: √(mean(Δr²)/2).

    Slow structure barely changes between neighbouring samples, so this is the sample-rate noise
    floor of the data (white + quantisation), robust to the drift still in the residual. Differences
    beyond 8 robust σ (spikes, steps) are trimmed; a plain MAD would be biased by quantised values.
    """
    d = np.diff(np.asarray(r, float))
    return white_sigma_of_differences(d[np.diff(np.asarray(run_index)) == 0])


def white_sigma_of_differences(d: np.ndarray) -> float:
    """√(mean(d²)/2) of first differences ``d`` inside runs, beyond 8 robust σ trimmed (see
    :func:`white_noise_sigma_from_differences`)."""
    if d.size == 0:
        return 0.0
    scale = np.percentile(np.abs(d), 75) / 0.6745 or np.std(d)
    d = d[np.abs(d) <= 8 * scale] if scale > 0 else d
    return float(np.sqrt(np.mean(d * d) / 2.0))


def allan_deviation(x: np.ndarray, rate_hz: float, n_taus: int = 30):
    """Overlapping Allan deviation (IEEE 952 / NIST SP 1065) on a log grid of averaging times."""
    from sim.sensor import allan_deviation as _adev

    n = len(x)
    taus = np.unique(np.logspace(0, np.log10(max(2, n // 8)), n_taus).astype(int)) / rate_hz
    return _adev(x, rate_hz, taus)
