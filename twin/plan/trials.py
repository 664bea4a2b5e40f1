"""The finalists tried by simulation before one is chosen (docs/plan.md §3).

The expected separation ranks every candidate, but it is a model of the diagnosis: near the decision
rule's thresholds it misjudges what the blind diagnosis does (the held-out gain is judged per 10-s
mean, so a weak effect fails it on any length of test; the random-walk retest takes a slow effect's
evidence on some noise realisations and not on others). So the finalists are run through the
diagnosis itself: each rival as the truth, its parameters drawn within their uncertainty, the test
simulated and diagnosed blind, as the check does, on seeds apart from the check's. The finalists race
by successive halving (Jamieson & Talwalkar 2016, *AISTATS*): every design on a few seeds, the better
half kept and given twice the seeds, until the survivors have the seeds asked for; all on the same
seeds, so the comparisons share their noise.

A few seeds cannot count a miss of one test in twenty, so a design is scored by how far each truth
stood from the two ways it goes unnamed, extrapolated to the tail (normal, over the seeds):

* the held-out gain over its minimum;
* the random-walk retest's choice: the restricted-likelihood criterion of the best noise model that
  leaves the truth's ΔBIC above its minimum, against the best that takes it below (positive: the
  retest keeps the evidence). A walk takes a slow effect's evidence at one step of θ and not at
  the next, a cliff the ΔBIC itself does not show.

Seeds on which the truth passed the rule but another effect was named count as they come.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import NamedTuple

import numpy as np
from scipy import stats

from twin.estimation.linalg import orthonormal_basis
from twin.estimation.noise import WalkARModel, walk_ar_criteria
from twin.plan.check import named_first, simulate_and_diagnose
from twin.plan.hypotheses import NONE, NULLS, Hypothesis, named_when_true

#: first seed of the trials: the check starts at 1000, so the two never share a simulated test
TRIAL_FIRST_SEED = 500
#: seeds per rival of the first round
FIRST_ROUND_SEEDS = 3


class Outcome(NamedTuple):
    """One simulated test diagnosed blind (:func:`trial`).

    Attributes
    ----------
    named : str
        The effect named first, or ``none``.
    passed : bool
        The truth's candidate passed the decision rule (for ``none``: nothing did).
    gain : float
        The truth's held-out gain minus the rule's minimum [1] (nan for ``none``).
    walk : float
        The retest's criterion margin (module docstring) [1]: +inf where no noise model takes the
        evidence, −inf where none leaves it (nan for ``none``).
    """

    named: str
    passed: bool
    gain: float
    walk: float


@dataclass
class TrialScore:
    """One design's trials so far.

    Attributes
    ----------
    seeds : int
        Simulated tests per rival.
    outcomes : dict of str to list of Outcome
        Rival → its tests as the truth.
    """

    seeds: int = 0
    outcomes: dict[str, list[Outcome]] = field(default_factory=dict)

    def rate(self) -> dict[str, float]:
        """Rival → share of its tests on which it was named first [1].

        Returns
        -------
        dict of str to float
        """
        return {e: sum(o.named == named_when_true(e) for o in out) / len(out) for e, out in self.outcomes.items() if out}

    def expected_rate(self) -> dict[str, float]:
        """Rival → the rate extrapolated from the margins (module docstring) [1]: P(gain passes) ×
        P(the retest keeps the evidence) × (1 − the share named otherwise, as (k + ½)/(n + 1)).
        For ``none``: (k + 1)/(n + 2) named nothing (Laplace's rule).

        Returns
        -------
        dict of str to float
        """
        out = {}
        for e, runs in self.outcomes.items():
            n = len(runs)
            if e in NULLS:
                out[e] = (sum(o.named == NONE for o in runs) + 1) / (n + 2)
                continue
            other = sum(o.passed and o.named != e for o in runs)
            out[e] = (_tail([o.gain for o in runs]) * _tail([o.walk for o in runs])
                      * (1 - (other + 0.5) / (n + 1)))
        return out

    def key(self) -> tuple[float, float]:
        """Sort key, larger is better: the least expected rate over the rivals, then their mean.

        Returns
        -------
        tuple of float
        """
        r = list(self.expected_rate().values())
        return (min(r), float(np.mean(r))) if r else (0.0, 0.0)


def _tail(margins: list[float]) -> float:
    """P(margin > 0) for margins normal over the seeds, infinite ones counted as they come."""
    m = np.asarray(margins, float)
    finite = m[np.isfinite(m)]
    p = float(np.mean(m == np.inf)) if m.size else 0.0
    if finite.size:
        # a spread below a tenth of the mean's size would call a handful of seeds certain
        sd = max(float(np.std(finite, ddof=1)) if finite.size > 1 else 0.0, 0.1 * abs(float(finite.mean())), 1e-12)
        p += finite.size / m.size * float(stats.norm.cdf(finite.mean() / sd))
    return p


def trial(job: tuple[dict, Hypothesis, int]) -> Outcome:
    """Simulate and diagnose as the check does, and how far the truth stood from the rule.

    Parameters
    ----------
    job : tuple
        (scenario dict, hypothesis, seed).

    Returns
    -------
    Outcome
    """
    hyp = job[1]
    d = simulate_and_diagnose(job)
    named = named_first(d)
    c = next((c for c in d.candidates if c.effect == hyp.effect), None)
    if hyp.effect in NULLS:
        return Outcome(named, not any(x.significant for x in d.candidates), math.nan, math.nan)
    if c is None or c.columns_full is None:
        return Outcome(named, False, -math.inf, -math.inf)
    cfg = d.problem.config
    return Outcome(named, bool(c.significant), c.heldout_gain - cfg.min_heldout_gain, walk_margin(d, c))


def walk_margin(d, c) -> float:
    """The random-walk retest's margin for candidate ``c`` on the diagnosis ``d``'s data: over the
    walk + AR noise models the retest chooses among (:func:`twin.estimation.noise.walk_ar_criteria`,
    the criterion of :func:`~twin.estimation.noise.fit_walk_ar`), the least criterion of a model
    that leaves ``c``'s ΔBIC under the rule's minimum, less the least of one that keeps it above.

    Parameters
    ----------
    d : twin.diagnosis.diagnose.Diagnosis
    c : twin.diagnosis.screen.CandidateResult
        A screened candidate (its full-rate columns).

    Returns
    -------
    float
        [1]; +inf where no model takes the evidence, −inf where none leaves it.
    """
    problem, cal = d.problem, d.fit
    runs = problem.run_avg
    J, X, y = problem.avg(cal.X_full), problem.avg(c.columns_full), problem.avg(problem.y - cal.fixed_full)
    best = {True: math.inf, False: math.inf}  # keeps the evidence → least criterion
    for model, crit in walk_ar_criteria(np.column_stack([J, X]), y, runs, problem.config.max_ar_order):
        keeps = _delta_bic(model, J, X, y, runs) > problem.config.min_delta_bic
        best[keeps] = min(best[keeps], crit)
    return best[False] - best[True] if math.isfinite(best[True]) else -math.inf


def _delta_bic(model: WalkARModel, J: np.ndarray, X: np.ndarray, y: np.ndarray, runs: np.ndarray) -> float:
    """ΔBIC of X on top of J under ``model`` (as :func:`twin.diagnosis.screen.gls_test`)."""
    Jw, Xw, yw = model.prewhiten(J, runs), model.prewhiten(X, runs), model.prewhiten(y, runs)
    Q = orthonormal_basis(Jw)
    r0, Xp = yw - Q @ (Q.T @ yw), Xw - Q @ (Q.T @ Xw)
    fit = Xp @ np.linalg.lstsq(Xp, r0, rcond=None)[0]
    rss0 = float(r0 @ r0)
    return float(yw.size * np.log(rss0 / max(rss0 - float(fit @ fit), 1e-300)) - X.shape[1] * np.log(yw.size))


def race(scenarios: list[dict], hyps: list[Hypothesis], seeds: int,
         runner: Callable[[Callable, list], list]) -> tuple[int, list[TrialScore]]:
    """The design among ``scenarios`` whose tests the diagnosis reads best, by successive halving.

    Parameters
    ----------
    scenarios : list of dict
        The finalists' scenarios (twin alone as device).
    hyps : list of Hypothesis
        Every rival, each the truth in turn (``none``: named nothing is right).
    seeds : int
        Simulated tests per rival the winner gets (at least the first round's).
    runner : callable
        ``runner(fn, jobs)`` → results in order.

    Returns
    -------
    best : int
        Index of the winner in ``scenarios``.
    scores : list of TrialScore
        Every design's trials (the dropped ones with fewer seeds).
    """
    scores = [TrialScore(0, {h.effect: [] for h in hyps}) for _ in scenarios]
    alive = list(range(len(scenarios)))
    done, target = 0, min(FIRST_ROUND_SEEDS, max(1, seeds))
    while True:
        jobs = [(scenarios[i], h, TRIAL_FIRST_SEED + k) for i in alive for h in hyps for k in range(done, target)]
        out = iter(runner(trial, jobs))
        for i in alive:
            for h in hyps:
                scores[i].outcomes[h.effect] += [next(out) for _ in range(done, target)]
            scores[i].seeds = target
        done = target
        alive.sort(key=lambda i: scores[i].key(), reverse=True)
        if done >= seeds:
            return alive[0], scores
        alive = alive[:max(1, math.ceil(len(alive) / 2))]
        target = min(2 * done, seeds)


def race_jobs(designs: int, rivals: int, seeds: int) -> int:
    """Simulated tests :func:`race` runs for ``designs`` finalists and ``rivals`` rivals (for a
    progress bar's total).

    Parameters
    ----------
    designs, rivals, seeds : int

    Returns
    -------
    int
    """
    total, alive, done, target = 0, designs, 0, min(FIRST_ROUND_SEEDS, max(1, seeds))
    while True:
        total += alive * rivals * (target - done)
        done = target
        if done >= seeds:
            return total
        alive, target = max(1, math.ceil(alive / 2)), min(2 * done, seeds)
