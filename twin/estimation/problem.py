"""The measurement prepared for modelling (docs/diagnosis.md §1 step 1) and the model's design.

The thermometer is smoothed with a zero-phase filter only (a causal one would inject the lag the
tool then "discovers"); blocks are averaged (10 s) for screening.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import numpy as np

from twin.arrays import interleaved_folds, moving_mean, run_slices
from twin.estimation.noise import BlockAverager
from twin.effects import Composition, EffectInputs, get_effect
from twin.measurement import Measurement


@dataclass
class DiagnosisConfig:
    """Settings of the diagnosis; defaults as in docs/diagnosis.md §1.

    Attributes
    ----------
    average_s : float
        Block length of the screening means [s] (step 1).
    smooth_temperature_s : float
        Window of the zero-phase temperature smoothing [s] (step 1).
    max_ar_order : int
        Largest AR order of the noise model (step 3).
    alpha, min_delta_bic, min_heldout_gain : float
        Decision rule: adjusted p below ``alpha`` [1], ΔBIC above ``min_delta_bic`` [1], held-out
        gain above ``min_heldout_gain`` [1] (step 4).
    cv_folds : int
        Cross-validation folds (step 4).
    cv_block_s : float
        Length of the interleaved cross-validation blocks [s] (step 4).
    max_added : int
        Most effects named by forward selection (step 5).
    alias_novelty, alias_correlation : float
        Novelty below which a candidate is untestable, and the |ρ| above which two are aliased [1]
        (step 0).
    slow_window_s : float
        Smoothing window of the slow residual for the confidence label [s] (step 5).
    """

    average_s: float = 10.0
    smooth_temperature_s: float = 10.0
    max_ar_order: int = 20
    alpha: float = 0.01
    min_delta_bic: float = 10.0
    min_heldout_gain: float = 0.05
    cv_folds: int = 5
    cv_block_s: float = 300.0
    max_added: int = 3
    alias_novelty: float = 0.02
    alias_correlation: float = 0.9
    slow_window_s: float = 1800.0


class Problem:
    """A measurement prepared for modelling (docs/diagnosis.md §1 step 1).

    Parameters
    ----------
    m : Measurement
        Time [s], temperature [°C], output and applied acceleration [g], runs.
    config : DiagnosisConfig
    time_since_power_on_s : np.ndarray, optional
        Per row [s]; given when ``m`` holds block means of a faster log.

    Attributes
    ----------
    rate_hz : float
        Sample rate of ``m`` [Hz].
    applied : np.ndarray
        Applied acceleration [g]; the run's median output where the orientation is unknown.
    inputs : EffectInputs
        The effects' inputs, die temperature = the smoothed thermometer [°C].
    y : np.ndarray
        Output minus applied [g].
    avg : BlockAverager
        The ``average_s`` blocks inside runs.
    run_avg : np.ndarray
        Run of each block.
    nuisance : np.ndarray
        Per-run offset columns, and the scale-factor column K1 (IEEE Std 1293) on a tumble.
    nuisance_names : list of str
    averaged : dict
        Block means of the effects' columns, kept by :func:`averaged_design`.
    """

    def __init__(self, m: Measurement, config: DiagnosisConfig, time_since_power_on_s: np.ndarray | None = None):
        self.m, self.config = m, config
        rate = m.sample_rate_hz
        self.rate_hz = rate
        w = max(1, int(round(config.smooth_temperature_s * rate)))
        temp = np.empty_like(m.temperature_c)
        for s in run_slices(m.run_index):
            temp[s] = moving_mean(m.temperature_c[s], w)
        applied = m.applied_g.copy()
        if not m.applied_known:  # orientation unknown: a per-run constant (absorbed by per-run offsets)
            for s in run_slices(m.run_index):
                applied[s] = np.median(m.output_g[s])
        self.applied = applied
        self.inputs = EffectInputs(time_s=m.time_s, die_c=temp, thermometer_c=temp, applied_g=applied,
                                   run_index=m.run_index,
                                   time_since_power_on_s=m.time_since_power_on_s() if time_since_power_on_s is None
                                   else time_since_power_on_s)
        self.y = m.output_g - applied
        self.avg = BlockAverager.build(m.run_index, int(round(config.average_s * rate)))
        self.run_avg = self.avg.run_of_block
        cols, names = [], []
        for r in range(m.runs):
            cols.append((m.run_index == r).astype(float))
            names.append(f"offset_run{r}")
        # sensitivity error K1 (IEEE 1293): separable from the per-run offsets only when the
        # orientation changes within a run (a tumble); with one orientation per run it is their difference
        if m.applied_known and any(np.std(applied[s]) > 0.1 for s in run_slices(m.run_index)):
            cols.append(applied)
            names.append("scale_factor_k1")
        self.nuisance = np.column_stack(cols)
        self.nuisance_names = names
        self.averaged: dict = {}  # block means of effects' columns (averaged_design)

    @property
    def n(self) -> int:
        """Number of samples [1]."""
        return int(self.y.size)

    @cached_property
    def nuisance_means(self) -> np.ndarray:
        """Block means of the nuisance columns (blocks × columns)."""
        return self.avg(self.nuisance)

    @cached_property
    def y_means(self) -> np.ndarray:
        """Block means of y [g]."""
        return self.avg(self.y)


def design_matrix(problem: Problem, comp: Composition, pinned: frozenset = frozenset()
                  ) -> tuple[np.ndarray, list[tuple[str, str]], np.ndarray, EffectInputs]:
    """Full-rate columns of the model's free amplitudes, their names, the fixed part, the inputs.

    ``pinned`` amplitudes (exactly aliased ones) are held at their current values.

    Parameters
    ----------
    problem : Problem
        The prepared measurement.
    comp : Composition
        The model.
    pinned : frozenset of (effect, amplitude)
        Amplitudes held at their current values.

    Returns
    -------
    X : np.ndarray
        n × k columns, one per free amplitude, per unit of the parameter.
    names : list of (effect, amplitude)
        The columns' names.
    fixed : np.ndarray
        The output of everything not free [g].
    inputs : EffectInputs
        The inputs with the model's die temperature.
    """
    inputs = comp.with_die_temperature(problem.inputs)
    cols, names = [], []
    fixed = np.zeros(problem.n)
    for e in comp.drift_effects:
        free = _free_amplitudes(e, pinned)
        for amp, contrib in e.basis(inputs).items():
            col = np.broadcast_to(contrib.output_g(problem.applied), (problem.n,)).astype(float)
            if amp in free:
                cols.append(col)
                names.append((e.name, amp))
            else:
                fixed += e.values[amp] * col
    X = np.column_stack(cols) if cols else np.zeros((problem.n, 0))
    return X, names, fixed, inputs


def _free_amplitudes(e, pinned: frozenset) -> set[str]:
    """The amplitudes of ``e`` a fit calibrates: free ones (all, for an effect added by the user:
    ``fit_all``), less the pinned."""
    fit_all = e.context.get("fit_all", False)
    return {p.name for p in e.parameters
            if p.role == "amplitude" and (p.free or fit_all) and (e.name, p.name) not in pinned}


# effects' averaged columns a Problem keeps, least recently used dropped first: a fit varies one
# parameter while the few other effects of its model stay (a column is 8 bytes per 10-s block:
# 69 kB for a day, 0.5 MB for a week)
AVERAGED_CACHE = 32


def averaged_design(problem: Problem, comp: Composition, pinned: frozenset = frozenset()
                    ) -> tuple[np.ndarray, np.ndarray, list[tuple[str, str]]]:
    """The block means of :func:`design_matrix`: A = means of [nuisance, X], b = means of y − fixed.

    Means are linear, so each effect's columns are averaged once and kept on the problem, keyed by
    the effect's values and the temperature slot's (the :data:`AVERAGED_CACHE` most recently used): a search over
    one nonlinear parameter recomputes that effect only, or, for the temperature slot, the effects
    reading the die temperature. An effect whose values or context cannot be a key is recomputed
    every time.

    Parameters
    ----------
    problem : Problem
        The prepared measurement.
    comp : Composition
        The model.
    pinned : frozenset of (effect, amplitude)
        Amplitudes held at their current values.

    Returns
    -------
    A : np.ndarray
        Block means of the nuisance and free-amplitude columns.
    b : np.ndarray
        Block means of y minus everything not free [g].
    names : list of (effect, amplitude)
        The free columns' names.
    """
    cache = problem.averaged
    slot = comp.temperature_effect
    inputs = None
    cols, names, b = [problem.nuisance_means], [], problem.y_means
    for e in comp.drift_effects:
        key = _effect_key(e, slot)
        averaged = cache.pop(key, None) if key is not None else None  # re-inserted below: most recent last
        if averaged is None:
            if inputs is None:
                inputs = comp.with_die_temperature(problem.inputs)
            averaged = {amp: problem.avg(np.broadcast_to(contrib.output_g(problem.applied), (problem.n,)))
                        for amp, contrib in e.basis(inputs).items()}
            if len(cache) >= AVERAGED_CACHE:  # the least recently used (dicts keep insertion order)
                del cache[next(iter(cache))]
        if key is not None:
            cache[key] = averaged
        free = _free_amplitudes(e, pinned)
        for amp, col in averaged.items():
            if amp in free:
                cols.append(col[:, None])
                names.append((e.name, amp))
            else:
                b = b - e.values[amp] * col
    return np.column_stack(cols), b, names


def _effect_key(e, slot) -> tuple | None:
    """What an effect's basis depends on besides the problem: its class, values and context, and
    the temperature slot's (``None`` when one of them cannot be hashed)."""
    def of(effect):
        return (type(effect), tuple(sorted(effect.values.items())), tuple(sorted(effect.context.items())))
    key = (of(e), of(slot) if slot is not None else None)
    try:
        hash(key)
    except TypeError:
        return None
    return key


def amplitude_bounds(names: list[tuple[str, str]], n_nuisance: int) -> tuple[np.ndarray, np.ndarray]:
    """Lower and upper bounds of the nuisance (unbounded) then the named amplitudes.

    Parameters
    ----------
    names : list of (effect, amplitude)
        Amplitude columns, as from :func:`design_matrix`.
    n_nuisance : int
        Number of nuisance columns before them.

    Returns
    -------
    lo, hi : np.ndarray
        Per column [the amplitude's unit; ±inf for the nuisance].
    """
    lo, hi = [-np.inf] * n_nuisance, [np.inf] * n_nuisance
    for eff, amp in names:
        p = next(p for p in get_effect(eff).parameters if p.name == amp)
        lo.append(p.bounds[0])  # columns are per unit of the parameter: bounds apply as they are
        hi.append(p.bounds[1])
    return np.array(lo), np.array(hi)


def cv_folds(problem: Problem) -> np.ndarray:
    """Fold of each averaged block for interleaved-block cross-validation: the diagnosis's layout
    (blocks of ``cv_block_s``, ``cv_folds`` folds) of :func:`twin.arrays.interleaved_folds`.

    Parameters
    ----------
    problem : Problem

    Returns
    -------
    np.ndarray
        Fold index (``0 … cv_folds − 1``) of each block, in blocks of ``cv_block_s``.
    """
    cfg = problem.config
    block = max(1, int(round(cfg.cv_block_s / cfg.average_s)))
    return interleaved_folds(np.arange(problem.run_avg.size), cfg.cv_folds, block_rows=block)
