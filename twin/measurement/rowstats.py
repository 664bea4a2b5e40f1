"""Row statistics of a log, for the log-quality stage: moving windows, runs of a mask, robust
thresholds, and the rows a saturated converter or a stuck thermometer gives."""

from __future__ import annotations

import numpy as np


def unit(v) -> np.ndarray:
    """``v`` scaled to unit length (a zero vector stays near zero).

    Parameters
    ----------
    v : array_like
        A vector [any unit].

    Returns
    -------
    ndarray
        Unit vector [1].
    """
    v = np.asarray(v, float)
    return v / max(float(np.linalg.norm(v)), 1e-12)


def window_stats(x: np.ndarray, w: int) -> tuple[np.ndarray, np.ndarray]:
    """Centred moving mean and σ over ``w`` rows, per column.

    Parameters
    ----------
    x : ndarray
        Values, shape (n, columns) [any unit].
    w : int
        Window [rows], cut at the ends.

    Returns
    -------
    mean, sigma : ndarray
        Per row and column [unit of ``x``].
    """
    centre = np.median(x, axis=0)
    x = x - centre  # small numbers in the cumulative sums of a long log
    i = np.arange(x.shape[0])
    lo, hi = np.clip(i - w // 2, 0, i.size), np.clip(i - w // 2 + w, 0, i.size)
    c1, c2 = (np.vstack([np.zeros(x.shape[1]), np.cumsum(v, axis=0)]) for v in (x, x * x))
    cnt = (hi - lo)[:, None]
    mean = (c1[hi] - c1[lo]) / cnt
    return mean + centre, np.sqrt(np.clip((c2[hi] - c2[lo]) / cnt - mean**2, 0, None))


def slow_median(t: np.ndarray, x: np.ndarray, block_s: float) -> np.ndarray:
    """Per column, the medians of consecutive ``block_s`` blocks interpolated at every row: a slow
    reference that a short motion inside a block does not move (a running mean would).

    Parameters
    ----------
    t : ndarray
        Sample times [s].
    x : ndarray
        Values, shape (n, columns) [any unit].
    block_s : float
        Block length [s].

    Returns
    -------
    ndarray
        The slow reference, shape of ``x`` [unit of ``x``].
    """
    # blocks as runs of one block number: O(n) whatever the time span (a corrupt timestamp years
    # away must not make an edge per block of the empty span)
    k = np.floor((t - t[0]) / block_s)
    starts = np.r_[0, np.flatnonzero(np.diff(k) != 0) + 1]
    blocks = list(zip(starts, np.r_[starts[1:], t.size]))
    centres = np.array([t[i:j].mean() for i, j in blocks])
    medians = np.array([np.median(x[i:j], axis=0) for i, j in blocks])
    return np.column_stack([np.interp(t, centres, medians[:, c]) for c in range(x.shape[1])])


def still_threshold(values: np.ndarray, floor: float, ceiling: float = np.inf, k: float = 6.0) -> float:
    """median + k·MAD (as σ) of the still part, found by iterating from the quietest quarter
    upwards until the rows below the threshold stop changing; within [``floor``, ``ceiling``].

    Parameters
    ----------
    values : ndarray
        A per-row statistic (non-finite values ignored) [any unit].
    floor, ceiling : float
        Limits of the threshold [unit of ``values``].
    k : float
        Multiple of the MAD-based σ (MAD × 1.4826, the normal-consistent scale).

    Returns
    -------
    float
        The threshold [unit of ``values``].

    References
    ----------
    Median absolute deviation as a robust σ (1.4826 for normal data), a standard result.
    """
    v = values[np.isfinite(values)]
    still, thr = v <= np.percentile(v, 25), float(floor)
    for _ in range(20):
        med = float(np.median(v[still]))
        thr = max(float(floor), med + k * 1.4826 * float(np.median(np.abs(v[still] - med))))
        nxt = v <= thr
        if np.array_equal(nxt, still) or not nxt.any():
            break
        still = nxt
    return min(thr, max(float(ceiling), float(floor)))


def dilate(mask: np.ndarray, k: int) -> np.ndarray:
    """``mask`` widened by ``k`` rows on both sides.

    Parameters
    ----------
    mask : ndarray of bool
        Rows flagged.
    k : int
        Rows added on each side.

    Returns
    -------
    ndarray of bool
        The widened mask.
    """
    if k <= 0 or not mask.any():
        return mask.copy()
    c = np.r_[0, np.cumsum(mask)]
    i = np.arange(mask.size)
    return c[np.minimum(i + k + 1, mask.size)] - c[np.maximum(i - k, 0)] > 0


def runs(mask: np.ndarray, breaks=()) -> list[tuple[int, int]]:
    """(start, stop) of every run of True, cut at the row indices ``breaks``.

    Parameters
    ----------
    mask : ndarray of bool
        Rows flagged.
    breaks : sequence of int
        Row indices where a run is cut.

    Returns
    -------
    list of tuple of int
        Half-open row ranges.
    """
    # vectorised: a row starts a run when it is flagged and its predecessor is not, or a break falls
    # on it inside a run (a thermometer repeating its 0.01 °C steps at 100 Hz makes 10⁵ runs)
    m = np.asarray(mask, bool)
    n = m.size
    cut = np.zeros(n + 1, bool)
    cuts = np.asarray(breaks, int).ravel()
    cut[cuts[(cuts > 0) & (cuts < n)]] = True
    start = m & ~np.r_[False, m[:-1]] | m & cut[:n]
    stop = m & ~np.r_[m[1:], False] | m & cut[1:]
    return list(zip(np.flatnonzero(start).tolist(), (np.flatnonzero(stop) + 1).tolist()))


def frozen_rows(t: np.ndarray, T: np.ndarray, frozen_s: float) -> np.ndarray:
    """Rows of an identical temperature for > ``frozen_s`` when the rest of the log changes on most
    steps (a coarse or noise-free thermometer repeats itself in every dwell: nothing is frozen).

    Parameters
    ----------
    t : ndarray
        Sample times [s].
    T : ndarray
        Temperature [°C].
    frozen_s : float
        Longest plausible repeat [s].

    Returns
    -------
    ndarray of bool
        Rows of a stuck thermometer.
    """
    out = np.zeros(T.size, bool)
    same = np.r_[False, np.diff(T) == 0]
    spans = np.array(runs(same), int).reshape(-1, 2)
    for i, j in spans[t[spans[:, 1] - 1] - t[spans[:, 0] - 1] > frozen_s]:
        out[i - 1:j] = True
    rest = ~same[1:][~out[1:]]  # the steps outside the long runs: do they change?
    if rest.size < 10 or np.mean(rest) < 0.5:
        out[:] = False
    return out


def clipped_rows(a: np.ndarray, range_g: float) -> np.ndarray:
    """‖a‖ beyond ``range_g``, or at the axis' log maximum (above 2 g: gravity alone never gets
    there) for ≥ 3 consecutive samples: a saturated converter reads one value.

    Parameters
    ----------
    a : ndarray
        Acceleration, shape (n, axes) [g].
    range_g : float
        The part's full scale [g].

    Returns
    -------
    ndarray of bool
        Rows of a saturated converter.
    """
    mag = np.abs(a)
    out = (mag >= range_g).any(axis=1)
    for k in np.flatnonzero(mag.max(axis=0) > 2.0):
        for i, j in runs(mag[:, k] >= mag[:, k].max() * (1 - 1e-6)):
            out[i:j] |= j - i >= 3
    return out
