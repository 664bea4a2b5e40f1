"""Heating / cooling / dwell branches of a temperature log, and the validation protocols built on them.

The protocol for thermal compensation is "fit on heating, test on cooling" (and the reverse): the
two directions differ in the sign of every rate-dependent effect, so a model that only
interpolates in temperature fails visibly. With only heating there is nothing to test the rate
dependence on; interleaved blocks are then the fallback, with a note saying so.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from twin.arrays import interleaved_folds, run_slices, temperature_rate_c_per_s
from twin.calibration.lag import ThermalLog, as_log, lagged_c, make_X
from twin.errors import TwinError


@dataclass(frozen=True)
class Branch:
    """A monotone (or constant) stretch of the temperature log.

    Attributes
    ----------
    kind : {"heating", "cooling", "dwell"}
    start, stop : int
        Sample indices, ``stop`` exclusive.
    start_c, stop_c, min_c, max_c : float
        Temperatures at the ends and extremes [°C].
    duration_s : float
    mean_rate_c_per_min : float
    run : int
    """

    kind: str
    start: int
    stop: int
    start_c: float
    stop_c: float
    min_c: float
    max_c: float
    duration_s: float
    mean_rate_c_per_min: float
    run: int = 0

    @property
    def index(self) -> np.ndarray:
        """Sample indices ``start:stop`` of the branch [rows]."""
        return np.arange(self.start, self.stop)

    def label(self, k: int) -> str:
        """Name of the branch for tables, e.g. ``"heating 1 (25.0→60.0 °C)"``.

        Parameters
        ----------
        k : int
            Its number among the branches of its kind (1-based).

        Returns
        -------
        str
            The label, with the end temperatures [°C].
        """
        return f"{self.kind} {k} ({self.start_c:.1f}→{self.stop_c:.1f} °C)"


def _zero_phase(log: ThermalLog, tau_s: float) -> np.ndarray:
    """Forward-backward first-order smoothing (no delay, so turning points stay in place)."""
    fwd = lagged_c(log, tau_s)
    back = ThermalLog(log.time_s[-1] - log.time_s[::-1], fwd[::-1], log.run[::-1])
    return lagged_c(back, tau_s)[::-1]


def _pivots(s: np.ndarray, span_c: float) -> list[int]:
    """Zigzag turning points: an extreme is confirmed once the signal has left it by ``span_c``."""
    pivots, trend, hi, lo, cand = [0], 0, 0, 0, 0
    for k in range(1, s.size):
        if trend == 0:
            hi, lo = (k if s[k] > s[hi] else hi), (k if s[k] < s[lo] else lo)
            if s[hi] - s[lo] >= span_c:
                trend, cand = (1, hi) if hi > lo else (-1, lo)
        elif (s[k] - s[cand]) * trend > 0:
            cand = k
        elif (s[cand] - s[k]) * trend >= span_c:
            pivots.append(cand)
            trend, cand = -trend, k
    return pivots + [s.size - 1]


def split_branches(time_s, temperature_c, min_span_c: float = 5.0, smooth_s: float = 60.0,
                   dwell_rate_c_per_min: float = 0.1, min_dwell_s: float = 600.0, run=None) -> list[Branch]:
    """Split a log into heating, cooling and dwell branches.

    Parameters
    ----------
    time_s, temperature_c : (n,) arrays
    min_span_c : float
        A reversal smaller than this [°C] is noise, not a branch (it stays inside its branch).
    smooth_s : float
        Time constant [s] of the zero-phase smoothing used to find turning points and dwells.
    dwell_rate_c_per_min : float
        Below this |rate| for at least ``min_dwell_s``, a stretch is a dwell.
    run : (n,) int array, optional
        Run id per sample; branches never cross runs.

    Returns
    -------
    list of Branch, in time order. Turning points sit at the raw extreme nearest the smoothed one;
        each belongs to the heating branch beside it.
    """
    log = as_log(make_X(time_s, temperature_c, run))
    raw = log.temperature_c
    smooth = _zero_phase(log, smooth_s / 2)
    out: list[Branch] = []
    for seg in log.segments():
        t, s = log.time_s[seg], smooth[seg]
        step = max(float(np.median(np.diff(t))), 1e-9)
        stride = max(int(smooth_s / 4 / step), 1)  # the zigzag loop runs on a decimated copy
        pick = np.r_[np.arange(0, s.size, stride), s.size - 1]
        half = max(int(smooth_s / step), 1)
        edges = []
        for p in _pivots(s[pick], min_span_c)[1:-1]:
            k = pick[p]
            lo, hi = max(k - half, 0), min(k + half + 1, s.size)
            local = raw[seg][lo:hi]
            # a turning point belongs to the heating branch beside it (heating spans min → max)
            if s[k] >= s[max(k - stride, 0)]:
                edges.append(lo + int(np.argmax(local)) + 1)
            else:
                edges.append(lo + int(np.argmin(local)))
        bounds = np.array([0, *edges, s.size], dtype=int)
        rate = temperature_rate_c_per_s(t, s) * 60.0  # °C/min of the zero-phase smoothed temperature
        for a, b in zip(bounds[:-1], bounds[1:]):
            out += _with_dwells(seg.start, a, b, t, raw[seg], rate, dwell_rate_c_per_min, min_dwell_s,
                                min_span_c, int(log.run[seg.start]))
    return out


def _with_dwells(offset, a, b, t, raw, rate, dwell_rate, min_dwell_s, min_span_c, run) -> list[Branch]:
    """The branch [a, b) with its long slow stretches carved out as dwells."""
    slow = np.r_[0, (np.abs(rate[a:b]) < dwell_rate).astype(np.int8), 0]
    starts, stops = np.flatnonzero(np.diff(slow) == 1), np.flatnonzero(np.diff(slow) == -1)
    cuts = [(a + i, a + j) for i, j in zip(starts, stops) if t[a + j - 1] - t[a + i] >= min_dwell_s]
    pieces, last = [], a
    for c0, c1 in cuts:
        pieces += [(last, c0, None), (c0, c1, "dwell")]
        last = c1
    pieces.append((last, b, None))
    out = []
    for p0, p1, kind in pieces:
        if p1 - p0 < 2:
            continue
        T = raw[p0:p1]
        if kind is None:
            kind = "heating" if T[-1] > T[0] else "cooling"
            if np.ptp(T) < min_span_c:
                kind = "dwell"  # a remnant beside a dwell, too small to be a branch
        dur = float(t[p1 - 1] - t[p0])
        out.append(Branch(kind, int(offset + p0), int(offset + p1), float(T[0]), float(T[-1]), float(T.min()),
                          float(T.max()), dur, float((T[-1] - T[0]) / max(dur, 1e-9) * 60), run))
    return out


@dataclass(frozen=True, eq=False)
class TestSet:
    """Held-out samples of one branch (or block) with the share outside the trained range.

    Attributes
    ----------
    name : str
        The branch or block.
    index : ndarray of int
        Held-out rows.
    extrapolated : ndarray of bool
        Per sample: temperature outside the training range.
    """

    name: str
    index: np.ndarray
    extrapolated: np.ndarray  # bool per sample: temperature outside the training range

    @property
    def extrapolated_fraction(self) -> float:
        """Share of the held-out samples outside the training temperature range [0–1]."""
        return float(self.extrapolated.mean()) if self.extrapolated.size else 0.0


@dataclass(frozen=True, eq=False)
class Fold:
    """Train on ``train`` (indices), test on each of ``tests``.

    Attributes
    ----------
    name : str
        The fold.
    train : ndarray of int
        Training rows.
    tests : tuple of TestSet
        Held-out sets.
    note : str
        Caveat, or empty.
    directions : tuple of str
        Thermal directions the training rows hold, each spanning enough.
    """

    name: str
    train: np.ndarray
    tests: tuple[TestSet, ...]
    note: str = ""
    directions: tuple[str, ...] = ()  # thermal directions the training rows hold, each spanning enough

    @property
    def both_directions(self) -> bool:
        """The training rows heat and cool: a rate-dependent term fitted on them is tested, not absorbed."""
        return len(self.directions) == 2


@dataclass(frozen=True, eq=False)
class Protocol:
    """A validation protocol: its folds, the branches it was built from, and caveats.

    Attributes
    ----------
    name : str
        The protocol.
    folds : tuple of Fold
        Its folds.
    branches : tuple of Branch
        The branches it was built from.
    note : str
        Caveat, or empty.
    """

    name: str
    folds: tuple[Fold, ...]
    branches: tuple[Branch, ...] = field(default=())
    note: str = ""


def _fold(name, temperature_c, train, tests, note="", branches=(), min_span_c: float = 10.0) -> Fold:
    # int32 rows below 2³¹: a long log's folds each hold most of its rows
    train = np.asarray(train, np.int32 if temperature_c.size < 2**31 else np.int64)
    lo, hi = temperature_c[train].min(), temperature_c[train].max()
    sets = tuple(TestSet(n, i, (temperature_c[i] < lo) | (temperature_c[i] > hi)) for n, i in tests if i.size)
    return Fold(name, train, sets, note, _directions(temperature_c, train, branches, min_span_c))


def _directions(temperature_c, train, branches, min_span_c: float) -> tuple[str, ...]:
    """The directions ("heating", "cooling") whose training rows span at least ``min_span_c`` °C."""
    rows = np.zeros(temperature_c.size, bool)
    rows[np.asarray(train)] = True
    out = []
    for kind in ("heating", "cooling"):
        of_kind = np.zeros_like(rows)
        for br in branches:
            of_kind[br.start:br.stop] |= br.kind == kind
        T = temperature_c[rows & of_kind]
        if T.size and np.ptp(T) >= min_span_c:
            out.append(kind)
    return tuple(out)


MAX_HELD_OUT_BRANCHES = 4  # folds of a long log: each refits every method on most of its rows


def spread_folds(folds: list, limit: int = MAX_HELD_OUT_BRANCHES) -> tuple:
    """At most ``limit`` of the leave-one-branch-out folds, in time order: the last (the forward fold,
    "calibrate today, fly tomorrow") and the others evenly spread over the log.

    Every fold refits every method on all the other branches, so leaving out each of a long log's
    branches costs folds × rows: a 6-hour tester log of 8 ramps took more per row than its first
    1.5 hours. A few branches spread over the log, both directions among them, test the same
    thing — fitted here, applied there — at a cost that grows with the log, not faster.

    Parameters
    ----------
    folds : list of Fold
        The candidate folds, in time order.
    limit : int
        Folds kept (≥ 1).

    Returns
    -------
    tuple of Fold
    """
    if len(folds) <= limit:
        return tuple(folds)
    # evenly spaced positions from the first to the last fold (the last one included)
    picks = np.unique(np.round(np.linspace(len(folds) - 1, 0, max(1, limit))).astype(int))
    return tuple(folds[i] for i in picks)


def protocol_as_used(time_s, temperature_c, run=None, reverse: bool = True, min_train_span_c: float = 10.0,
                     **split_kwargs) -> Protocol:
    """Folds that test a compensation the way it is used: fitted on one stretch, applied to another.

    In order of preference:

    1. several runs: leave one run out;
    2. leave one heating or cooling branch out, wherever the other branches still heat and cool
       over ``min_train_span_c`` each (the last branch left out is "calibrate today, fly tomorrow");
    3. with two branches: forward in time (fit everything before the middle of the last branch,
       test the rest of it) and the first half of the last branch left out, each where the
       training rows hold both directions;
    4. otherwise the one-direction folds of :func:`protocol_heating_vs_cooling`, whose training
       rows cannot tell a rate-dependent term from the static curve (``Fold.both_directions`` is
       False, and the recommendation does not trust such a term on them).

    Every fold records the directions its training rows hold.

    Parameters
    ----------
    time_s, temperature_c : (n,) array-like
        Sample times [s] and temperatures [°C].
    run : (n,) array-like of int, optional
        Run id per sample.
    reverse : bool
        Also the reverse direction in the fallback folds.
    min_train_span_c : float
        Span [°C] each training direction needs.
    **split_kwargs
        Keywords of :func:`split_branches`.

    Returns
    -------
    Protocol
        The folds and the branches.
    """
    T = np.asarray(temperature_c, float)
    if run is not None and np.unique(np.asarray(run)).size > 1:
        return protocol_heating_vs_cooling(time_s, T, run=run, reverse=reverse, min_train_span_c=min_train_span_c,
                                           **split_kwargs)
    branches = split_branches(time_s, T, run=run, **split_kwargs)
    ramps = [b for b in branches if b.kind != "dwell"]
    labels = {id(b): b.label(k) for kind in ("heating", "cooling")
              for k, b in enumerate([b for b in ramps if b.kind == kind], start=1)}
    folds = []
    for b in ramps if len(ramps) > 1 else ():
        train = np.concatenate([o.index for o in ramps if o is not b])
        fold = _fold(f"{'forward' if b is ramps[-1] else 'leave out'}: {labels[id(b)]}", T, train,
                     [(labels[id(b)], b.index)], "", branches, min_train_span_c)
        if fold.both_directions:
            folds.append(fold)
    if not folds and len(ramps) >= 2:  # two branches: each half of the last one left out in turn
        last = ramps[-1]
        cut = (last.start + last.stop) // 2
        earlier = np.concatenate([o.index for o in ramps[:-1]])
        first, second = np.arange(last.start, cut), np.arange(cut, last.stop)
        for name, train, test in ((f"forward: second half of {labels[id(last)]}", np.r_[earlier, first],
                                   (f"{labels[id(last)]} from {T[cut]:.1f} °C", second)),
                                  (f"leave out: first half of {labels[id(last)]}", np.r_[earlier, second],
                                   (f"{labels[id(last)]} to {T[cut]:.1f} °C", first))):
            fold = _fold(name, T, train, [test], "", branches, min_train_span_c)
            if fold.both_directions:
                folds.append(fold)
    if folds:
        kept = spread_folds(folds)
        note = (f"{len(kept)} of the {len(folds)} branches that can be left out are (evenly spread, the last one "
                "included)" if len(kept) < len(folds) else "")
        return Protocol("held-out branches, both directions in training", kept, tuple(branches), note)
    return protocol_heating_vs_cooling(time_s, T, run=run, reverse=reverse, min_train_span_c=min_train_span_c,
                                       **split_kwargs)


def protocol_heating_vs_cooling(time_s, temperature_c, run=None, reverse: bool = True, n_blocks: int = 6,
                                min_train_span_c: float = 10.0, **split_kwargs) -> Protocol:
    """Folds "fit on heating, test on each cooling branch" (and the reverse).

    A direction whose rows span less than ``min_train_span_c`` trains no fold (the firmware fits
    need 10 °C); the fold left says so in its note, and with neither the blocks below are used.

    Several runs give leave-one-run-out folds instead (each held-out run tested per branch).
    A log with only one direction falls back to interleaved contiguous blocks (every other block
    held out), with a note: such a test cannot see rate-dependent errors. Dwells are in neither set.

    Parameters
    ----------
    time_s, temperature_c : (n,) array-like
        Sample times [s] and temperatures [°C].
    run : (n,) array-like of int, optional
        Run id per sample.
    reverse : bool
        Also fit on cooling and test on heating.
    n_blocks : int
        Blocks per half in the interleaved fallback.
    min_train_span_c : float
        Span [°C] a training direction needs.
    **split_kwargs
        Keywords of :func:`split_branches`.

    Returns
    -------
    Protocol
        The folds and the branches.

    Raises
    ------
    TwinError
        When too few samples remain for the interleaved blocks.
    """
    T = np.asarray(temperature_c, float)
    branches = split_branches(time_s, T, run=run, **split_kwargs)
    labelled = [(b, b.label(k)) for kind in ("heating", "cooling", "dwell")
                for k, b in enumerate([b for b in branches if b.kind == kind], start=1)]
    labelled.sort(key=lambda bl: bl[0].start)
    runs = np.unique(np.asarray(run)) if run is not None else np.zeros(1)
    if runs.size > 1:
        r = np.asarray(run)
        folds = tuple(_fold(f"leave out run {int(u)}", T, np.flatnonzero(r != u),
                            [(f"run {int(u)} {lab}", b.index) for b, lab in labelled if b.run == u], "",
                            branches, min_train_span_c)
                      for u in runs)
        return Protocol("leave one run out", folds, tuple(branches))
    idx = {kind: np.concatenate([b.index for b in branches if b.kind == kind] or [np.zeros(0, int)])
           for kind in ("heating", "cooling")}
    span = {kind: float(np.ptp(T[i])) if i.size else 0.0 for kind, i in idx.items()}
    # a fold trains every method, the firmware ones included: ArduPilot's fit refuses < 10 °C of range
    trainable = {kind: span[kind] >= min_train_span_c for kind in idx}
    if idx["heating"].size and idx["cooling"].size and (trainable["heating"] or trainable["cooling"] and reverse):
        skipped = [f"{a}→{b} not run: the {a} rows span {span[a]:.1f} °C < {min_train_span_c:g} °C"
                   for a, b in (("heating", "cooling"), ("cooling", "heating")) if not trainable[a]]
        note = "; ".join(skipped)
        folds = [_fold("heating→cooling", T, idx["heating"],
                       [(lab, b.index) for b, lab in labelled if b.kind == "cooling"], note, branches,
                       min_train_span_c)] if trainable["heating"] else []
        if reverse and trainable["cooling"]:
            folds.append(_fold("cooling→heating", T, idx["cooling"],
                               [(lab, b.index) for b, lab in labelled if b.kind == "heating"], note, branches,
                               min_train_span_c))
        return Protocol("fit on heating, test on cooling", tuple(folds), tuple(branches))
    pool = np.concatenate([idx["heating"], idx["cooling"]]) if (idx["heating"].size + idx["cooling"].size) else \
        np.arange(T.size)
    if pool.size < 4 * n_blocks:
        raise TwinError(f"{pool.size} samples are too few for {2 * n_blocks} interleaved blocks")
    half = interleaved_folds(np.arange(pool.size), 2, n_blocks)  # every other block held out
    train = pool[half == 0]
    blocks = [pool[b] for b in run_slices(half)]  # the halves alternate: each stretch of one is a block
    first = ("only one thermal direction in the log" if not (idx["heating"].size and idx["cooling"].size) else
             f"no thermal direction spans {min_train_span_c:g} °C alone (heating {span['heating']:.1f} °C, cooling "
             f"{span['cooling']:.1f} °C)")
    note = (f"{first}: interleaved blocks (every other block held out); "
            "test temperatures lie inside the fitted range, so rate-dependent errors go unseen")
    fold = _fold("interleaved blocks", T, train, [(f"block {2 * k + 1}", b) for k, b in enumerate(blocks[1::2])],
                 note, branches, min_train_span_c)
    return Protocol("interleaved blocks", (fold,), tuple(branches), note)
