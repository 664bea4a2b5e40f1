"""Noise model for the diagnosis: block averaging, AR(p) by Yule–Walker, prewhitening, noise floor.

The IIS328DQ residual carries slow correlated noise (bias instability), so every test statistic
is computed on prewhitened data (docs/diagnosis.md §0, §1 step 3): AR(p) with p chosen by BIC up
to 20, prewhitening per run *without dropping the first samples* (power-on transients live there).
"""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass, field

import numpy as np

from sim.recursion import first_order_filter
from twin.arrays import run_slices


@dataclass
class BlockAverager:
    """Means over blocks of ``k`` samples inside each run (a partial last block is kept).

    Calling it with an array (n,) or (n, m) returns the block means, (blocks,) or (blocks, m).

    Attributes
    ----------
    starts : np.ndarray
        First sample of each block.
    lengths : np.ndarray
        Samples in each block.
    run_of_block : np.ndarray
        Run of each block.
    """

    starts: np.ndarray  # first sample of each block
    lengths: np.ndarray
    run_of_block: np.ndarray

    @classmethod
    def build(cls, run_index: np.ndarray, k: int) -> BlockAverager:
        """Blocks of ``k`` samples, restarting at each run.

        Parameters
        ----------
        run_index : np.ndarray
            Run of each sample.
        k : int
            Samples per block (at least 1).

        Returns
        -------
        BlockAverager
        """
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

    Attributes
    ----------
    coefficients : np.ndarray
        a_1 … a_p [1].
    sigma2 : float
        Innovation variance [unit of x squared].
    partial : list of (np.ndarray, float)
        The Levinson–Durbin predictors of orders 0..p−1 with their error variances, used for the
        first samples of each run.
    """

    coefficients: np.ndarray
    sigma2: float
    partial: list[tuple[np.ndarray, float]] = field(default_factory=list)

    @property
    def order(self) -> int:
        """The AR order p [1]."""
        return int(self.coefficients.size)

    def prewhiten(self, x: np.ndarray, run_index: np.ndarray) -> np.ndarray:
        """Exact AR(p) whitening, run by run, keeping every sample (innovations algorithm).

        From sample p on: e = x − Σ a_i x[t−i]. The first p samples of a run have fewer past
        values: sample t is predicted with the order-t predictor and its error scaled by
        √(σ²_p / σ²_t), so all outputs share one variance. Zero-initialised filtering would leave
        those samples with the full process variance, and a regressor concentrated at run starts
        (a power-on transient) would look significant in pure noise.

        Parameters
        ----------
        x : np.ndarray
            Series (n,) or columns (n, m) [any unit].
        run_index : np.ndarray
            Run of each row; whitening restarts at each run.

        Returns
        -------
        np.ndarray
            Innovations, shape of ``x`` [unit of x].

        References
        ----------
        Brockwell & Davis, *Time Series: Theory and Methods*, §5.2 (recursive best linear
        predictors); docs/diagnosis.md §1 step 3.
        """
        b = np.concatenate(([1.0], -self.coefficients))
        x = np.asarray(x, float)
        out = np.empty_like(x)
        for run in run_slices(run_index):
            a, z = run.start, run.stop
            seg = x[a:z]
            out[a:z] = _fir(b, seg)
            for t, (coef, s2) in enumerate(self.partial[: z - a]):
                # tensordot(coef, past, axes=(0, 0)) as tensordot computes it (a (1, t) by (t, m)
                # product), without its argument handling (≈ 30 µs a call, 2,000 calls a compare)
                pred = np.dot(coef[None, :], seg[t - 1 :: -1][:t].reshape(t, -1)).reshape(seg.shape[1:]) if t else 0.0
                out[a + t] = (seg[t] - pred) * np.sqrt(self.sigma2 / s2)
        return out


def _fir(b: np.ndarray, x: np.ndarray) -> np.ndarray:
    """Σ_k b[k]·x[t−k] along the first axis, zero before the start, summed as
    ``scipy.signal.lfilter(b, [1], x, axis=0)`` sums it (b[0]·x[t] + (b[1]·x[t−1] + (…))), so the
    same bits, without importing scipy.signal."""
    acc = np.zeros_like(x)
    for k in range(b.size - 1, 0, -1):
        acc[k:] = b[k] * x[:-k] + acc[k:]
    return b[0] * x + acc


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

    Parameters
    ----------
    x : np.ndarray
        The residual [any unit].
    run_index : np.ndarray
        Run of each sample; the autocovariance is pooled over runs, each demeaned.
    max_order : int
        Largest order tried (at most n / 10).

    Returns
    -------
    ARModel
        The order with the lowest BIC (order 0 when nothing beats white noise).

    References
    ----------
    Yule–Walker equations (Yule 1927, *Phil. Trans. R. Soc. A* 226:267; Walker 1931, *Proc. R. Soc. A*
    131:518), solved by Levinson–Durbin (Brockwell & Davis §5.2); BIC: Schwarz, G. (1978), Estimating
    the dimension of a model, *Ann. Stat.* 6(2):461–464; docs/diagnosis.md §1 step 3.
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
        a = np.concatenate((a - k * a[::-1], [k]))
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
    determinant alone and models with different θ compare by their residuals.

    Parameters
    ----------
    x : np.ndarray
        Series (n,) or columns (n, m) [any unit].
    run_index : np.ndarray
        Run of each row; the filter restarts at each run.
    theta : float
        MA parameter θ [1].

    Returns
    -------
    np.ndarray
        The filtered series [unit of x].
    """
    x = np.asarray(x, float)
    if theta >= 1.0:
        return x
    out = np.empty_like(x)
    for run in run_slices(run_index):
        out[run] = first_order_filter(x[run], 1.0, -1.0, theta)
    return out


@dataclass
class WalkARModel:
    """Noise = random walk + AR(p): the walk filter with ``theta`` (1: no walk), then ``ar``.

    Attributes
    ----------
    theta : float
        Parameter of :func:`walk_filter` [1].
    ar : ARModel
        AR model of the walk-filtered series.
    """

    theta: float
    ar: ARModel

    def prewhiten(self, x: np.ndarray, run_index: np.ndarray) -> np.ndarray:
        """:func:`walk_filter`, then :meth:`ARModel.prewhiten`, run by run.

        Parameters
        ----------
        x : np.ndarray
            Series (n,) or columns (n, m) [any unit].
        run_index : np.ndarray
            Run of each row.

        Returns
        -------
        np.ndarray
            Innovations [unit of x].
        """
        return self.ar.prewhiten(walk_filter(x, run_index, self.theta), run_index)


def fit_walk_ar(A: np.ndarray, y: np.ndarray, run_index: np.ndarray, max_order: int = 20) -> WalkARModel:
    """The walk + AR noise model of ``y`` about the regression on ``A``, θ chosen by restricted
    (REML) likelihood with a BIC penalty on the walk and the AR order.

    The restricted likelihood counts the regressors' own log det(AᵀΣ⁻¹A) (Harville, *JASA* 72,
    1977, §4), so a trend in ``A`` does not hide the walk that looks like it: a plain likelihood of
    the residual after fitting the trend underestimates the walk exactly when it drifts one way.

    Parameters
    ----------
    A : np.ndarray
        Regressors (n × k).
    y : np.ndarray
        Target (n,) [any unit].
    run_index : np.ndarray
        Run of each row.
    max_order : int
        Largest AR order.

    Returns
    -------
    WalkARModel
        θ from :data:`WALK_THETAS` and the AR model of the walk-filtered residual.
    """
    A = np.asarray(A, float).reshape(len(y), -1)
    best, best_crit = None, np.inf
    for model, crit in walk_ar_criteria(A, y, run_index, max_order):
        if crit < best_crit:
            best, best_crit = model, crit
    if best is not None:
        return best
    r_ols = y - A @ np.linalg.lstsq(A, y, rcond=None)[0]
    return WalkARModel(1.0, fit_ar(r_ols, run_index, max_order))


def walk_ar_criteria(A: np.ndarray, y: np.ndarray, run_index: np.ndarray,
                     max_order: int = 20) -> Iterator[tuple[WalkARModel, float]]:
    """Each walk + AR noise model of :func:`fit_walk_ar` (one per θ of :data:`WALK_THETAS`) with its
    restricted-likelihood criterion (smaller is better); a θ whose prewhitened fit is degenerate is
    left out.

    Parameters
    ----------
    A : np.ndarray
        Regressors (n × k).
    y : np.ndarray
        Target (n,) [any unit].
    run_index : np.ndarray
        Run of each row.
    max_order : int
        Largest AR order.

    Yields
    ------
    model : WalkARModel
    criterion : float
        −2 × restricted log-likelihood plus the BIC penalty on the walk and the AR order [1].
    """
    A = np.asarray(A, float).reshape(len(y), -1)
    r_ols = y - A @ np.linalg.lstsq(A, y, rcond=None)[0]
    n, k = A.shape
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
        yield model, (n - k) * np.log(rss / (n - k)) + head + logdet + (ar.order + (theta < 1)) * np.log(n)


def white_noise_sigma_from_differences(r: np.ndarray, run_index: np.ndarray) -> float:
    """σ of the white part of a residual from its first differences: √(mean(Δr²)/2).

    Slow structure barely changes between neighbouring samples, so this is the sample-rate noise
    floor of the data (white + quantisation), robust to the drift still in the residual. Differences
    beyond 8 robust σ (spikes, steps) are trimmed; a plain MAD would be biased by quantised values.

    Parameters
    ----------
    r : np.ndarray
        Residual [g].
    run_index : np.ndarray
        Run of each sample; differences across runs are dropped.

    Returns
    -------
    float
        White-noise σ [g] (docs/diagnosis.md §2k).
    """
    d = np.diff(np.asarray(r, float))
    return white_sigma_of_differences(d[np.diff(np.asarray(run_index)) == 0])


def white_sigma_of_differences(d: np.ndarray) -> float:
    """√(mean(d²)/2) of first differences ``d`` inside runs, beyond 8 robust σ trimmed (see
    :func:`white_noise_sigma_from_differences`).

    Parameters
    ----------
    d : np.ndarray
        First differences inside runs [g].

    Returns
    -------
    float
        White-noise σ [g]; 0 for no differences.
    """
    if d.size == 0:
        return 0.0
    scale = np.percentile(np.abs(d), 75) / 0.6745 or np.std(d)
    d = d[np.abs(d) <= 8 * scale] if scale > 0 else d
    return float(np.sqrt(np.mean(d * d) / 2.0))


def white_sigma_in_place(d: np.ndarray) -> float:
    """:func:`white_sigma_of_differences` of ``d``, overwriting ``d`` with ``|d|``: the same estimator
    and the same number (neither the trim nor the squares see the sign; tests/test_long_logs.py
    checks equality) with one full-length temporary instead of four, which set the peak memory of a
    week-long log.

    Parameters
    ----------
    d : np.ndarray
        First differences inside runs [g]; overwritten.

    Returns
    -------
    float
        White-noise σ [g]; 0 for no differences.
    """
    if d.size == 0:
        return 0.0
    magnitude = np.abs(d)
    scale = np.percentile(magnitude, 75, overwrite_input=True) / 0.6745  # partitions the temporary
    del magnitude
    if not scale > 0:  # mostly zero differences: the fallback scale needs the signed values
        return white_sigma_of_differences(d)
    np.abs(d, out=d)
    kept = d[d <= 8 * scale]
    np.square(kept, out=kept)
    return float(np.sqrt(np.mean(kept) / 2.0))


def allan_taus_s(n: int, rate_hz: float, n_taus: int = 30) -> np.ndarray:
    """Averaging times for an Allan deviation (:func:`sim.sensor.allan_deviation`, the one
    implementation) of ``n`` samples: log-spaced from 1 sample up to n / 8, duplicates merged.

    Parameters
    ----------
    n : int
        Samples of the signal.
    rate_hz : float
        Sample rate [Hz].
    n_taus : int
        Points of the log grid before duplicates are merged.

    Returns
    -------
    np.ndarray
        Averaging times [s].
    """
    return np.unique(np.logspace(0, np.log10(max(2, n // 8)), n_taus).astype(int)) / rate_hz
