"""Screen every registered effect not in the model (docs/diagnosis.md §1 step 4).

Each candidate is tested on its parameter grid on top of the calibrated model: prewhitened
F-test, Bonferroni over every test, ΔBIC, held-out gain by interleaved-block cross-validation.
Decision: p_adj < 0.01 AND ΔBIC > 10 AND held-out gain > 5 %.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator
from contextlib import contextmanager
from dataclasses import dataclass

import numpy as np

from twin.estimation.fit import TwinFit
from twin.estimation.linalg import heldout_errors, novelty, orthonormal_basis
from twin.estimation.noise import fit_ar, fit_walk_ar
from twin.estimation.problem import DiagnosisConfig, Problem, cv_folds
from twin.estimation.search import bounded_minimum
from twin.estimation.tails import f_survival
from twin.effects import REGISTRY, Composition, Effect, get_effect

_PROGRESS: list[Callable[[int], object]] = []  # callbacks told of each grid point screened


@contextmanager
def screening_progress(callback: Callable[[int], object]) -> Iterator[None]:
    """Call ``callback(1)`` after every grid point screened inside the block (e.g. a tqdm bar's
    ``update``: the CLI owns the bar, the library only counts).

    Parameters
    ----------
    callback : callable
        Called with 1 per grid point screened.

    Yields
    ------
    None
        The block runs with the callback registered; it is removed on exit.
    """
    _PROGRESS.append(callback)
    try:
        yield
    finally:
        _PROGRESS.remove(callback)


@dataclass
class CandidateResult:
    """One candidate effect screened at its best grid point (docs/diagnosis.md §1 step 4).

    Attributes
    ----------
    effect, family : str
    grid_values : dict of str to float
        Its grid point, in each parameter's unit.
    delta_bic, p_value, p_adjusted : float
        ΔBIC, F-test p-value and the Bonferroni-adjusted one [1].
    explained_fraction, heldout_gain, novelty : float
        ERR, relative fall of the held-out error, share the model cannot absorb [1].
    amplitudes : dict of str to tuple of float
        Amplitude → (estimate, half-width of its 95 % interval) [its unit].
    columns_full : numpy.ndarray, optional
        Its full-rate columns (n × m).
    significant : bool
        Passes the decision rule.
    rms_residual_g : float
        Residual RMS with it added [g].
    refined_values : dict of str to float, optional
        ``grid_values`` refined between grid points (named effect).
    delta_bic_ar : float, optional
        ΔBIC with the AR-only noise model, where a walk retest replaced it [1].
    """

    effect: str
    family: str
    grid_values: dict[str, float]
    delta_bic: float
    p_value: float
    p_adjusted: float
    explained_fraction: float
    heldout_gain: float
    novelty: float
    amplitudes: dict[str, tuple[float, float]]  # name -> (estimate, half-width of 95 % CI)
    columns_full: np.ndarray | None = None
    significant: bool = False
    rms_residual_g: float = float("nan")
    refined_values: dict[str, float] | None = None  # grid_values refined between grid points (named effect)
    delta_bic_ar: float | None = None  # ΔBIC with the AR-only noise model, where a walk retest replaced it

    @property
    def evidence_ar(self) -> float:
        """ΔBIC with the AR-only noise model [1]."""
        return self.delta_bic if self.delta_bic_ar is None else self.delta_bic_ar


@dataclass(frozen=True)
class CandidateTest:
    """Outcome of :func:`gls_candidate_test`.

    Attributes
    ----------
    delta_bic : float
        BIC improvement, prewhitened [1].
    p_value : float
        F-test, before the Bonferroni correction [1].
    explained_fraction : float
        ERR: share of the prewhitened residual the candidate explains [1].
    coef, half_width : numpy.ndarray
        Coefficients and their 95 % half-widths [each column's amplitude unit].
    """

    delta_bic: float
    p_value: float  # F-test, before the Bonferroni correction
    explained_fraction: float  # ERR: share of the prewhitened residual the candidate explains
    coef: np.ndarray
    half_width: np.ndarray  # of the coefficients' 95 % intervals


def candidate_names(comp: Composition) -> list[str]:
    """Registered effects the model lacks (one temperature slot at most).

    Parameters
    ----------
    comp : Composition

    Returns
    -------
    list of str
        Sorted effect names, ``null`` and effects not screened blind (``screened = False``) excluded.
    """
    present = {e.name for e in comp.effects}
    has_slot = comp.temperature_effect is not None
    return sorted(n for n, c in REGISTRY.items()
                  if n not in present and n != "null" and c.screened and not (c.slot == "temperature" and has_slot))


def is_testable(c: CandidateResult, cfg: DiagnosisConfig) -> bool:
    """Whether this data can test the candidate: identifiable and novel enough.

    Parameters
    ----------
    c : CandidateResult
    cfg : DiagnosisConfig

    Returns
    -------
    bool
    """
    return c.novelty >= cfg.alias_novelty and get_effect(c.effect).identifiable


def screen_columns(problem: Problem, cal: TwinFit, cls: type[Effect], values: dict[str, float]):
    """Full-rate candidate columns (n × m) and amplitude names.

    Parameters
    ----------
    problem : Problem
    cal : TwinFit
        Caches the model's temperature derivative for temperature-slot candidates.
    cls : type[Effect]
        The candidate.
    values : dict
        Its grid point.

    Returns
    -------
    columns : np.ndarray
        n × m.
    names : list of str
        Amplitude of each column.
    """
    ctx = cal.composition.effects[0].context if cal.composition.effects else {}
    eff = cls(ctx, **values)
    if eff.slot == "temperature":
        # Linearised: the calibrated model's temperature sensitivity times the lag of the die.
        lagged = eff.die_temperature(problem.inputs)
        if cal.temperature_derivative is None:  # the same for every grid point: compute once
            cal.temperature_derivative = _temperature_derivative(problem, cal)
        deriv = cal.temperature_derivative
        if np.max(np.abs(deriv)) < 1e-9:
            deriv = np.full(problem.n, 1e-3)
        return (deriv * (lagged - problem.inputs.die_c))[:, None], ["fraction"]
    screened = [p.name for p in eff.parameters if p.role == "amplitude" and p.screen]
    basis = eff.basis(cal.inputs)
    names = [a for a in screened if a in basis]
    out = np.empty((problem.n, len(names)))  # filled in place: one copy per column, not two
    for j, a in enumerate(names):
        out[:, j] = basis[a].output_g(problem.applied)
    return out, names


def _temperature_derivative(problem: Problem, cal: TwinFit, h: float = 0.5) -> np.ndarray:
    """∂(model output)/∂(die temperature) of the calibrated drift effects [g/°C]."""
    def total(shift):
        inp = cal.inputs.replace(die_c=cal.inputs.die_c + shift, applied_g=problem.applied)
        out = np.zeros(problem.n)
        for e in cal.composition.drift_effects:
            out += np.broadcast_to(e.contribution(inp).output_g(problem.applied), (problem.n,))
        return out

    return (total(h) - total(-h)) / (2 * h)


def gls_candidate_test(problem: Problem, J: np.ndarray, y: np.ndarray, X: np.ndarray,
                       max_order: int, walk: bool = False) -> CandidateTest:
    """:func:`gls_test` of X on top of J inside the problem's runs.

    Parameters
    ----------
    problem : Problem
        Gives the run of each average.
    J, y, X : np.ndarray
        The model's design, the target [g] and the candidate's columns, on averages.
    max_order : int
        Largest AR order.
    walk : bool
        Let the noise model hold a random walk.

    Returns
    -------
    CandidateTest
    """
    return gls_test(J, X, y, problem.run_avg, max_order, walk)


def gls_test(J: np.ndarray, X: np.ndarray, y: np.ndarray, runs: np.ndarray, max_order: int,
             walk: bool = False) -> CandidateTest:
    """GLS test of X on top of J, the AR noise model estimated under the alternative.

    Fitting the AR model to the base residual would let it learn a large missing effect and
    whiten it away; estimated from the residual of J + X it describes the noise that remains.
    With ``walk`` the noise model may hold a random walk too (:func:`~twin.estimation.noise.fit_walk_ar`).

    Parameters
    ----------
    J : np.ndarray
        The model's design on averages.
    X : np.ndarray
        The candidate's columns on averages.
    y : np.ndarray
        The target on averages [g].
    runs : np.ndarray
        Stretch id of each average (prewhitening restarts at each stretch).
    max_order : int
        Largest AR order.
    walk : bool
        Let the noise model hold a random walk, chosen by restricted likelihood.

    Returns
    -------
    CandidateTest
        ΔBIC, F p-value, ERR, coefficients, their 95 % half-widths.

    References
    ----------
    docs/diagnosis.md §1 step 4. ΔBIC = n ln(RSS₀/RSS₁) − m ln n: Schwarz, G. (1978), Estimating the
    dimension of a model, *Ann. Stat.* 6(2):461–464; ERR: Billings (2013), *Nonlinear System
    Identification: NARMAX Methods*.
    """
    A1 = np.column_stack([J, X])
    if walk:
        ar = fit_walk_ar(A1, y, runs, max_order)
    else:
        ar = fit_ar(y - A1 @ np.linalg.lstsq(A1, y, rcond=None)[0], runs, max_order)
    Jw, Xw, yw = ar.prewhiten(J, runs), ar.prewhiten(X, runs), ar.prewhiten(y, runs)
    Q = orthonormal_basis(Jw)
    r0 = yw - Q @ (Q.T @ yw)
    Xp = Xw - Q @ (Q.T @ Xw)
    rss0 = float(r0 @ r0)
    coef = np.linalg.lstsq(Xp, r0, rcond=None)[0]
    fit = Xp @ coef
    rss1 = max(rss0 - float(fit @ fit), 1e-300)
    n, q, m = yw.size, Q.shape[1], X.shape[1]
    dof = max(1, n - q - m)
    F = ((rss0 - rss1) / m) / (rss1 / dof)
    cov = rss1 / dof * np.linalg.pinv(Xp.T @ Xp)
    half = 1.96 * np.sqrt(np.clip(np.diag(cov), 0, None))
    return CandidateTest(float(n * np.log(rss0 / rss1) - m * np.log(n)), float(f_survival(m, dof, F)),
                         1 - rss1 / rss0, coef, half)


def _significant(c: CandidateResult, cls: type[Effect], cfg: DiagnosisConfig) -> bool:
    return bool(c.p_adjusted < cfg.alpha and c.delta_bic > cfg.min_delta_bic and c.heldout_gain > cfg.min_heldout_gain
                and cls.identifiable and c.novelty >= cfg.alias_novelty)


def _retest_with_walk(problem: Problem, J: np.ndarray, y: np.ndarray, c: CandidateResult, n_tests: int) -> None:
    """The candidate's test redone with a random walk allowed in the noise model (unchanged when the
    restricted likelihood keeps θ = 1: the same AR model, the same numbers)."""
    X = problem.avg(c.columns_full)
    t = gls_candidate_test(problem, J, y, X, problem.config.max_ar_order, walk=True)
    c.delta_bic_ar = c.delta_bic
    c.delta_bic, c.p_value, c.p_adjusted = t.delta_bic, t.p_value, min(1.0, t.p_value * n_tests)
    c.explained_fraction = t.explained_fraction
    c.amplitudes = {a: (float(t.coef[j]), float(t.half_width[j])) for j, a in enumerate(c.amplitudes)}


def refine_grid_value(problem: Problem, cal: TwinFit, c: CandidateResult, J: np.ndarray,
                      y: np.ndarray) -> dict[str, float]:
    """The candidate's one varying nonlinear parameter (τ, play width) refined between its grid
    neighbours by maximising the screening ΔBIC on a log scale (docs/diagnosis.md §1 step 5);
    ``J``, ``y``: the calibrated model's design and target on averages, as in :func:`screen`.

    Parameters
    ----------
    problem : Problem
    cal : TwinFit
    c : CandidateResult
        The candidate at its best grid point.
    J, y : np.ndarray
        Design and target [g] on averages.

    Returns
    -------
    dict
        The grid values with the varying one refined (unchanged when nothing beats the grid point).
    """
    cls = get_effect(c.effect)
    grid = cls.grid()
    varying = [k for k in c.grid_values if len({g[k] for g in grid}) > 1]
    if len(varying) != 1 or c.columns_full is None:
        return dict(c.grid_values)
    k = varying[0]
    vals = sorted({g[k] for g in grid})
    i = vals.index(c.grid_values[k])
    lo, hi = vals[max(i - 1, 0)], vals[min(i + 1, len(vals) - 1)]
    if lo <= 0:
        return dict(c.grid_values)

    def neg_dbic(log_v: float) -> float:
        X = problem.avg(screen_columns(problem, cal, cls, {**c.grid_values, k: float(np.exp(log_v))})[0])
        return -gls_candidate_test(problem, J, y, X, problem.config.max_ar_order).delta_bic

    res = bounded_minimum(neg_dbic, np.log(lo), np.log(hi), xatol=0.01)
    best = float(np.exp(res.x)) if -res.fun > c.delta_bic else c.grid_values[k]
    return {**c.grid_values, k: best}


def screen(problem: Problem, cal: TwinFit, candidates: list[str], extra: np.ndarray | None = None,
           n_tests: int | None = None) -> list[CandidateResult]:
    """Screen ``candidates`` on top of the calibrated model (plus ``extra`` full-rate columns).

    Parameters
    ----------
    problem : Problem
    cal : TwinFit
    candidates : list of str
        Effect names.
    extra : np.ndarray, optional
        Full-rate columns of effects already selected.
    n_tests : int, optional
        Number of tests for the Bonferroni correction; by default every grid point of ``candidates``.

    Returns
    -------
    list of CandidateResult
        Each candidate at its best grid point, testable ones first, then by ΔBIC.
    """
    cfg = problem.config
    J_full = cal.X_full if extra is None else np.column_stack([cal.X_full, extra])
    J = problem.avg(J_full)
    y_avg = problem.avg(problem.y - cal.fixed_full)
    folds = cv_folds(problem)
    Qraw = orthonormal_basis(J)
    if n_tests is None:
        n_tests = sum(len(get_effect(c).grid()) for c in candidates)
    results = []
    for name in candidates:
        cls = get_effect(name)
        best = None
        for g in cls.grid():
            X_full, amp_names = screen_columns(problem, cal, cls, g)
            X = problem.avg(X_full)
            nov = novelty(X, Qraw)
            if nov < 1e-6:  # what is left is round-off: regressing on it would be noise
                res = CandidateResult(name, cls.family, g, 0.0, 1.0, 1.0, 0.0, 0.0, nov, {}, X_full)
            else:
                t = gls_candidate_test(problem, J, y_avg, X, cfg.max_ar_order)
                amps = {a: (float(t.coef[j]), float(t.half_width[j])) for j, a in enumerate(amp_names)}
                res = CandidateResult(name, cls.family, g, t.delta_bic, t.p_value, min(1.0, t.p_value * n_tests),
                                      t.explained_fraction, 0.0, nov, amps, X_full)
            if best is None or res.delta_bic > best.delta_bic:
                best = res
            for tick in _PROGRESS:
                tick(1)
        if best.delta_bic > 0:
            X = problem.avg(best.columns_full)
            # gain where the candidate acts: a power-on transient must not be diluted by hours of dwell
            act = np.abs(X - Qraw @ (Qraw.T @ X)).max(axis=1)
            support = act > 0.1 * act.max()
            e0 = heldout_errors(J, y_avg, folds)[support]
            e1 = heldout_errors(np.column_stack([J, X]), y_avg, folds)[support]
            sse0s, sse1s = float(e0 @ e0), float(e1 @ e1)
            best.heldout_gain = float(1 - np.sqrt(sse1s / sse0s)) if sse0s > 0 else 0.0
        best.significant = _significant(best, cls, cfg)
        if best.significant:  # a walk drifting one way passes an AR model; every candidate is retested so
            _retest_with_walk(problem, J, y_avg, best, n_tests)  # they rank under one noise model
            best.significant = _significant(best, cls, cfg)
        results.append(best)
    # what the data can test ranks before what it cannot, then by evidence
    results.sort(key=lambda r: (r.novelty >= cfg.alias_novelty and get_effect(r.effect).identifiable, r.delta_bic),
                 reverse=True)
    return results
