"""The lag-aware model's training SSE as a function of its time constants, searched on block means.

For given time constants (τ_die, τ_rate) the model is linear, so a trial costs two lags of the
temperature and one small least squares. On a log sampled faster than twice 1/``SEARCH_STEP_S``
(:mod:`twin.calibration.lagcache`; a tester at 100 Hz, a flight controller's IMU at 10 Hz) the
trials run on means of ``SEARCH_STEP_S`` seconds inside each run: the first-order-hold lag of the
means is the lag of the piecewise-linear temperature through them, the block mean of a reading is
the same sum, and the full-rate SSE is the means' weighted SSE plus the scatter of the readings
inside the blocks (constant in τ). What the means leave out is the design's own variation inside
a block: the temperature's curvature over one second of a ramp, and the thermometer's noise,
which enters the rate term T − lag(T, τ_rate) unfiltered at full rate. On a noise-free thermometer the two
searches agree to 1 ms in τ_rate (a 6-h tester log at 100 Hz); with 0.01 °C of thermometer noise the
full-rate optimum moves to a longer τ_rate and a 3 % smaller rate amplitude (their product, the
part the data fix, stays within 0.2 %): the noise's share of the SSE, n·b²·σ_T², shrinks as b
does — a bias of the full-rate search, which the means do not have. Only blocks whose rows are
all training rows enter.

The candidate structures are scored (BIC) with this SSE. The effective sample size, the final
amplitudes and the residual's power and autocorrelation (the σ of every interval) are computed on
every full-rate training row; the curvature of the SSE in all parameters (JᵀJ) on the search's
rows, where each column is its block mean to second order (``TDE_TWIN_FULL_RATE=1``: full rate).

Every solve uses the normal equations of the (few) design columns, equilibrated; residuals are
computed directly. Lags are cached within a byte budget (``LAG_CACHE_BYTES``); the folds of one
log share its block means, their lags and sums (:class:`~twin.calibration.lagcache.WholeLog`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from twin.calibration.lag import ThermalLog
from twin.calibration.lagcache import LagCache, WholeLog, reading_block_sums, search_factor
from twin.calibration.models import poly_columns
from twin.calibration.polygram import solve_gram
from twin.estimation.noise import BlockAverager

MAX_ROW_LAGS = 32  # the search's lags kept on its rows, per fit (the grid's 25 and recent refinements)
MIN_SEARCH_BLOCKS = 200  # fewer whole training blocks than this: the search runs on the full-rate rows
FULL_CHUNK = 1 << 16  # full-rate training rows per pass step: a design of this many rows stays in cache


def _step(tau_s: float) -> tuple[float, float]:
    """(lo, hi) of the central difference in τ: τ ± max(10⁻³ τ, 0.05 s), lo never below 0."""
    h = max(1e-3 * tau_s, 0.05)
    return max(tau_s - h, 0.0), tau_s + h


@dataclass(frozen=True, eq=False)
class FullStats:
    """What one pass over the full-rate training rows gives (:meth:`Profile.full_stats`).

    Attributes
    ----------
    sse, lag1, total : (3,) ndarray
        Σ r², Σ r_i·r_{i+1} (consecutive training rows) and Σ r per axis.
    first, last : (3,) ndarray
        The first and last residual.
    n : int
    """

    sse: np.ndarray
    lag1: np.ndarray
    total: np.ndarray
    first: np.ndarray
    last: np.ndarray
    n: int


class Profile:
    """Training SSE per axis as a function of (τ_die, τ_rate), linear parameters projected out.

    :meth:`sse`, :meth:`search_coef` and :meth:`gauss_newton_blocks` are on the search's rows
    (block means when the log is fast, module docstring); :meth:`design`, :meth:`full_coef` and
    :meth:`full_stats` on the full-rate rows, the last two in chunks of :data:`FULL_CHUNK` rows.

    Parameters
    ----------
    log : ThermalLog
        The whole temperature log (the lags run over it).
    y : (n, 3) ndarray
        Readings [g].
    keep : (n,) ndarray of bool
        Training rows.
    degree : int
        Polynomial degree in the die temperature.
    reference_c : float
        Expansion point [°C].
    factor : int, optional
        Samples per search mean (default :func:`search_factor`).
    whole_log : WholeLog, optional
        The same log reduced before (its ``factor`` is used).
    """

    def __init__(self, log: ThermalLog, y: np.ndarray, keep: np.ndarray, degree: int, reference_c: float,
                 factor: int | None = None, whole_log: WholeLog | None = None):
        self.log, self.keep, self._y = log, keep, y
        self.n = int(keep.sum())
        self.degree, self.reference_c = degree, reference_c
        # full-rate lags are each fit's own (its τ's): a cache shared by the folds would only hold memory
        self._full = LagCache(log, runs=None if whole_log is None else whole_log.runs)
        if whole_log is not None:  # the search's blocks, lags and sums of an earlier fit's log
            self.factor = whole_log.factor
        else:
            self.factor = search_factor(log) if factor is None else max(1, int(factor))
        edges = np.diff(np.r_[0, keep.astype(np.int8), 0])
        self._spans = list(zip(np.flatnonzero(edges == 1).tolist(), np.flatnonzero(edges == -1).tolist()))
        if self.factor == 1 or not self._reduce(y, keep, whole_log):
            self.factor = 1
            self._search, self._rows, self._yb, self._sw, self._within = self._full, keep, y[keep], None, 0.0
        self._yw = self._yb if self._sw is None else self._yb * self._sw[:, None]  # (rows, 3) and (3, rows)
        self._ywt = np.ascontiguousarray(self._yw.T)
        self._sse_memo: dict = {}  # (τ_die, τ_rate or None) → SSE: a few hundred triples per fit
        self._at_rows, self._T_rows = {}, None  # the search's lags and temperatures on its rows

    def _reduce(self, y: np.ndarray, keep: np.ndarray, whole_log: WholeLog | None = None) -> bool:
        """Block means of the log (all rows: the lags run over them) and of the training readings
        (``whole_log``'s, selected); False (search on full rate) when fewer than
        :data:`MIN_SEARCH_BLOCKS` blocks are all training rows."""
        blocks = BlockAverager.build(self.log.run, self.factor) if whole_log is None else whole_log.blocks
        whole = np.add.reduceat(keep.astype(np.int64), blocks.starts) == blocks.lengths  # every row trains
        if whole.sum() < MIN_SEARCH_BLOCKS:
            return False
        if whole_log is not None:  # a block whose rows all train has the sums of all its rows
            self._search, level = whole_log.search, whole_log.level
            sums, squares = whole_log.sums[whole], whole_log.squares[whole]
        else:
            log = self.log
            self._search = LagCache(ThermalLog(blocks(log.time_s), blocks(log.temperature_c), log.run[blocks.starts]))
            level = np.array([y[keep, k].mean() for k in range(3)])
            sums, squares = reading_block_sums(y, keep, blocks.starts, level)
            sums, squares = sums[whole], squares[whole]
        n = blocks.lengths[whole].astype(float)[:, None]
        self._rows, self._yb, self._sw = whole, sums / n + level, np.sqrt(n[:, 0])
        # inside each block Σ(y − ȳ)² = Σy² − (Σy)²/n: the part of the full-rate SSE no τ can change
        self._within = np.maximum(squares - sums * sums / n, 0.0).sum(axis=0)
        return True

    def lag(self, tau_s: float) -> np.ndarray:
        """Lagged temperature ``lag(T, τ)`` [°C] of the whole full-rate log, cached.

        Parameters
        ----------
        tau_s : float
            Time constant [s].

        Returns
        -------
        (n,) ndarray
            Lagged temperature [°C].
        """
        return self._full(tau_s)

    def _search_columns(self, tau_die_s: float, tau_rate_s: float | None) -> np.ndarray:
        """:meth:`_columns` of the search's rows, their lags kept by τ (the grid pairs each τ_die with
        every τ_rate: a lag is selected once, not per pair) and their temperatures once."""
        if self._T_rows is None:
            self._T_rows = self._search.log.temperature_c[self._rows]
        rated = tau_rate_s is not None and np.isfinite(tau_rate_s)
        return self._stack(self._lag_rows(tau_die_s), self._T_rows if rated else None,
                           self._lag_rows(tau_rate_s) if rated else None)

    def _lag_rows(self, tau_s: float) -> np.ndarray:
        key = round(float(tau_s), 9)
        if key not in self._at_rows:
            if len(self._at_rows) >= MAX_ROW_LAGS:
                self._at_rows.pop(next(iter(self._at_rows)))
            self._at_rows[key] = self._search(key)[self._rows]
        return self._at_rows[key]

    def _columns(self, lag, temperature_c, tau_die_s, tau_rate_s, rows) -> np.ndarray:
        rated = tau_rate_s is not None and np.isfinite(tau_rate_s)
        return self._stack(lag(tau_die_s)[rows], temperature_c[rows] if rated else None,
                           lag(tau_rate_s)[rows] if rated else None)

    def _stack(self, die, temperature_c=None, rate_lag=None, out=None) -> np.ndarray:
        """The design's transpose, (p, rows), from the die lag (and T and the rate lag) of the same
        rows (into ``out`` when given: a pass reuses one buffer). Every product below keeps the
        rows along the last axis: a (rows, p) view times (p, 3) is 30× slower in OpenBLAS."""
        p = self.degree + 1 + (rate_lag is not None)
        out = np.empty((p, die.size)) if out is None else out
        x = die - self.reference_c if self.degree < 1 else np.subtract(die, self.reference_c, out=out[1])
        poly_columns(x, self.degree, out)
        if rate_lag is not None:
            np.subtract(temperature_c, rate_lag, out=out[-1])
        return out

    def design(self, tau_die_s: float, tau_rate_s: float | None, rows=slice(None)) -> np.ndarray:
        """(n, degree + 1 [+ 1]) full-rate columns: (T_die − ref)/10 °C powers [+ (T − lag(T, τ_rate)) °C].

        Parameters
        ----------
        tau_die_s : float
            Die lag [s].
        tau_rate_s : float or None
            Rate-term lag [s]; None or NaN: no rate column.
        rows : slice or ndarray, optional
            Rows returned.

        Returns
        -------
        ndarray
            The design matrix.
        """
        return self._columns(self._full, self.log.temperature_c, tau_die_s, tau_rate_s, rows).T

    def sse(self, tau_die_s: float, tau_rate_s: float | None) -> np.ndarray:
        """The search's training residual sum of squares per axis [g²], floored above zero: on
        block means (weighted by their rows, plus the scatter inside the blocks) or full rate.

        Parameters
        ----------
        tau_die_s, tau_rate_s : float, float or None
            Die and rate-term lags [s].

        Returns
        -------
        (3,) ndarray
            SSE per axis [g²].
        """
        # the refinements start from grid points and end by re-scoring both ends: each SSE once
        key = (float(tau_die_s), float(tau_rate_s) if tau_rate_s is not None and np.isfinite(tau_rate_s) else None)
        if key not in self._sse_memo:
            Ft = self._search_columns(tau_die_s, tau_rate_s)
            if self._sw is not None:
                Ft *= self._sw
            r = self._ywt - solve_gram(Ft @ Ft.T, Ft @ self._yw).T @ Ft
            sse = np.einsum("ij,ij->i", r, r)
            # floored: an exact fit (a noise-free log) must not send log(SSE) to -inf in the scores
            self._sse_memo[key] = np.maximum(sse + self._within, np.finfo(float).tiny * self.n)
        return self._sse_memo[key].copy()

    def _chunks(self):
        """(start, stop) of the training rows in order, contiguous, at most :data:`FULL_CHUNK` each."""
        for a, b in self._spans:
            for start in range(a, b, FULL_CHUNK):
                yield start, min(start + FULL_CHUNK, b)

    def full_coef(self, tau_die_s: float, tau_rate_s: float | None) -> np.ndarray:
        """Linear coefficients of the three axes on every full-rate training row (normal equations
        summed chunk by chunk: no full-length design is ever formed).

        Parameters
        ----------
        tau_die_s, tau_rate_s : float, float or None
            Die and rate-term lags [s].

        Returns
        -------
        (p, 3) ndarray
            Coefficients of :meth:`design`'s columns per axis.
        """
        G, B = 0.0, 0.0
        lags = self._lags(tau_die_s, tau_rate_s)
        buf = np.empty((self.degree + 1 + (lags[1] is not None), FULL_CHUNK))
        for a, b in self._chunks():
            Ft = self._chunk(lags, a, b, buf)
            G, B = G + Ft @ Ft.T, B + Ft @ self._y[a:b]
        return solve_gram(G, B)

    def _lags(self, tau_die_s: float, tau_rate_s: float | None) -> tuple:
        """The full-rate lags a design needs, held for a pass (the cache may drop them meanwhile)."""
        rated = tau_rate_s is not None and np.isfinite(tau_rate_s)
        return self._full(tau_die_s), (self._full(tau_rate_s) if rated else None)

    def _chunk(self, lags: tuple, a: int, b: int, buf: np.ndarray) -> np.ndarray:
        die, rate = lags
        T = self.log.temperature_c[a:b]
        return self._stack(die[a:b], T, None if rate is None else rate[a:b], buf[:, : b - a])

    def full_stats(self, tau_die_s: float, tau_rate_s: float | None, coef: np.ndarray) -> FullStats:
        """Residual statistics of ``coef`` on every full-rate training row, in order, chunk by chunk.

        Parameters
        ----------
        tau_die_s, tau_rate_s : float, float or None
            Die and rate-term lags [s].
        coef : (p, 3) ndarray
            Coefficients per axis.

        Returns
        -------
        FullStats
        """
        sse, lag1, total, first, last, prev = np.zeros(3), np.zeros(3), np.zeros(3), None, None, None
        lags = self._lags(tau_die_s, tau_rate_s)
        buf, rbuf = np.empty((coef.shape[0], FULL_CHUNK)), np.empty((3, FULL_CHUNK))
        for a, b in self._chunks():
            Ft = self._chunk(lags, a, b, buf)
            r = np.matmul(coef.T, Ft, out=rbuf[:, : b - a])
            np.subtract(self._y[a:b].T, r, out=r)  # (3, rows)
            sse += np.einsum("ij,ij->i", r, r)
            lag1 += np.einsum("ij,ij->i", r[:, 1:], r[:, :-1]) + (prev * r[:, 0] if prev is not None else 0.0)
            total += r.sum(axis=1)
            first = r[:, 0].copy() if first is None else first
            prev = last = r[:, -1].copy()
        return FullStats(sse, lag1, total, first, last, self.n)

    def search_coef(self, tau_die_s: float, tau_rate_s: float | None) -> np.ndarray:
        """Linear coefficients of the three axes on the search's rows (block means on a fast log).

        Parameters
        ----------
        tau_die_s, tau_rate_s : float, float or None
            Die and rate-term lags [s].

        Returns
        -------
        (p, 3) ndarray
        """
        Ft = self._columns(self._search, self._search.log.temperature_c, tau_die_s, tau_rate_s, self._rows)
        if self._sw is not None:
            Ft *= self._sw
        return solve_gram(Ft @ Ft.T, Ft @ self._yw)

    def gauss_newton_blocks(self, tau_die_s: float, tau_rate_s: float | None, coef: np.ndarray) -> np.ndarray:
        """Per axis ``AᵀA``, A = [design | ∂prediction/∂τ_die (| ∂/∂τ_rate)], summed over the
        search's rows: block means weighted by their rows on a fast log — the columns are smooth
        in time, so inside a block each is its mean to second order (the thermometer's own noise in
        the rate column adds σ_T²/var(T − T_g), 10⁻⁵ of that entry on the simulated tester log) —
        and every training row on a slow one. Central differences of the lag: τ ± max(10⁻³ τ,
        0.05 s), forward at τ = 0.

        Parameters
        ----------
        tau_die_s, tau_rate_s : float, float or None
            Die and rate-term lags [s].
        coef : (p, 3) ndarray
            Coefficients per axis.

        Returns
        -------
        (3, q, q) ndarray
            q = p + 1 (+ 1 with a rate term).
        """
        lag, rows = self._search, self._rows
        rated = tau_rate_s is not None and np.isfinite(tau_rate_s)
        Ft = self._columns(lag, lag.log.temperature_c, tau_die_s, tau_rate_s, rows)
        lo, hi = _step(tau_die_s)
        cT = coef[: self.degree + 1].T
        D = cT @ self._stack(lag(hi)[rows])
        D -= cT @ self._stack(lag(lo)[rows])
        D /= hi - lo
        if rated:  # b·(T − lag(T, τ)): T cancels
            lo, hi = _step(tau_rate_s)
            D = np.vstack([D, coef[-1][:, None] * ((lag(lo)[rows] - lag(hi)[rows]) / (hi - lo))])
        if self._sw is not None:
            Ft, D = Ft * self._sw, D * self._sw
        FF, FD, DD = Ft @ Ft.T, Ft @ D.T, D @ D.T
        out = []
        for axis in range(3):
            idx = [axis, axis + 3] if rated else [axis]
            out.append(np.block([[FF, FD[:, idx]], [FD[:, idx].T, DD[np.ix_(idx, idx)]]]))
        return np.array(out)

