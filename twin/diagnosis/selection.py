"""Forward selection and the confidence label (docs/diagnosis.md §1 step 5).

The best-ranked significant candidate is named, unless a testable candidate of another family
outranks it (more ΔBIC, short of a threshold); then nothing is named, the pair is reported as
``withheld`` and the confidence is uncertain. Between significant candidates of one family, the
whole calibrated models decide (:func:`choose_within_family`). The label comes from the
slow-residual share, run consistency, confounding and rival explanations.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import NamedTuple

import numpy as np

from twin.arrays import moving_mean
from twin.estimation.fit import TwinFit, fit_twin
from twin.estimation.decimate import block_aligned_factor, decimate
from twin.estimation.problem import DiagnosisConfig, Problem
from twin.estimation.tails import f_survival
from twin.diagnosis.records import Alias, FamilyChoice, FamilyModel, Withheld
from twin.diagnosis.screen import CandidateResult, is_testable, screen
from twin.effects import get_effect


class Pick(NamedTuple):
    """Outcome of :func:`next_selection`."""

    candidate: CandidateResult | None  # the best-ranked significant testable candidate
    blocker: CandidateResult | None  # a testable candidate of another family ranked above it


@dataclass
class Selection:
    """The forward selection's outcome (docs/diagnosis.md §1 step 5).

    Attributes
    ----------
    selected : list of CandidateResult
        Named, in order of selection.
    withheld : list of Withheld
        Significant but outranked by another family.
    family_choices : list of FamilyChoice
        One family's candidates, calibrated whole.
    """

    selected: list[CandidateResult] = field(default_factory=list)  # named, in order of selection
    withheld: list[Withheld] = field(default_factory=list)  # significant but outranked by another family
    family_choices: list[FamilyChoice] = field(default_factory=list)  # one family's candidates, calibrated whole


@dataclass
class Confidence:
    """The confidence label and the evidence behind it (docs/diagnosis.md §1 step 5).

    Attributes
    ----------
    label : str
        ``confident``, ``uncertain`` or ``none``.
    slow_share : float, optional
        Share of the slow (30-min smoothed) residual variance the named effect removes [1].
    run_consistent : bool, optional
        Its coefficient is the same in every run.
    rivals : list of str
        Other families aliased with at least half its ΔBIC (either noise model).
    """

    label: str  # "confident", "uncertain" or "none"
    slow_share: float | None = None  # share of the slow residual the named effect removes
    run_consistent: bool | None = None  # its coefficient is the same in every run
    rivals: list[str] = field(default_factory=list)  # other families aliased, ≥ ½ its ΔBIC (either noise model)


def next_selection(pool: list[CandidateResult], cfg: DiagnosisConfig) -> Pick:
    """The best-ranked significant testable candidate, and what outranks it if it cannot be claimed.

    A significant candidate ranked below a testable one of *another* family (more ΔBIC, but short
    of a threshold, e.g. held-out gain) is not claimed: the evidence prefers the other family, so
    naming either would be a guess.

    Parameters
    ----------
    pool : list of CandidateResult
        A screening, in rank order.
    cfg : DiagnosisConfig

    Returns
    -------
    Pick
        (candidate or None, blocking candidate or None).
    """
    above: list[CandidateResult] = []
    for c in pool:
        if not is_testable(c, cfg):
            continue
        if c.significant:
            return Pick(c, next((b for b in above if b.family != c.family), None))
        above.append(c)
    return Pick(None, None)


#: a richer model of one family displaces a simpler one only on very strong evidence, BIC lower by
#: more than 10 (Kass & Raftery 1995, J. Am. Stat. Assoc. 90, 773), that also matters: a residual
#: RMS on the prewhitened means lower by more than 1 % (significance is not importance at 10⁵ means)
DECISIVE_BIC = 10.0
MIN_RMS_GAIN = 0.01


def choose_within_family(problem: Problem, cal: TwinFit, top: CandidateResult, pool: list[CandidateResult],
                         named: list[CandidateResult]) -> tuple[CandidateResult, FamilyChoice | None]:
    """Among the significant candidates of ``top``'s family, the one to name, calibrated whole, and
    the comparison (None when the family has one significant candidate).

    Screening gives every candidate a free amplitude, so two effects with one column shape tie
    there and a τ grid point decides. Calibrated whole they differ: a die lag acts through the
    model's own tempcos and needs no amplitude of its own, a package gradient does. Each candidate
    is calibrated whole on top of the model and the effects named so far, on 1-s means (the 10-s
    means it is judged on are the same sums); BIC = n ln(RSS/n) + k ln n (Schwarz 1978) on the
    prewhitened 10-s means, one AR model for all (the best fit's), k counting offsets, free
    amplitudes and free nonlinear parameters. The candidate with the fewest parameters is named
    unless a richer one is lower in BIC by more than :data:`DECISIVE_BIC` and in residual RMS by
    more than :data:`MIN_RMS_GAIN`: on a day-long log a thermometer's own 2-s lag, which no lag
    model holds, makes the gradient's free amplitude worth 10 in BIC for a 0.1 % lower RMS.

    Parameters
    ----------
    problem, cal : Problem, TwinFit
    top : CandidateResult
        The pick of :func:`next_selection`.
    pool : list of CandidateResult
        The screening it came from.
    named : list of CandidateResult
        Effects named before it, included whole in every model.

    Returns
    -------
    candidate : CandidateResult
        The candidate named.
    comparison : FamilyChoice or None
        Why it is named (``fewest_parameters``, ``decisively_better`` or, all k equal,
        ``lowest_bic``), with each model's k, BIC against the named one's and residual over the best.
    """
    cfg = problem.config
    same = [c for c in pool if c.family == top.family and c.significant and is_testable(c, cfg)]
    if len(same) < 2:
        return top, None
    coarse = _on_second_means(problem)
    ctx = {k: v for k, v in (cal.composition.effects[0].context if cal.composition.effects else {}).items()
           if k != "fit_all"}
    base = cal.composition.added([c.effect for c in named], ctx)
    fits = {c.effect: fit_twin(coarse, base.added([c.effect], ctx), intervals=False) for c in same}
    best_fit = min(fits.values(), key=lambda f: float(f.residual_avg @ f.residual_avg))
    n = coarse.run_avg.size
    rss = {e: max(float(np.sum(best_fit.ar.prewhiten(f.residual_avg, coarse.run_avg) ** 2)), 1e-300)
           for e, f in fits.items()}
    bic = {e: n * np.log(rss[e] / n) + fits[e].free_parameters * np.log(n) for e in fits}
    simplest = min(fits, key=lambda e: (fits[e].free_parameters, bic[e]))
    lowest = min(fits, key=bic.get)
    decisive = bic[simplest] - bic[lowest] > DECISIVE_BIC and np.sqrt(rss[simplest] / rss[lowest]) > 1 + MIN_RMS_GAIN
    chosen = lowest if decisive else simplest
    reason = ("decisively_better" if chosen != simplest else "lowest_bic"
              if len({f.free_parameters for f in fits.values()}) == 1 else "fewest_parameters")
    models = sorted((FamilyModel(e, fits[e].free_parameters, float(bic[e] - bic[chosen]), rss[e] / min(rss.values()))
                     for e in fits), key=lambda m: (m.effect != chosen, m.bic_minus_named))
    return next(c for c in same if c.effect == chosen), FamilyChoice(top.family, chosen, top.effect, reason, tuple(models))


def _on_second_means(problem: Problem) -> Problem:
    """``problem`` on 1-s means (k samples, k dividing its 10-s blocks); itself at 1 Hz or slower."""
    k = block_aligned_factor(int(problem.rate_hz), int(round(problem.config.average_s * problem.rate_hz)))
    if k <= 1:
        return problem
    dec, blocks = decimate(problem.m, k)
    return Problem(dec, problem.config, time_since_power_on_s=blocks(problem.inputs.time_since_power_on_s))


def forward_selection(problem: Problem, cal: TwinFit, first: list[CandidateResult], n_tests: int) -> Selection:
    """Name effects one at a time, rescreening the other families on top of those named.

    Parameters
    ----------
    problem, cal : Problem, TwinFit
    first : list of CandidateResult
        The first screening: the pool the first pick comes from.
    n_tests : int
        Bonferroni count of the first screening, kept for every rescreening.

    Returns
    -------
    Selection
    """
    cfg = problem.config
    out = Selection()
    pool = first
    extra = None
    while pool and len(out.selected) < cfg.max_added:
        top, blocker = next_selection(pool, cfg)
        if blocker is not None:
            out.withheld.append(Withheld(top.effect, top.family, blocker.effect, blocker.family,
                                         (top.delta_bic, blocker.delta_bic)))
            break
        if top is None:
            break
        top, choice = choose_within_family(problem, cal, top, pool, out.selected)
        if choice is not None:
            out.family_choices.append(choice)
        out.selected.append(top)
        extra = np.column_stack([extra, top.columns_full]) if extra is not None else top.columns_full
        rest = [c.effect for c in pool if c.effect != top.effect and c.family != top.family]
        pool = screen(problem, cal, rest, extra=extra, n_tests=n_tests) if rest else []
    return out


def cross_family_partners(top: CandidateResult, aliases: list[Alias], candidates: list[CandidateResult]
                          ) -> dict[str, float]:
    """Effects of another family in an alias group with ``top`` (screened ones only) → their ΔBIC.

    Parameters
    ----------
    top : CandidateResult
    aliases : list of Alias
        From the audit.
    candidates : list of CandidateResult
        The screening that gives each effect's ΔBIC.

    Returns
    -------
    dict
        Effect name → ΔBIC.
    """
    dbic = {c.effect: c.delta_bic for c in candidates}
    return {e: dbic[e] for a in aliases if a.among_candidates and top.effect in a.effects
            for e in a.effects if e in dbic and get_effect(e).family != top.family}


def assess_confidence(problem: Problem, cal: TwinFit, selection: Selection, aliases: list[Alias],
                      confounded: bool, first: list[CandidateResult]) -> Confidence:
    """The confidence label of the finding.

    Parameters
    ----------
    problem : Problem
    cal : TwinFit
    selection : Selection
    aliases : list of Alias
        From the audit.
    confounded : bool
        The audit found temperature confounded with the per-run offsets.
    first : list of CandidateResult
        The first screening.

    Returns
    -------
    Confidence
    """
    if not selection.selected:
        return Confidence("uncertain" if confounded or selection.withheld else "none")
    top = selection.selected[0]
    X = problem.avg(top.columns_full)
    J2 = np.column_stack([problem.avg(cal.X_full), X])
    y2 = problem.avg(problem.y - cal.fixed_full)
    after = y2 - J2 @ np.linalg.lstsq(J2, y2, rcond=None)[0]
    slow = _slow_share(problem, cal.residual_avg, after)
    consistent = _run_consistency(problem, cal, top)
    # an aliased effect of another family with at least half the ΔBIC of the named one's family (either
    # noise model) is a rival explanation: naming either is then a guess
    ar = {c.effect: c.evidence_ar for c in first}
    family = [c for c in first if c.family == top.family]  # the first pick comes from `first`: never empty
    own, own_ar = max(c.delta_bic for c in family), max(c.evidence_ar for c in family)
    rivals = sorted(e for e, b in cross_family_partners(top, aliases, first).items()
                    if b >= 0.5 * own or ar[e] >= 0.5 * own_ar)
    confident = slow >= 0.5 and consistent is not False and not confounded and not rivals
    return Confidence("confident" if confident else "uncertain", slow, consistent, rivals)


def _slow_share(problem: Problem, before: np.ndarray, after: np.ndarray) -> float:
    w = max(1, int(round(problem.config.slow_window_s / problem.config.average_s)))
    s0 = moving_mean(before, w)
    s1 = moving_mean(after, w)
    v0 = float(np.var(s0))
    return float(1 - np.var(s1) / v0) if v0 > 0 else 0.0


def _run_consistency(problem: Problem, cal: TwinFit, cand: CandidateResult) -> bool | None:
    """F-test that the candidate's coefficient is the same in every run (None: one run, or the
    feature lives in one run only)."""
    m = problem.m
    if m.runs < 2:
        return None
    X = problem.avg(cand.columns_full)[:, 0]
    runs = problem.run_avg
    active = [r for r in range(m.runs) if np.std(X[runs == r]) > 1e-3 * np.std(X)]
    if len(active) < 2:
        return None
    J = problem.avg(cal.X_full)
    y = problem.avg(problem.y - cal.fixed_full)
    common = np.column_stack([J, X])
    split = np.column_stack([J] + [np.where(runs == r, X, 0.0) for r in active])
    ar = cal.ar
    cw, sw, yw = ar.prewhiten(common, runs), ar.prewhiten(split, runs), ar.prewhiten(y, runs)
    r0 = yw - cw @ np.linalg.lstsq(cw, yw, rcond=None)[0]
    r1 = yw - sw @ np.linalg.lstsq(sw, yw, rcond=None)[0]
    k = len(active) - 1
    dof = max(1, yw.size - sw.shape[1])
    F = ((r0 @ r0 - r1 @ r1) / k) / ((r1 @ r1) / dof)
    return bool(f_survival(k, dof, F) > 0.001)
