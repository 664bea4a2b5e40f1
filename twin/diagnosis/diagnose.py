"""Compare the twin with a measurement, show where it fails, and name the missing effect.

Pipeline (docs/diagnosis.md §1), one module per step:

0. **Audit** (:mod:`~twin.diagnosis.audit`): novelty of every effect against what the calibrated
   model can already absorb (per-run offsets, the model's own free amplitudes): aliased or
   untestable effects are listed with the test step that would separate them.
1. **Prepare** (:mod:`~twin.diagnosis.problem`): the thermometer smoothed with a zero-phase filter
   only (a causal one would inject the lag the tool then "discovers"); blocks averaged (10 s) for
   screening.
2. **Calibrate** (:mod:`~twin.diagnosis.calibrate`) the twin's effects: bounded linear least
   squares for amplitudes, profile search and bounded refinement for nonlinear parameters, 95 %
   intervals from the prewhitened (GLS) fit.
3. **Noise model** (:mod:`~twin.diagnosis.noise`): AR(p), p by BIC ≤ 20, prewhitening per run
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

The finding is worded by :mod:`~twin.diagnosis.language`, the JSON by :mod:`~twin.diagnosis.contract`.
Compare is blind: it sees the scenario's ``twin``, ``device.sensor`` and ``test_plan`` and the
measurement's columns, never ``device.effects`` or ground truth.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from twin.diagnosis.audit import audit
from twin.diagnosis.calibrate import Calibration, calibrate
from twin.diagnosis.language import finding_text
from twin.diagnosis.linalg import heldout_sse
from twin.diagnosis.noise import white_noise_sigma_from_differences
from twin.diagnosis.problem import Problem, cv_folds
from twin.diagnosis.screen import (
    CandidateResult,
    candidate_names,
    refine_grid_value,
    screen,
)
from twin.diagnosis.segments import residual_segments
from twin.diagnosis.structure import residual_structure
from twin.diagnosis.selection import assess_confidence, forward_selection
from twin.effects import Composition, get_effect

#: above this multiple of the white-noise floor, a finding may say "no missing effect" only when the
#: residual has no structure in temperature, rate or time (the issue's honesty rule)
HONESTY_RATIO = 1.1


@dataclass
class Diagnosis:
    calibration: Calibration
    problem: Problem
    candidates: list[CandidateResult]
    selected: list[CandidateResult]
    aliases: list[dict]
    untestable: list[dict]
    model_aliased: list[dict]
    noise_floor_g: float
    noise_floor_model_g: float | None
    confidence: str
    finding: str
    heldout_rms_g: float
    slow_share: float | None
    run_consistent: bool | None
    segments: dict
    withheld: list[dict] = field(default_factory=list)
    # other families aliased with the named one, with ≥ ½ its ΔBIC under either noise model
    rivals: list[str] = field(default_factory=list)
    structure: list = field(default_factory=list)  # Structure: where the residual is not noise (after named effects)
    rms_after_selected_g: float = float("nan")  # residual with the named effects added
    family_choices: list[dict] = field(default_factory=list)  # a family's candidates calibrated whole (BIC)
    discovery: object | None = None  # a Discovery, when ``--discover`` ran
    plugin_path: str | None = None  # where the discovered term was written as an effect

    @property
    def rms_residual_g(self) -> float:
        return float(np.sqrt(np.mean(self.calibration.residual ** 2)))


def diagnose(problem: Problem, comp: Composition, noise_floor_model_g: float | None = None) -> Diagnosis:
    """Calibrate, audit, screen, select; see the module docstring.

    Parameters
    ----------
    problem : Problem
        The prepared measurement.
    comp : Composition
        The twin's model (never the device's effects).
    noise_floor_model_g : float, optional
        Per-sample noise σ of the sensor model, reported beside the one from the data.

    Returns
    -------
    Diagnosis
    """
    cal = calibrate(problem, comp)
    names = _candidates_to_screen(problem, cal)
    n_tests = sum(len(get_effect(c).grid()) for c in names)
    first = screen(problem, cal, names, n_tests=n_tests)
    selection = forward_selection(problem, cal, first, n_tests)
    _refine_named(problem, cal, selection.selected)
    _rms_after_adding(problem, cal, first)
    found = audit(problem, cal, first)
    floor = white_noise_sigma_from_differences(cal.residual, problem.m.run_index)
    conf = assess_confidence(problem, cal, selection, found.aliases, found.confounded, first)
    d = Diagnosis(cal, problem, first, selection.selected, found.aliases, found.untestable, found.model_aliased,
                  floor, noise_floor_model_g, conf.label, "", _heldout_rms(problem, cal), conf.slow_share,
                  conf.run_consistent, residual_segments(problem, cal.residual), selection.withheld, conf.rivals)
    d.family_choices = selection.family_choices
    d.rms_after_selected_g = _rms_with(problem, cal, selection.selected)
    if d.rms_after_selected_g > HONESTY_RATIO * floor:  # only then can "no missing effect" be wrong
        d.structure = residual_structure(problem, cal, selection.selected, floor)
    d.finding = finding_text(d)
    return d


def _rms_with(problem: Problem, cal: Calibration, selected: list[CandidateResult]) -> float:
    """Residual RMS at the sample rate with the named effects added (linear refit on averages)."""
    if not selected:
        return float(np.sqrt(np.mean(cal.residual ** 2)))
    A_full = np.column_stack([cal.X_full] + [c.columns_full for c in selected])
    y = problem.y - cal.fixed_full
    beta = np.linalg.lstsq(problem.avg(A_full), problem.avg(y), rcond=None)[0]
    r = y - A_full @ beta
    return float(np.sqrt(np.mean(r * r)))


def _candidates_to_screen(problem: Problem, cal: Calibration) -> list[str]:
    names = candidate_names(cal.composition)
    if not problem.m.applied_known:
        names = [n for n in names if get_effect(n).family != "scale_factor"]
    return names


def _refine_named(problem: Problem, cal: Calibration, selected: list[CandidateResult]) -> None:
    # the finding quotes the named effect's τ or width between grid points, not a grid point
    if selected:
        A_avg = problem.avg(cal.X_full)
        y_avg = problem.avg(problem.y - cal.fixed_full)
        selected[0].refined_values = refine_grid_value(problem, cal, selected[0], A_avg, y_avg)


def _rms_after_adding(problem: Problem, cal: Calibration, candidates: list[CandidateResult]) -> None:
    """Error after adding each candidate (linear refit at its best grid point), at the sample rate."""
    A_full = cal.X_full
    A_avg = problem.avg(A_full)
    y_avg = problem.avg(problem.y - cal.fixed_full)
    for c in candidates:
        X = c.columns_full
        beta = np.linalg.lstsq(np.column_stack([A_avg, problem.avg(X)]), y_avg, rcond=None)[0]
        r = problem.y - cal.fixed_full - np.column_stack([A_full, X]) @ beta
        c.rms_residual_g = float(np.sqrt(np.mean(r * r)))


def _heldout_rms(problem: Problem, cal: Calibration) -> float:
    """RMS of the calibrated model's held-out errors on averages (interleaved-block CV)."""
    folds = cv_folds(problem)
    return float(np.sqrt(heldout_sse(problem.avg(cal.X_full), problem.avg(problem.y - cal.fixed_full), folds)
                         / problem.run_avg.size))
