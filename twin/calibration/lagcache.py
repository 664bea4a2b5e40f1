"""Lagged temperatures kept for the τ search, and a log reduced once for every fit on rows of it.

:class:`LagCache` holds the lags of one series by τ within a byte budget; :class:`WholeLog` holds
what the folds of one validation have in common — the search's block means of the clock and
temperature (:func:`search_factor`), their lags, and per block the sums of the readings — so a
fold's :class:`~twin.calibration.lagprofile.Profile` selects them instead of reducing the log again.
"""

from __future__ import annotations

import numpy as np

from twin.calibration.lag import ThermalLog, clock_of, lag_on_clock
from twin.estimation.decimate import decimation_factor
from twin.estimation.noise import BlockAverager

SEARCH_STEP_S = 1.0  # the time constants are searched on 1-s means of faster logs
LAG_CACHE_BYTES = 64 * 2**20  # lagged temperatures kept per cache (search series and full rate each)
SHARED_CACHE_BYTES = 8 * 2**20  # the folds' shared search lags: the grid's, and the recent refinements
MIN_CACHED_LAGS = 4  # the current trial's two lags and the refinement's neighbours, at any length


def search_factor(log: ThermalLog) -> int:
    """Samples per search mean: 1 for logs at up to twice 1/:data:`SEARCH_STEP_S`, else the rate
    over that (100 at 100 Hz); 1 whenever ``TDE_TWIN_FULL_RATE`` is set.

    Parameters
    ----------
    log : ThermalLog
        The whole log.

    Returns
    -------
    int
        Samples per mean (≥ 1).
    """
    dt = np.diff(log.time_s)
    dt = dt[dt > 0]
    if not dt.size:
        return 1
    return decimation_factor(1.0 / float(np.median(dt)), 1.0 / SEARCH_STEP_S)


class LagCache:
    """Lagged temperatures of one series by τ, least recently used dropped beyond the byte budget;
    each run's clock read once, as ``lagged_c``.

    Parameters
    ----------
    log : ThermalLog
        The series (time [s], temperature [°C], runs).
    budget : int
        Bytes the cached lags may hold.
    runs : list of (slice, RunClock), optional
        Each run's rows and clock (default: read here from ``log``).
    """

    def __init__(self, log: ThermalLog, budget: int = LAG_CACHE_BYTES, runs: list | None = None):
        self.log = log
        self.size = max(MIN_CACHED_LAGS, budget // max(8 * log.time_s.size, 1))
        self.lags: dict[float, np.ndarray] = {}
        self.runs = runs if runs is not None else [(seg, clock_of(log.time_s[seg])) for seg in log.segments()]

    def _lag(self, tau_s: float) -> np.ndarray:
        T, out = self.log.temperature_c, np.empty_like(self.log.temperature_c)
        for seg, clock in self.runs:  # as lag.lagged_c, with the clock read once
            out[seg] = lag_on_clock(self.log.time_s[seg], T[seg], tau_s, clock)
        return out

    def __call__(self, tau_s: float) -> np.ndarray:
        key = round(float(tau_s), 9)
        if key in self.lags:
            self.lags[key] = self.lags.pop(key)  # most recent last
        else:
            if len(self.lags) >= self.size:  # refinements revisit recent values: drop the oldest
                self.lags.pop(next(iter(self.lags)))
            self.lags[key] = self._lag(key)
        return self.lags[key]


def reading_block_sums(y: np.ndarray, rows: np.ndarray, starts: np.ndarray, level: np.ndarray):
    """Per block, Σ (y − level) and Σ (y − level)² over ``rows`` (about the level: the sums of
    squares keep their digits), axis by axis: two full-length temporaries, not six.

    Parameters
    ----------
    y : (n, 3) ndarray
    rows : (n,) ndarray of bool
        Rows summed (NaN readings must be off them).
    starts : (b,) ndarray of int
        First row of each block.
    level : (3,) ndarray

    Returns
    -------
    (sums, squares) : (b, 3) ndarrays
    """
    sums, squares = np.empty((starts.size, 3)), np.empty((starts.size, 3))
    for k in range(3):
        yc = y[:, k] - level[k]
        yc[~rows] = 0.0
        sums[:, k] = np.add.reduceat(yc, starts)
        yc *= yc
        squares[:, k] = np.add.reduceat(yc, starts)
    return sums, squares


class WholeLog:
    """A log reduced once for every fit on rows of it (the folds of a validation): the search's
    block means of the clock and temperature, their lags, and per block the sums of the readings
    about the mean of all finite rows. A fold's :class:`~twin.calibration.lagprofile.Profile`
    selects the blocks whose rows all train: their sums are the same in every fold, taken about
    another level than a Profile's own (the mean of its training rows), which moves their
    rounding, not their value.

    Parameters
    ----------
    log : ThermalLog
        The whole log.
    y : (n, 3) ndarray
        Readings [g].
    factor : int, optional
        Samples per search mean (default :func:`search_factor`).

    Attributes
    ----------
    rows, factor : int
        Rows of the log; samples per search mean (1: searched at full rate, nothing reduced).
    runs : list of (slice, RunClock)
        Each run's clock (:func:`twin.calibration.lag.clock_of`).
    step_s : float
        The median step of the log [s].
    blocks : BlockAverager or None
    search : LagCache or None
        Lags of the block means, shared by the folds within :data:`SHARED_CACHE_BYTES`.
    level : (3,) ndarray
    sums, squares : (blocks, 3) ndarrays
        Σ (y − level) and Σ (y − level)² per block.
    """

    def __init__(self, log: ThermalLog, y: np.ndarray, factor: int | None = None):
        self.rows = log.time_s.size
        self.factor = search_factor(log) if factor is None else max(1, int(factor))
        self.runs = [(seg, clock_of(log.time_s[seg])) for seg in log.segments()]  # each run's clock
        self.step_s = float(np.median(np.diff(log.time_s)))
        self.blocks = self.search = None
        if self.factor > 1:  # a slow log is searched at full rate: nothing to reduce
            self.blocks = BlockAverager.build(log.run, self.factor)
            means = ThermalLog(self.blocks(log.time_s), self.blocks(log.temperature_c), log.run[self.blocks.starts])
            self.search = LagCache(means, SHARED_CACHE_BYTES)
            finite = np.isfinite(y).all(axis=1)
            self.level = np.array([y[finite, k].mean() if finite.any() else 0.0 for k in range(3)])
            self.sums, self.squares = reading_block_sums(y, finite, self.blocks.starts, self.level)
