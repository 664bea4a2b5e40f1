"""Discovery: when the library leaves structure, find a sparse expression that explains it.

A dictionary of candidate terms (:mod:`~twin.discovery.features`) is searched by forward
orthogonal selection (OMP / the FROLS of Billings, *Nonlinear System Identification*, 2013, ch. 3)
on prewhitened 10-s means, with the AR noise model re-estimated under each alternative as in
screening. Why our own search and not pysindy's STLSQ/SR3 or sysidentpy's FROLS: the tests here
need (a) the AR prewhitening per run and per contiguous search segment, (b) a GLS F-test with a
Bonferroni factor equal to the number of features tried, and (c) a held-out gain on interleaved
blocks the search never saw; those libraries' regressors give a sparse fit, not these tests.

Guard rails: the search sees only the search blocks (cv folds 0–2 of the interleaved 300-s
blocks), the gain is reported on the others (folds 3–4) with coefficients fitted on the search
blocks; nothing is proposed at the noise floor; a library effect that explains the residual as
well is preferred; p-values are multiplied by the number of features tried.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from twin.estimation.fit import TwinFit
from twin.discovery.features import FeatureSpec, block_feature, block_inputs, dictionary, feature_full
from twin.estimation.linalg import novelty, orthonormal_basis
from twin.estimation.noise import fit_ar
from twin.estimation.problem import Problem, cv_folds
from twin.diagnosis.screen import CandidateResult, CandidateTest, gls_test

SEARCH_FOLDS = (0, 1, 2)
MAX_TERMS = 3
TOP_RECHECK = 6  # best-scoring features re-tested with the AR model under their alternative
AT_FLOOR = 1.02  # residual within 2 % of the white-noise floor: nothing to discover
PREFER_LIBRARY_MARGIN = 10.0  # a library effect within this ΔBIC of the discovered term explains it as well


@dataclass(frozen=True)
class RunnerUp:
    """A feature the first discovered term beat, with its ΔBIC.

    Attributes
    ----------
    feature : str
        The feature's printed form.
    delta_bic : float
        Its ΔBIC on the search blocks [1].
    """

    feature: str
    delta_bic: float


@dataclass
class Term:
    """One discovered term.

    Attributes
    ----------
    spec : FeatureSpec
        The feature.
    coef_mg, ci95_mg : float
        Coefficient and the half-width of its 95 % interval [mg per unit of the feature].
    delta_bic : float
        ΔBIC of its step of the search, on the search blocks [1].
    p_adjusted : float
        F-test p-value times the features tried at every step [1].
    """

    spec: FeatureSpec
    coef_mg: float  # mg per unit of the feature
    ci95_mg: float
    delta_bic: float
    p_adjusted: float


@dataclass
class Discovery:
    """What the dictionary search found outside the library (docs/diagnosis.md §1 step 7).

    Attributes
    ----------
    proposed : bool
        A term is proposed.
    reason : str
        Why (or why nothing is proposed).
    terms : list of Term
    features_tried : int
        Features in the dictionary (the Bonferroni factor of each step).
    heldout_gain : float
        Relative fall of the error on blocks the search did not see [1].
    delta_bic : float
        Sum of the terms' ΔBIC [1].
    rms_before_g, rms_predicted_g : float
        Residual RMS before, and predicted with the terms [g].
    beaten : list of RunnerUp
        Runner-up features of the first step.
    preferred_library : str or None
        A library effect that explains the residual as well.
    average_s : float
        Block length of the search [s].
    contribution_g : np.ndarray, optional
        The discovered term at the sample times [g].
    """

    proposed: bool
    reason: str
    terms: list[Term] = field(default_factory=list)
    features_tried: int = 0
    heldout_gain: float = 0.0
    delta_bic: float = 0.0
    rms_before_g: float = float("nan")
    rms_predicted_g: float = float("nan")
    beaten: list[RunnerUp] = field(default_factory=list)  # runner-up features of the first step
    preferred_library: str | None = None
    average_s: float = 10.0
    contribution_g: np.ndarray | None = None  # the discovered term at the sample times

    def equation(self) -> str:
        """The proposed bias term, e.g. ``bias = +0.31 mg/°C/min · dT/dt``.

        Returns
        -------
        str
            ``""`` without terms.
        """
        if not self.terms:
            return ""
        parts = [f"{t.coef_mg:+.4g} mg/{t.spec.unit or '1'} · {t.spec.label}".replace("mg/1 ·", "mg ·")
                 for t in self.terms]
        return "bias = " + " ".join(parts)


def _segments(mask: np.ndarray, run: np.ndarray) -> np.ndarray:
    """Id of each contiguous stretch of search blocks (prewhitening restarts there: no leakage)."""
    idx = np.flatnonzero(mask)
    brk = np.r_[True, (np.diff(idx) != 1) | (np.diff(run[idx]) != 0)]
    return np.cumsum(brk) - 1


def base_design(problem: Problem, cal: TwinFit, selected: list[CandidateResult]):
    """The calibrated model's columns plus the named library effects (full rate) and the target.

    Parameters
    ----------
    problem, cal : Problem, TwinFit
    selected : list of CandidateResult
        Library effects named; their full-rate columns join the design.

    Returns
    -------
    X_full : np.ndarray
        Design, n × k.
    y : np.ndarray
        Output minus applied minus the fixed part of the model [g].
    """
    extra = [c.columns_full for c in selected if c.columns_full is not None]
    X_full = np.column_stack([cal.X_full, *extra]) if extra else cal.X_full
    return X_full, problem.y - cal.fixed_full


def discover(problem: Problem, cal: TwinFit, selected: list[CandidateResult], candidates: list[CandidateResult],
             noise_floor_g: float) -> Discovery:
    """Search the dictionary for a term the library lacks; see the module docstring.

    Parameters
    ----------
    problem, cal : Problem, TwinFit
    selected : list of CandidateResult
        Library effects the diagnosis named (part of the base model here).
    candidates : list of CandidateResult
        The screening, to prefer a library effect that explains the residual as well.
    noise_floor_g : float
        White-noise floor from the data [g].

    Returns
    -------
    Discovery
    """
    cfg = problem.config
    X_full, y_full = base_design(problem, cal, selected)
    J, y = problem.avg(X_full), problem.avg(y_full)
    beta0 = np.linalg.lstsq(J, y, rcond=None)[0]
    rms0 = float(np.sqrt(np.mean((y_full - X_full @ beta0) ** 2)))
    inp = cal.inputs
    b, _ = block_inputs(inp.time_s, inp.die_c, inp.run_index, inp.time_since_power_on_s, cfg.average_s)
    out = Discovery(False, "", rms_before_g=rms0, rms_predicted_g=rms0, average_s=cfg.average_s)
    if b.temp_c.size != y.size:  # the feature grid must be the problem's blocks
        out.reason = "block grids differ"
        return out
    if rms0 <= AT_FLOOR * noise_floor_g:
        out.reason = f"residual at the noise floor ({rms0 / noise_floor_g:.2f}×): nothing to discover"
        return out
    specs = dictionary(b)
    F = np.column_stack([block_feature(s, b) for s in specs])
    Qraw = orthonormal_basis(J)
    keep = [j for j in range(F.shape[1]) if np.std(F[:, j]) > 0 and novelty(F[:, [j]], Qraw) >= cfg.alias_novelty]
    specs, F = [specs[j] for j in keep], F[:, keep]
    K = len(specs)
    out.features_tried = K
    folds = cv_folds(problem)
    search = np.isin(folds, SEARCH_FOLDS)
    seg = _segments(search, problem.run_avg)
    Js, ys, Fs = J[search], y[search], F[search]
    chosen: list[int] = []
    tests: list[CandidateTest] = []
    total_dbic = 0.0
    for step in range(MAX_TERMS):
        D = np.column_stack([Js, Fs[:, chosen]]) if chosen else Js
        r = ys - D @ np.linalg.lstsq(D, ys, rcond=None)[0]
        ar = fit_ar(r, seg, cfg.max_ar_order)
        Dw, Fw, rw = ar.prewhiten(D, seg), ar.prewhiten(Fs, seg), ar.prewhiten(r, seg)
        Q = orthonormal_basis(Dw)
        Fp = Fw - Q @ (Q.T @ Fw)
        rp = rw - Q @ (Q.T @ rw)
        norms = np.einsum("ij,ij->j", Fp, Fp)
        score = np.where(norms > 1e-12 * norms.max(), (Fp.T @ rp) ** 2 / np.maximum(norms, 1e-300), 0.0)
        score[chosen] = 0.0
        top = [int(j) for j in np.argsort(score)[::-1][:TOP_RECHECK] if score[j] > 0]
        results = {j: gls_test(D, Fs[:, [j]], ys, seg, cfg.max_ar_order) for j in top}
        if not results:
            break
        best = max(results, key=lambda j: results[j].delta_bic)
        t = results[best]
        p_adj = min(1.0, t.p_value * K * (step + 1))  # every feature tried, at every step
        if step == 0:
            out.beaten = [RunnerUp(specs[j].label, results[j].delta_bic)
                          for j in sorted(results, key=lambda j: -results[j].delta_bic)[1:5]]
        if not (p_adj < cfg.alpha and t.delta_bic > cfg.min_delta_bic):
            break
        chosen.append(best)
        tests.append(CandidateTest(t.delta_bic, p_adj, t.explained_fraction, t.coef, t.half_width))
        total_dbic += t.delta_bic
    if not chosen:
        out.reason = f"no term of {K} passes p_adj < {cfg.alpha} and ΔBIC > {cfg.min_delta_bic:g} on the search blocks"
        return out
    # the terms together, a random walk allowed in the noise (a walk drifting one way looks like trends);
    # on every block, runs unbroken: a walk restarted at each search stretch would not be a walk
    t = gls_test(J, F[:, chosen], y, problem.run_avg, cfg.max_ar_order, walk=True)
    if not (min(1.0, t.p_value * K * len(chosen)) < cfg.alpha and t.delta_bic > cfg.min_delta_bic):
        out.reason = (f"the terms found (ΔBIC {total_dbic:.0f}) are not significant once the noise model may hold a "
                      f"bias random walk (ΔBIC {t.delta_bic:.0f}): a slow drift of the bias explains them as well")
        return out
    # held-out gain: coefficients from the search blocks, errors on the others
    val = ~search
    A0, A1 = Js, np.column_stack([Js, Fs[:, chosen]])
    e0 = y[val] - J[val] @ np.linalg.lstsq(A0, ys, rcond=None)[0]
    e1 = y[val] - np.column_stack([J[val], F[val][:, chosen]]) @ np.linalg.lstsq(A1, ys, rcond=None)[0]
    sse0, sse1 = float(e0 @ e0), float(e1 @ e1)
    out.heldout_gain = float(1 - np.sqrt(sse1 / sse0)) if sse0 > 0 else 0.0
    out.delta_bic = total_dbic
    if out.heldout_gain <= cfg.min_heldout_gain:
        out.reason = (f"the best terms found on the search blocks do not predict the others (held-out gain "
                      f"{100 * out.heldout_gain:.1f} % ≤ {100 * cfg.min_heldout_gain:.0f} %)")
        return out
    lib = _library_rival(problem, Js, ys, seg, search, candidates, selected, total_dbic)
    if lib is not None:
        out.preferred_library, out.reason = lib, f"the library effect {lib} explains the residual as well"
        return out
    # final coefficients on every block; the prediction at the sample times (what the plugin computes)
    cols = [feature_full(specs[j], inp.time_s, inp.die_c, inp.run_index, inp.time_since_power_on_s, cfg.average_s)
            for j in chosen]
    Ff = np.column_stack(cols)
    A = np.column_stack([J, problem.avg(Ff)])
    beta = np.linalg.lstsq(A, y, rcond=None)[0]
    k = J.shape[1]
    out.contribution_g = Ff @ beta[k:]
    out.rms_predicted_g = float(np.sqrt(np.mean((y_full - X_full @ beta[:k] - out.contribution_g) ** 2)))
    out.terms = [Term(specs[j], float(beta[k + i] * 1e3), float(tests[i].half_width[0] * 1e3) if i < len(tests) else 0.0,
                      tests[i].delta_bic, tests[i].p_value) for i, j in enumerate(chosen)]
    out.proposed = True
    out.reason = "structure explained by a term outside the library"
    return out


def _library_rival(problem, Js, ys, seg, search, candidates, selected, dbic_discovered) -> str | None:
    """A testable library candidate (not yet named) that explains the search blocks as well."""
    named = {c.effect for c in selected}
    for c in [c for c in candidates if c.effect not in named and c.columns_full is not None][:4]:
        X = problem.avg(c.columns_full)[search]
        if np.std(X) == 0:
            continue
        t = gls_test(Js, X, ys, seg, problem.config.max_ar_order)
        if t.delta_bic >= dbic_discovered - PREFER_LIBRARY_MARGIN and t.delta_bic > problem.config.min_delta_bic:
            return c.effect
    return None
