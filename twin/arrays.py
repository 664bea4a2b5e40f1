"""Array helpers every subsystem shares."""

from __future__ import annotations

import numpy as np


def run_slices(run_index: np.ndarray) -> list[slice]:
    """Contiguous stretches of equal run index, in sample order (stateful filters restart at each).

    Parameters
    ----------
    run_index : np.ndarray
        Run of each sample.

    Returns
    -------
    list[slice]
        One slice per run; empty for an empty input.
    """
    run_index = np.asarray(run_index)
    if run_index.size == 0:
        return []
    edges = np.concatenate(([0], np.flatnonzero(np.diff(run_index)) + 1, [run_index.size]))
    return [slice(int(a), int(b)) for a, b in zip(edges[:-1], edges[1:])]


SUMMED_TERMS = 20_000_000  # windows × size up to which each window is summed on its own (≈ 20 ms)


def moving_mean(x: np.ndarray, size: int) -> np.ndarray:
    """Mean of the ``size`` samples centred on each one (``size // 2`` before it), the ends
    extended with the first and last values: ``scipy.ndimage.uniform_filter1d(x, size,
    mode="nearest")`` within rounding, without importing scipy at the start of a command.

    Each window is summed on its own while that is at most :data:`SUMMED_TERMS` additions: within
    ``size`` ulp of the exact mean, and exactly the value of a constant stretch (a dwell at 50 °C
    stays at 50 °C, in the bin it belongs to). Beyond that (a report's 10-min mean of a long log)
    the means are differences of a running sum of ``x − x[0]``, O(n) as scipy's own running sum,
    whose rounding grows along the array in the same way.

    Parameters
    ----------
    x : np.ndarray
        Samples, 1-D [any unit].
    size : int
        Window length [samples]; 1 or less returns a copy.

    Returns
    -------
    np.ndarray
        The moving mean, float, the length of ``x`` [unit of x].
    """
    x = np.asarray(x, float)
    if size <= 1 or x.size == 0:
        return x.copy()
    left = size // 2
    padded = np.concatenate([np.full(left, x[0]), x, np.full(size - 1 - left, x[-1])])
    if x.size * size <= SUMMED_TERMS:
        return np.lib.stride_tricks.sliding_window_view(padded, size).mean(axis=1)
    running = np.concatenate([[0.0], np.cumsum(padded - x[0])])
    return (running[size:] - running[:-size]) / size + x[0]


def median_dt(t: np.ndarray) -> float:
    """Median positive time step (1 when there is none).

    Parameters
    ----------
    t : ndarray
        Sample times [s].

    Returns
    -------
    float
        Step [s].
    """
    d = np.diff(t)
    return float(np.median(d[d > 0])) if np.any(d > 0) else 1.0


#: how :func:`temperature_rate_c_per_s` differentiates
RATE_METHODS = ("gradient", "half_windows", "forward")


def temperature_rate_c_per_s(time_s, temperature_c, run_index=None, *, smooth_s: float = 0.0,
                             method: str = "gradient") -> np.ndarray:
    """dT/dt of every row [°C/s], run by run: the project's one rate of change of temperature.

    The methods are what the call sites genuinely need, not variants of taste:

    * ``"gradient"``: second-order centred differences at the rows' times (one-sided at a run's
      ends), after a centred moving mean over the whole number of rows nearest ``smooth_s``
      (none at 0; cut at the run's ends by repeating them). Features and groupings.
    * ``"half_windows"``: the mean of the next half of a ``smooth_s`` window minus the mean of
      the last half, over the difference of their mean times: noise-robust without a filter's
      delay, 0 across a time reset. The log-quality stage's ramp direction.
    * ``"forward"``: (T[i+1] − T[i]) / (t[i+1] − t[i]) on row i (0 on a run's last row and where
      time does not advance): the steepest step between samples, which a bound needs and a
      centred difference averages away.

    Parameters
    ----------
    time_s : array_like or float
        Sample times [s], or one sample interval [s] for rows taken as evenly spaced.
    temperature_c : array_like
        Temperature [°C].
    run_index : array_like, optional
        Run of each row (contiguous runs); no rate spans two runs. None: one run.
    smooth_s : float
        Smoothing window [s] of ``"gradient"``, full window of ``"half_windows"`` (converted to
        rows with the median positive step of all rows); unused by ``"forward"``.
    method : {"gradient", "half_windows", "forward"}
        See above.

    Returns
    -------
    ndarray
        dT/dt per row [°C/s]; 0 for a run of one row.
    """
    if method not in RATE_METHODS:
        raise ValueError(f"method must be one of {', '.join(RATE_METHODS)}; got {method!r}")
    T = np.asarray(temperature_c, float)
    uniform = np.ndim(time_s) == 0
    if uniform:  # no time axis for the centred difference: a long log's rows hold no second copy
        step = float(time_s)
        t = None if method == "gradient" else np.arange(T.size) * step
    else:
        t = np.asarray(time_s, float)
        step = median_dt(t)
    out = np.zeros(T.size)
    for s in run_slices(run_index) if run_index is not None else [slice(0, T.size)]:
        if s.stop - s.start < 2:
            continue
        if method == "forward":
            gap = np.diff(t[s])
            out[s.start:s.stop - 1] = np.diff(T[s]) / np.where(gap > 0, gap, np.inf)
        elif method == "half_windows":
            out[s] = _half_window_rate(t[s], T[s], max(1, int(round(smooth_s / 2 / step))))
        else:
            x = moving_mean(T[s], max(1, int(round(smooth_s / step))))
            # evenly spaced rows: the scalar step, so no time axis is rounded into the result
            out[s] = np.gradient(x, step) if uniform else np.gradient(x, t[s])
    return out


def _half_window_rate(t: np.ndarray, T: np.ndarray, h: int) -> np.ndarray:
    """dT/dt [°C/s] from the means of the ``h`` rows after and before each row (see
    :func:`temperature_rate_c_per_s`, ``"half_windows"``)."""
    n = t.size
    i = np.arange(n)
    lo, hi = np.maximum(i - h, 0), np.minimum(i + h, n - 1)
    cT, ct = np.r_[0.0, np.cumsum(T - T[0])], np.r_[0.0, np.cumsum(t - t[0])]

    def mean(c, a, b):  # mean of rows a..b inclusive
        return (c[b + 1] - c[a]) / (b + 1 - a)

    dt, dT = mean(ct, i, hi) - mean(ct, lo, i), mean(cT, i, hi) - mean(cT, lo, i)
    return np.where(dt > 0, dT / np.where(dt > 0, dt, 1.0), 0.0)


def interleaved_folds(time_s, folds: int, blocks_per_fold: int | None = None, *,
                      block_rows: int | None = None) -> np.ndarray:
    """Fold (0 … folds − 1) of each row: contiguous blocks in time order, block b held out in fold
    b % folds. The project's one builder of held-out folds.

    Contiguous blocks keep neighbouring, correlated samples together (random splits would leak
    them); interleaving gives every fold the whole temperature programme.

    Parameters
    ----------
    time_s : array_like
        Sample times [s]; only their order matters (rows already in order: ``np.arange(n)``).
    folds : int
        Number of folds.
    blocks_per_fold : int, optional
        Cut the record into ``folds × blocks_per_fold`` blocks of equal rows (±1).
    block_rows : int, optional
        Instead, blocks of this many rows, as many as the record holds (the last one partial).

    Returns
    -------
    ndarray of int
        Fold of each row.
    """
    if (blocks_per_fold is None) == (block_rows is None):
        raise ValueError("give exactly one of blocks_per_fold and block_rows")
    order = np.argsort(np.asarray(time_s, dtype=float), kind="stable")
    rank = np.arange(order.size)
    block = rank // max(1, int(block_rows)) if block_rows is not None else \
        (rank * (folds * blocks_per_fold)) // order.size
    fold = np.empty(order.size, dtype=np.int64)
    fold[order] = block % folds
    return fold
