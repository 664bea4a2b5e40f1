"""Audit what this data can test (docs/diagnosis.md §1 step 0, §2).

Novelty of every effect against what the calibrated model can already absorb (per-run offsets,
the model's own free amplitudes): aliased or untestable effects are listed with the test step
that would separate them.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from twin.arrays import run_slices
from twin.estimation.fit import TwinFit
from twin.diagnosis.remedies import (
    OFFSET_ALIAS_REMEDY,
    ORIENTATION_NOT_LOGGED,
    REMEDY,
    UNIDENTIFIABLE,
    absorbed_reason,
    confounding_remedy,
)
from twin.estimation.linalg import closest_column, novelty, orthonormal_basis
from twin.estimation.problem import DiagnosisConfig, Problem
from twin.diagnosis.records import PER_RUN_OFFSETS, Alias, ModelAliased, Untestable
from twin.diagnosis.screen import CandidateResult, candidate_names, is_testable
from twin.effects import get_effect


@dataclass
class Audit:
    """What the data cannot test or separate; entries are the JSON's ``untestable`` and ``aliases``
    (docs/diagnosis.md §1 step 0).

    Attributes
    ----------
    untestable : list of Untestable
        Candidates the data cannot test, each with the test step that would.
    aliases : list of Alias
        Groups of candidates alike in shape once the model is projected out.
    model_aliased : list of ModelAliased
        Model amplitudes the data cannot fix.
    confounded : bool
        Temperature is confounded with the per-run offsets.
    """

    untestable: list[Untestable]
    aliases: list[Alias]
    model_aliased: list[ModelAliased]  # model amplitudes the data cannot fix
    confounded: bool  # temperature confounded with the per-run offsets


def untestable_effects(problem: Problem, cal: TwinFit, first: list[CandidateResult]) -> list[Untestable]:
    """Candidates the data cannot test: unidentifiable, absorbed, or needing the orientation.

    Parameters
    ----------
    problem, cal : Problem, TwinFit
    first : list of CandidateResult
        The first screening, whose novelty says what the calibrated model already absorbs.

    Returns
    -------
    list of Untestable
    """
    cfg = problem.config
    untestable = []
    for c in first:
        cls = get_effect(c.effect)
        if not cls.identifiable or c.novelty < cfg.alias_novelty:
            why = UNIDENTIFIABLE if not cls.identifiable else absorbed_reason(c.novelty)
            untestable.append(Untestable(c.effect, c.family, why, REMEDY.get(c.family, "")))
    if not problem.m.applied_known:
        for n in candidate_names(cal.composition):
            if get_effect(n).family == "scale_factor":
                untestable.append(Untestable(n, "scale_factor", ORIENTATION_NOT_LOGGED, REMEDY["scale_factor"]))
    return untestable


def alias_groups(problem: Problem, cal: TwinFit, first: list[CandidateResult]) -> list[Alias]:
    """Testable candidates alike in shape once the model is projected out (correlation above
    ``alias_correlation``), merged into groups.

    Parameters
    ----------
    problem : Problem
    cal : TwinFit
    first : list of CandidateResult

    Returns
    -------
    list of Alias
    """
    cfg = problem.config
    testable = [c for c in first if is_testable(c, cfg)]
    J = problem.avg(cal.X_full)
    Q = orthonormal_basis(J)
    perps = {}
    for c in testable:
        X = problem.avg(c.columns_full)[:, 0]
        perps[c.effect] = X - Q @ (Q.T @ X)
    groups: list[set[str]] = []
    keys = list(perps)
    for i, a in enumerate(keys):
        for b in keys[i + 1:]:
            pa, pb = perps[a], perps[b]
            if np.std(pa) == 0 or np.std(pb) == 0:
                continue
            if abs(np.corrcoef(pa, pb)[0, 1]) > cfg.alias_correlation:
                for g in groups:
                    if a in g or b in g:
                        g.update({a, b})
                        break
                else:
                    groups.append({a, b})
    aliases = []
    for g in groups:
        fams = tuple(sorted({get_effect(e).family for e in g}))
        aliases.append(Alias(tuple(sorted(g)), fams, "; ".join(REMEDY.get(f, "") for f in fams if REMEDY.get(f))))
    return aliases


def model_aliased_amplitudes(problem: Problem, cal: TwinFit, cfg: DiagnosisConfig) -> list[ModelAliased]:
    """Model amplitudes this data cannot estimate (aliased with offsets or each other).

    Parameters
    ----------
    problem : Problem
    cal : TwinFit
    cfg : DiagnosisConfig

    Returns
    -------
    list of ModelAliased
    """
    A = problem.avg(cal.X_full)
    nn = problem.nuisance.shape[1]
    labels = problem.nuisance_names + [f"{e}.{a}" for e, a in cal.names]
    out = []
    for j, (eff, amp) in enumerate(cal.names):
        others = [k for k in range(A.shape[1]) if k != nn + j]
        nov = novelty(A[:, [nn + j]], orthonormal_basis(A[:, others]))
        if nov < cfg.alias_novelty:
            out.append(ModelAliased(eff, amp, nov, closest_column(A, nn + j, others, labels)))
    return out


def orientation_temperature_confounding(problem: Problem) -> Alias | None:
    """The alias entry when each run sits at a nearly constant temperature and the orientation
    is not logged: the per-run offsets then absorb both.

    Parameters
    ----------
    problem : Problem

    Returns
    -------
    Alias or None
    """
    m = problem.m
    if m.runs > 1 and not m.applied_known:
        temp = problem.inputs.die_c
        spans = [np.percentile(temp[s], 95) - np.percentile(temp[s], 5) for s in run_slices(m.run_index)]
        medians = [np.median(temp[s]) for s in run_slices(m.run_index)]
        between = max(medians) - min(medians)
        if between > 0 and max(spans) < 0.25 * between:
            return Alias(("orientation", "static_bias_tc"), ("bias_tc",), confounding_remedy(max(spans), between),
                         PER_RUN_OFFSETS)
    return None


def audit(problem: Problem, cal: TwinFit, first: list[CandidateResult]) -> Audit:
    """Aliases among candidates, untestable effects, model amplitudes the data cannot fix.

    Parameters
    ----------
    problem, cal : Problem, TwinFit
    first : list of CandidateResult
        The first screening (every candidate, before forward selection).

    Returns
    -------
    Audit
        ``aliases``: the confounding entry first, then candidate groups, then model amplitudes.
    """
    cfg = problem.config
    untestable = untestable_effects(problem, cal, first)
    aliases = alias_groups(problem, cal, first)
    model_aliased = [ModelAliased(e, a, 0.0, partner, pinned=True) for (e, a), partner in cal.pinned]
    for a in model_aliased_amplitudes(problem, cal, cfg):
        if all(a.effect != b.effect for b in model_aliased):
            model_aliased.append(a)
    confounded = any(a.with_run_offsets for a in model_aliased)
    entry = orientation_temperature_confounding(problem)
    if entry is not None:
        aliases.insert(0, entry)
        confounded = True
    for a in {a.effect: a for a in reversed(model_aliased)}.values():
        family = get_effect(a.effect).family
        aliases.append(Alias((a.effect,), (family,), OFFSET_ALIAS_REMEDY if a.with_run_offsets else REMEDY.get(family, ""),
                             a.aliased_with))
    return Audit(untestable, aliases, model_aliased, confounded)
