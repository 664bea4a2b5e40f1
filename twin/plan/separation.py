"""The expected separation of rival hypotheses by one test: the T-optimal criterion (Atkinson &
Fedorov 1975) in the diagnosis' own statistics (docs/plan.md §3).

With hypothesis *i* true, the data's mean departs from the calibrated twin by fᵢ (simulated, noise
free). The diagnosis screens each rival *j* on top of what calibration absorbs (J: per-run offsets
and the twin's free amplitudes) on prewhitened block means. The expected ΔBIC by which *i* beats *j*
is then the lack of fit of *j*'s best model to fᵢ,

    λᵢⱼ = min over j's grid of ‖P⊥[J, Xⱼ] fᵢ‖² / σ²,

σ² the innovation variance of the noise on block means, all prewhitened by the noise's AR model;
λᵢ,none = ‖P⊥J fᵢ‖² / σ² is how far *i* stands out at all. Averaged over draws of the rivals'
parameters within the finding's intervals. The ΔBIC difference is about normal with mean λ and
standard deviation 2√λ (the cross term of signal and noise), which gives the predicted rates.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import stats

from twin.diagnosis.screen import gls_test, screen_columns
from twin.diagnosis.selection import DECISIVE_BIC
from twin.effects import get_effect
from twin.estimation.fit import TwinFit, fit_twin
from twin.estimation.linalg import orthonormal_basis
from twin.estimation.problem import DiagnosisConfig, Problem
from twin.measurement import from_dataset
from twin.model.simulate import simulate
from twin.plan.hypotheses import NULLS, Hypothesis
from twin.model.scenario import LoadedScenario
from twin.plan.scenarios import load, with_hypothesis

#: the decision rule's ΔBIC for a missing effect (docs/diagnosis.md §1 step 4)
DETECT_BIC = 10.0
#: noise realisations on which the screen's walk + AR model is fitted per test
NOISE_REALISATIONS = 8


@dataclass(frozen=True)
class Separation:
    """What one test is expected to tell apart.

    Attributes
    ----------
    effects : tuple of str
        The hypotheses, in order.
    expected_delta_bic : numpy.ndarray
        [i, j]: expected ΔBIC of hypothesis i (true) over j's best fit [1]; the ``none`` column is
        i's own evidence over the twin alone.
    predicted_rate : dict of str to float
        Probability that the diagnosis names each hypothesis first when it is true [1] (normal
        approximation; ``none`` not predicted).
    amplitude_ci95 : dict of str to dict of str to float
        Predicted 95 % half-width of each hypothesis' amplitudes [their unit].
    rows : int
        Block means the diagnosis would see.
    own_evidence : dict of str to float
        Expected screening ΔBIC of each hypothesis against the twin alone, λ + m − m ln n [1].
    """

    effects: tuple[str, ...]
    expected_delta_bic: np.ndarray
    predicted_rate: dict[str, float]
    amplitude_ci95: dict[str, dict[str, float]]
    rows: int
    own_evidence: dict[str, float]

    def worst_pair(self) -> tuple[str, str, float]:
        """The pair (true, rival) with the least expected ΔBIC, and that ΔBIC."""
        best = ("", "", float("inf"))
        for i, a in enumerate(self.effects):
            for j, b in enumerate(self.effects):
                if i != j and a not in NULLS and self.expected_delta_bic[i, j] < best[2]:
                    best = (a, b, float(self.expected_delta_bic[i, j]))
        return best

    @property
    def score(self) -> float:
        """The criterion: the least expected ΔBIC over ordered pairs of real effects [1]."""
        return self.worst_pair()[2]

    def without(self, effects: set[str]) -> Separation:
        """This separation with ``effects`` left out (rows, columns and rates).

        Parameters
        ----------
        effects : set of str

        Returns
        -------
        Separation
        """
        keep = [i for i, e in enumerate(self.effects) if e not in effects]
        return Separation(tuple(self.effects[i] for i in keep), self.expected_delta_bic[np.ix_(keep, keep)],
                          {e: r for e, r in self.predicted_rate.items() if e not in effects},
                          {e: a for e, a in self.amplitude_ci95.items() if e not in effects}, self.rows,
                          {e: v for e, v in self.own_evidence.items() if e not in effects})

    @property
    def least_rate(self) -> float:
        """The least predicted rate over the real effects [1]."""
        return min(self.predicted_rate.values(), default=0.0)


def clean_output_g(ds) -> np.ndarray:
    """A simulated output's drift, without noise, turn-on bias or the applied acceleration [g]
    (the part a hypothesis changes)."""
    return ds["truth/drift_g"]


class _Plan:
    """One test simulated once under the twin alone: the diagnosis' rows, what calibration absorbs,
    and the noise model."""

    def __init__(self, scenario: dict, seed: int, walk: bool = False):
        self.scenario, self.seed = scenario, seed
        loaded = load(scenario)
        ds = simulate(loaded, seed=seed)
        self.clean0 = clean_output_g(ds)
        self.problem = Problem(from_dataset(ds), DiagnosisConfig())
        self.rows = int(self.problem.run_avg.size)
        self.cal: TwinFit = fit_twin(self.problem, loaded.twin_composition(), intervals=False)
        runs = self.problem.run_avg
        self.white = lambda x: self.cal.ar.prewhiten(self.problem.avg(x), runs)  # noqa: E731
        self.J = self.problem.avg(self.cal.X_full)
        self.QJ = orthonormal_basis(self.cal.ar.prewhiten(self.J, runs))
        r = self.cal.ar.prewhiten(self.cal.residual_avg, runs)
        self.sigma2 = float(r @ r) / max(1, r.size - self.QJ.shape[1])
        # the held-out gain is judged on the block means as they are (not prewhitened)
        self.Qraw = orthonormal_basis(self.J)
        self.y_avg = self.problem.avg(self.problem.y - self.cal.fixed_full)
        self.block_var = float(np.var(self.cal.residual_avg))
        self.ys = self.noise_realisations(loaded) if walk else []
        self._spaces: dict[str, list[np.ndarray]] = {}

    def off_model(self, x: np.ndarray) -> np.ndarray:
        """Prewhitened block means of ``x`` with what calibration absorbs projected out."""
        w = self.white(x)
        return w - self.QJ @ (self.QJ.T @ w)

    def signal(self, hyp: Hypothesis, values: dict[str, float]) -> tuple[np.ndarray, float]:
        """fᵢ [g] for ``hyp`` at ``values`` (same seed: same thermometer and noise draws), and the
        probability that its held-out gain passes the decision rule."""
        if hyp.effect in NULLS:
            return np.zeros(self.problem.n), 0.0
        ds = simulate(load(with_hypothesis(self.scenario, hyp, values)), seed=self.seed)
        f = clean_output_g(ds) - self.clean0
        return f, self.gain_probability(f)

    def noise_realisations(self, loaded: LoadedScenario) -> list[np.ndarray]:
        """The target's block means under the twin alone on :data:`NOISE_REALISATIONS` noise
        realisations of this test (the plan's seed and the next ones) [g]."""
        ys = [self.y_avg]
        for k in range(1, NOISE_REALISATIONS):
            p = Problem(from_dataset(simulate(loaded, seed=self.seed + k)), DiagnosisConfig())
            ys.append(p.avg(p.y - self.cal.fixed_full))
        return ys

    def detect_probability(self, hyp: Hypothesis, values: dict[str, float], f: np.ndarray, own: float,
                           m: int) -> float:
        """P(the screen finds ``hyp`` significant by ΔBIC on data with signal f [g]).

        Expected ΔBIC = λ + m − m ln n for m amplitudes over n block means (Schwarz 1978), standard
        deviation 2√λ. With ``walk`` realisations, the screen's retest of a significant candidate
        with a random walk allowed in the noise model (docs/diagnosis.md §1 step 4) is run on each: a
        walk can take a slow drift's evidence away (θ = 0.99 leaves ΔBIC 9 of 1500 for a linear
        aging drift), which no expectation over an AR model shows."""
        dbic = own + m - m * np.log(self.rows)
        if not self.ys:
            return float(stats.norm.cdf((dbic - DETECT_BIC) / (2.0 * np.sqrt(max(own, 0.0)) + 1.0)))
        cls = get_effect(hyp.effect)
        nonlinear = {p.name: values.get(p.name, p.default) for p in cls.parameters if p.role == "nonlinear"}
        X = self.problem.avg(screen_columns(self.problem, self.cal, cls, nonlinear)[0])
        fa, cfg = self.problem.avg(f), self.problem.config
        out = 0.0
        for y in self.ys:
            walk = gls_test(self.J, X, y + fa, self.problem.run_avg, cfg.max_ar_order, walk=True).delta_bic
            out += float(stats.norm.cdf((min(dbic, walk) - DETECT_BIC) / (2.0 * np.sqrt(max(own, 0.0)) + 1.0)))
        return out / len(self.ys)

    def gain_probability(self, f: np.ndarray) -> float:
        """P(held-out gain > the rule's minimum) for a signal f [g] (docs/plan.md §3).

        The screen measures the gain on the block means where the candidate acts (its column above
        a tenth of its peak): with signal energy S over n such means of noise variance v, the
        held-out error falls from about S + n·v to n·v, a gain of 1 − √(n·v / (S + n·v)). It
        passes the minimum g when S > c·n·v, c = 1/(1 − g)² − 1; S's estimate carries the cross
        term of signal and noise, standard deviation 2√(v·S)."""
        x = self.problem.avg(f)
        x = x - self.Qraw @ (self.Qraw.T @ x)
        act = np.abs(x)
        support = act > 0.1 * act.max() if act.max() > 0 else act > 0
        S, n = float(np.sum(x[support] ** 2)), int(support.sum())
        c = 1.0 / (1.0 - self.problem.config.min_heldout_gain) ** 2 - 1.0
        if S <= 0:
            return 0.0
        return float(stats.norm.cdf((S - c * n * self.block_var) / (2.0 * np.sqrt(self.block_var * S))))

    def spaces(self, effect: str) -> list[np.ndarray]:
        """Orthonormal bases of ``effect``'s columns off the model, one per grid point (cached)."""
        if effect not in self._spaces:
            cls = get_effect(effect)
            bases = []
            for g in cls.grid():
                X, _ = screen_columns(self.problem, self.cal, cls, g)
                bases.append(orthonormal_basis(self.off_model(X)))
            self._spaces[effect] = bases
        return self._spaces[effect]

    def amplitude_ci95(self, hyp: Hypothesis) -> dict[str, float]:
        """Predicted 95 % half-widths of ``hyp``'s screened amplitudes [their unit]."""
        if hyp.effect in NULLS:
            return {}
        cls = get_effect(hyp.effect)
        nonlinear = {p.name: hyp.values.get(p.name, p.default) for p in cls.parameters if p.role == "nonlinear"}
        X, names = screen_columns(self.problem, self.cal, cls, nonlinear)
        Xp = self.off_model(X)
        cov = self.sigma2 * np.linalg.pinv(Xp.T @ Xp)
        return {n: float(1.96 * np.sqrt(max(cov[k, k], 0.0))) for k, n in enumerate(names)}


def lack_of_fit(f: np.ndarray, bases: list[np.ndarray]) -> float:
    """min over ``bases`` of ‖f − Q Qᵀ f‖² (the best fit of a rival's model to f)."""
    ff = float(f @ f)
    return min((ff - float(np.sum((Q.T @ f) ** 2)) for Q in bases), default=ff)


def _rate(lam: np.ndarray, margin: np.ndarray) -> float:
    """P(every ΔBIC difference exceeds its margin), the differences taken as independent normals
    of mean λ and standard deviation 2√λ."""
    z = (lam - margin) / (2.0 * np.sqrt(np.maximum(lam, 0.0)) + 1.0)
    return float(np.prod(stats.norm.cdf(z)))


def separation(scenario: dict, hyps: list[Hypothesis], draws: int = 3, seed: int = 0, walk: bool = False) -> Separation:
    """Expected separation of ``hyps`` by the test ``scenario`` (its program and test plan), and the
    predicted rate at which the diagnosis names each first: detected (ΔBIC over the twin alone and
    held-out gain, the decision rule) and ahead of every rival.

    Parameters
    ----------
    scenario : dict
        A planned test (:func:`twin.plan.scenarios.with_program`), the twin alone as device.
    hyps : list of Hypothesis
    draws : int
        Parameter draws per hypothesis (the first is the estimate itself).
    seed : int
        Seed of the simulation and of the draws.
    walk : bool
        Predict detection on :data:`NOISE_REALISATIONS` noise realisations with the screen's random
        walk retest (slower; the plan's finalists are tried by simulation instead,
        :mod:`twin.plan.trials`).

    Returns
    -------
    Separation
    """
    plan = _Plan(scenario, seed, walk)
    rng = np.random.default_rng(np.random.SeedSequence([seed, 29]))
    effects = tuple(h.effect for h in hyps)
    lam = np.zeros((len(hyps), len(hyps)))
    rates, evidence = {}, {}
    for i, h in enumerate(hyps):
        if h.effect in NULLS:
            continue
        margin = np.array([DETECT_BIC if e in NULLS else _margin(h.effect, e) for e in effects])
        keep = np.arange(len(hyps)) != i
        rate = 0.0
        m = sum(p.role == "amplitude" and p.screen for p in get_effect(h.effect).parameters)
        for d in range(draws):
            values = h.values if d == 0 else h.draw(rng)
            f_raw, p_gain = plan.signal(h, values)
            f = plan.off_model(f_raw)
            own = float(f @ f) / plan.sigma2
            row = np.array([own if j == i or hyps[j].effect in NULLS else
                            lack_of_fit(f, plan.spaces(hyps[j].effect)) / plan.sigma2 for j in range(len(hyps))])
            lam[i] += row / draws
            evidence[h.effect] = evidence.get(h.effect, 0.0) + (own + m - m * np.log(plan.rows)) / draws
            # named first: detected (ΔBIC under the noise models the screen takes, held-out gain) and
            # ahead of every rival
            p_detect = plan.detect_probability(h, values, f_raw, own, m)
            rate += p_gain * p_detect * _rate(row[keep], margin[keep]) / draws
        lam[i, i] = 0.0
        rates[h.effect] = rate
    return Separation(effects, lam, rates, {h.effect: plan.amplitude_ci95(h) for h in hyps if h.effect not in NULLS},
                      plan.rows, evidence)


def _margin(true: str, rival: str) -> float:
    """ΔBIC the true effect must win by: none across families (the better ranks first); within a
    family a richer model displaces a simpler one only by :data:`DECISIVE_BIC` (the selection's rule)."""
    a, b = get_effect(true), get_effect(rival)
    if a.family != b.family:
        return 0.0
    k = lambda c: sum(p.role != "fixed" and p.free for p in c.parameters)  # noqa: E731
    return DECISIVE_BIC if k(a) > k(b) else 0.0
