"""Compare the twin with a measurement, show where it fails, and name the missing effect.

Pipeline (docs/diagnosis.md §1), one module per step:

0. **Audit** (:mod:`~twin.diagnosis.audit`): novelty of every effect against what the calibrated
   model can already absorb (per-run offsets, the model's own free amplitudes): aliased or
   untestable effects are listed with the test step that would separate them.
1. **Prepare** (:mod:`~twin.estimation.problem`): the thermometer smoothed with a zero-phase filter
   only (a causal one would inject the lag the tool then "discovers"); blocks averaged (10 s) for
   screening.
2. **Calibrate** (:mod:`~twin.estimation.fit`) the twin's effects: bounded linear least
   squares for amplitudes, profile search and bounded refinement for nonlinear parameters, 95 %
   intervals from the prewhitened (GLS) fit.
3. **Noise model** (:mod:`~twin.estimation.noise`): AR(p), p by BIC ≤ 20, prewhitening per run
   keeping the first samples.
4. **Screen** (:mod:`~twin.diagnosis.screen`) every registered effect not in the model on its
   parameter grid: prewhitened F-test, Bonferroni over every test, ΔBIC, held-out gain by
   interleaved-block cross-validation. Decision: p_adj < 0.01 AND ΔBIC > 10 AND held-out gain > 5 %.
5. **Forward selection** (:mod:`~twin.diagnosis.selection`) for several effects: the best-ranked
   significant candidate is named, unless a testable candidate of another family outranks it
   (more ΔBIC, short of a threshold); then nothing is named, the pair is reported as ``withheld``
   and the confidence is uncertain. Significant candidates of one family are calibrated whole:
   the one with the fewest parameters is named unless a richer one is decisively better (a lag
   needs no amplitude of its own; a gradient does). A confidence label from the slow-residual
   share and run consistency.

The finding is worded and the compare result built by :mod:`twin.finding`.
Compare is blind: it sees the scenario's ``twin``, ``device.sensor`` and ``test_plan`` and the
measurement's columns, never ``device.effects`` or ground truth.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from twin.diagnosis.audit import audit
from twin.estimation.fit import TwinFit, fit_twin
from twin.estimation.linalg import heldout_sse
from twin.estimation.noise import white_noise_sigma_from_differences
from twin.estimation.problem import Problem, cv_folds
from twin.diagnosis.screen import (
    CandidateResult,
    candidate_names,
    refine_grid_value,
    screen,
)
from twin.diagnosis.records import (
    PER_RUN_OFFSETS, Alias, FamilyChoice, ModelAliased, SeparatedAlias, Untestable, Withheld,
)
from twin.diagnosis.segments import ResidualSplit, residual_segments, segment_kinds
from twin.diagnosis.structure import Structure, residual_structure
from twin.diagnosis.selection import assess_confidence, cross_family_partners, forward_selection
from twin.effects import Composition, get_effect

#: above this multiple of the white-noise floor, a finding may say "no missing effect" only when the
#: residual has no structure in temperature, rate or time (the issue's honesty rule)
HONESTY_RATIO = 1.1


@dataclass(frozen=True, eq=False)
class Diagnosis:
    """The twin calibrated to a measurement, what it leaves, and what is named as missing.

    Built once by :func:`diagnose`; :mod:`twin.finding` words it and makes the compare result.

    Attributes
    ----------
    fit : TwinFit
        The twin calibrated to the measurement.
    problem : Problem
        The measurement as modelled (block means for a fast log).
    candidates : list of CandidateResult
        The first screening of every effect not in the twin, best first.
    selected : list of CandidateResult
        The effects named missing, in the order named.
    aliases, untestable, model_aliased : list
        The audit: what this data cannot separate or test (:mod:`twin.diagnosis.records`).
    withheld, family_choices : list
        The selection's records: significant but outranked candidates, and the choice within a family.
    confidence : str
        ``confident``, ``uncertain`` or ``none``.
    slow_share : float or None
        Share of the slow residual [1] the first named effect removes.
    run_consistent : bool or None
        Its coefficient is the same in every run (None: one run).
    rivals : list of str
        Effects of other families aliased with the named one, with ≥ ½ its ΔBIC under either noise model.
    noise_floor_g : float
        White-noise floor of the residual from the data [g].
    noise_floor_model_g : float or None
        Per-sample noise σ of the sensor model [g].
    heldout_rms_g : float
        RMS of the calibrated twin's held-out errors on block means [g].
    segments : ResidualSplit
        The residual RMS by segment, run, orientation and temperature bin.
    segment_kind : ndarray of str
        ``heating``, ``cooling`` or ``dwell`` for each row of the problem.
    structure : list of Structure
        Where the residual (with the named effects) is not white noise.
    rms_after_selected_g : float
        Residual RMS with the named effects added [g].
    separated : list of SeparatedAlias
        Alias groups with the named effect that the evidence tells apart all the same.
    """

    fit: TwinFit
    problem: Problem
    candidates: list[CandidateResult]
    selected: list[CandidateResult]
    aliases: list[Alias]
    untestable: list[Untestable]
    model_aliased: list[ModelAliased]
    withheld: list[Withheld]
    family_choices: list[FamilyChoice]
    confidence: str
    slow_share: float | None
    run_consistent: bool | None
    rivals: list[str]
    noise_floor_g: float
    noise_floor_model_g: float | None
    heldout_rms_g: float
    segments: ResidualSplit
    segment_kind: np.ndarray
    structure: list[Structure]
    rms_after_selected_g: float
    separated: list[SeparatedAlias]

    @property
    def rms_residual_g(self) -> float:
        """Residual RMS of the calibrated twin on the problem's rows [g]."""
        return float(np.sqrt(np.mean(self.fit.residual ** 2)))

    @property
    def above_noise_floor(self) -> bool:
        """The residual stands above ``HONESTY_RATIO`` × the white-noise floor."""
        return self.rms_residual_g > HONESTY_RATIO * self.noise_floor_g

    @property
    def samples(self) -> int:
        """Samples of the measurement."""
        return self.problem.n

    @property
    def sample_rate_hz(self) -> float:
        """Sample rate of the measurement [Hz]."""
        return self.problem.rate_hz

    @property
    def means_of(self) -> int | None:
        """Samples per row diagnosed, when a fast log was diagnosed on means (else None)."""
        return None


def diagnose(problem: Problem, comp: Composition, noise_floor_model_g: float | None = None) -> Diagnosis:
    """Calibrate, audit, screen, select; see the module docstring.

    Parameters
    ----------
    problem : Problem
        The prepared measurement.
    comp : Composition
        The twin's model (never the device's effects).
    noise_floor_model_g : float, optional
        Per-sample noise σ of the sensor model [g], reported beside the one from the data.

    Returns
    -------
    Diagnosis
    """
    cal = fit_twin(problem, comp)
    names = _candidates_to_screen(problem, cal)
    n_tests = sum(len(get_effect(c).grid()) for c in names)
    first = screen(problem, cal, names, n_tests=n_tests)
    selection = forward_selection(problem, cal, first, n_tests)
    _refine_named(problem, cal, selection.selected)
    _rms_after_adding(problem, cal, first)
    found = audit(problem, cal, first)
    floor = white_noise_sigma_from_differences(cal.residual, problem.m.run_index)
    conf = assess_confidence(problem, cal, selection, found.aliases, found.confounded, first)
    rms_after = _rms_with(problem, cal, selection.selected)
    kind = segment_kinds(problem)
    return Diagnosis(
        fit=cal, problem=problem, candidates=first, selected=selection.selected, aliases=found.aliases,
        untestable=found.untestable, model_aliased=found.model_aliased, withheld=selection.withheld,
        family_choices=selection.family_choices, confidence=conf.label, slow_share=conf.slow_share,
        run_consistent=conf.run_consistent, rivals=conf.rivals, noise_floor_g=floor,
        noise_floor_model_g=noise_floor_model_g, heldout_rms_g=_heldout_rms(problem, cal),
        segments=residual_segments(problem, cal.residual, kind), segment_kind=kind,
        # only above the honesty ratio can "no missing effect" be wrong
        structure=(residual_structure(problem, cal, selection.selected, floor)
                   if rms_after > HONESTY_RATIO * floor else []),
        rms_after_selected_g=rms_after, separated=_separated(found.aliases, selection.selected, conf.rivals, first))


def _separated(aliases: list[Alias], selected: list[CandidateResult], rivals: list[str],
               first: list[CandidateResult]) -> list[SeparatedAlias]:
    """Alias groups holding the named effect whose other-family partners the evidence outranks
    (none when a rival explains the data as well)."""
    if not selected or rivals:
        return []
    top, out = selected[0], []
    for a in aliases:
        if a.aliased_with == PER_RUN_OFFSETS:
            continue
        others = cross_family_partners(top, [a], first)
        if others:
            best = max(others, key=others.get)
            out.append(SeparatedAlias(a.effects, top.effect, top.delta_bic, best, others[best]))
    return out


def _rms_with(problem: Problem, cal: TwinFit, selected: list[CandidateResult]) -> float:
    """Residual RMS at the sample rate with the named effects added (linear refit on averages)."""
    if not selected:
        return float(np.sqrt(np.mean(cal.residual ** 2)))
    A_full = np.column_stack([cal.X_full] + [c.columns_full for c in selected])
    y = problem.y - cal.fixed_full
    beta = np.linalg.lstsq(problem.avg(A_full), problem.avg(y), rcond=None)[0]
    r = y - A_full @ beta
    return float(np.sqrt(np.mean(r * r)))


def _candidates_to_screen(problem: Problem, cal: TwinFit) -> list[str]:
    names = candidate_names(cal.composition)
    if not problem.m.applied_known:
        names = [n for n in names if get_effect(n).family != "scale_factor"]
    return names


def _refine_named(problem: Problem, cal: TwinFit, selected: list[CandidateResult]) -> None:
    # the finding quotes the named effect's τ or width between grid points, not a grid point
    if selected:
        A_avg = problem.avg(cal.X_full)
        y_avg = problem.avg(problem.y - cal.fixed_full)
        selected[0].refined_values = refine_grid_value(problem, cal, selected[0], A_avg, y_avg)


def _rms_after_adding(problem: Problem, cal: TwinFit, candidates: list[CandidateResult]) -> None:
    """Error after adding each candidate (linear refit at its best grid point), at the sample rate."""
    A_full = cal.X_full
    A_avg = problem.avg(A_full)
    y_avg = problem.avg(problem.y - cal.fixed_full)
    for c in candidates:
        X = c.columns_full
        beta = np.linalg.lstsq(np.column_stack([A_avg, problem.avg(X)]), y_avg, rcond=None)[0]
        r = problem.y - cal.fixed_full - np.column_stack([A_full, X]) @ beta
        c.rms_residual_g = float(np.sqrt(np.mean(r * r)))


def _heldout_rms(problem: Problem, cal: TwinFit) -> float:
    """RMS of the calibrated model's held-out errors on averages (interleaved-block CV)."""
    folds = cv_folds(problem)
    return float(np.sqrt(heldout_sse(problem.avg(cal.X_full), problem.avg(problem.y - cal.fixed_full), folds)
                         / problem.run_avg.size))
