"""Compare the twin with a measurement, show where it fails, and name the missing effect.

Pipeline (diagnosis-methods §1):

0. **Audit**: novelty of every effect against what the calibrated model can already absorb
   (per-run offsets, the model's own free amplitudes): aliased or untestable effects are listed
   with the test step that would separate them.
1. **Prepare**: the thermometer smoothed with a zero-phase filter only (a causal one would inject
   the lag the tool then "discovers"); blocks averaged (10 s) for screening.
2. **Calibrate** the twin's effects: bounded linear least squares for amplitudes, profile search
   and bounded refinement for nonlinear parameters, 95 % intervals from the prewhitened (GLS) fit.
3. **Noise model**: AR(p), p by BIC ≤ 20, prewhitening per run keeping the first samples.
4. **Screen** every registered effect not in the model on its parameter grid: prewhitened F-test,
   Bonferroni over every test, ΔBIC, held-out gain by interleaved-block cross-validation.
   Decision: p_adj < 0.01 AND ΔBIC > 10 AND held-out gain > 5 %.
5. **Forward selection** for several effects: the best-ranked significant candidate is named,
   unless a testable candidate of another family outranks it (more ΔBIC, short of a threshold);
   then nothing is named, the pair is reported as ``withheld`` and the confidence is uncertain.
   A confidence label from the slow-residual share and run consistency.

Compare is blind: it sees the scenario's ``twin``, ``device.sensor`` and ``test_plan`` and the
measurement's columns, never ``device.effects`` or ground truth.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from scipy import stats
from scipy.ndimage import uniform_filter1d
from scipy.optimize import lsq_linear, minimize_scalar

from twin.effects import REGISTRY, Composition, Effect, EffectInputs, get_effect
from twin.measurement import Measurement
from twin.diagnosis.noise import ARModel, BlockAverager, fit_ar, white_noise_sigma_from_differences

# What would make an effect testable or separable (diagnosis-methods §2).
REMEDY = {
    "scale_factor": "add orientations: a +1 g / -1 g (tumble) run makes scale-factor drift odd in g",
    "bias_tc": "bias tempcos of MEMS, package and ASIC share one signature: only another package/board or "
               "self-test data separate them",
    "thermal_lag": "add a second probe on the PCB and a second ramp rate (lag and gradient respond differently)",
    "hysteresis": "add a second ramp rate and long dwells (lag scales with rate, hysteresis does not)",
    "aging": "return to the same temperature at start and end and repeat identical cycles",
    "warmup": "power-cycle the device 2-3 times at different chamber temperatures, keeping the first samples",
    "probe": "glue a calibrated reference probe to the package: a probe offset is absorbed by the fitted offset",
}


@dataclass
class DiagnosisConfig:
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


# --------------------------------------------------------------------------------------- problem


class Problem:
    """A measurement prepared for modelling."""

    def __init__(self, m: Measurement, config: DiagnosisConfig, sensor=None):
        self.m, self.config = m, config
        rate = m.sample_rate_hz
        self.rate_hz = rate
        w = max(1, int(round(config.smooth_temperature_s * rate)))
        temp = np.empty_like(m.temperature_c)
        for s in _run_slices(m.run_index):
            temp[s] = uniform_filter1d(m.temperature_c[s], w, mode="nearest") if w > 1 else m.temperature_c[s]
        applied = m.applied_g.copy()
        if not m.applied_known:  # orientation unknown: a per-run constant (absorbed by per-run offsets)
            for s in _run_slices(m.run_index):
                applied[s] = np.median(m.output_g[s])
        self.applied = applied
        self.inputs = EffectInputs(time_s=m.time_s, die_c=temp, thermometer_c=temp, applied_g=applied,
                                   run_index=m.run_index, time_since_power_on_s=m.time_since_power_on_s())
        self.y = m.output_g - applied
        self.avg = BlockAverager.build(m.run_index, int(round(config.average_s * rate)))
        self.run_avg = self.avg.run_of_block
        cols, names = [], []
        for r in range(m.runs):
            cols.append((m.run_index == r).astype(float))
            names.append(f"offset_run{r}")
        # sensitivity error K1 (IEEE 1293): separable from the per-run offsets only when the
        # orientation changes within a run (a tumble); with one orientation per run it is their difference
        if m.applied_known and any(np.std(applied[s]) > 0.1 for s in _run_slices(m.run_index)):
            cols.append(applied)
            names.append("scale_factor_k1")
        self.nuisance = np.column_stack(cols)
        self.nuisance_names = names
        self.sensor = sensor

    @property
    def n(self) -> int:
        return int(self.y.size)


def _run_slices(run_index: np.ndarray) -> list[slice]:
    edges = np.r_[0, np.flatnonzero(np.diff(run_index)) + 1, len(run_index)]
    return [slice(int(a), int(b)) for a, b in zip(edges[:-1], edges[1:])]


def _design(problem: Problem, comp: Composition, pinned: frozenset = frozenset()
            ) -> tuple[np.ndarray, list[tuple[str, str]], np.ndarray, EffectInputs]:
    """Full-rate columns of the model's free amplitudes, their names, the fixed part, the inputs.

    ``pinned`` amplitudes (exactly aliased ones) are held at their current values.
    """
    inputs = comp.with_die_temperature(problem.inputs)
    cols, names = [], []
    fixed = np.zeros(problem.n)
    for e in comp.drift_effects:
        fit_all = e.context.get("fit_all", False)  # added by the user: its amplitudes are calibrated too
        free = {p.name for p in e.parameters
                if p.role == "amplitude" and (p.free or fit_all) and (e.name, p.name) not in pinned}
        for amp, contrib in e.basis(inputs).items():
            col = np.broadcast_to(contrib.output_g(problem.applied), (problem.n,)).astype(float)
            if amp in free:
                cols.append(col)
                names.append((e.name, amp))
            else:
                fixed += e.values[amp] * col
    X = np.column_stack(cols) if cols else np.zeros((problem.n, 0))
    return X, names, fixed, inputs


def _bounds(comp: Composition, names, n_nuisance) -> tuple[np.ndarray, np.ndarray]:
    lo, hi = [-np.inf] * n_nuisance, [np.inf] * n_nuisance
    for eff, amp in names:
        p = next(p for p in get_effect(eff).parameters if p.name == amp)
        lo.append(p.bounds[0])  # columns are per unit of the parameter: bounds apply as they are
        hi.append(p.bounds[1])
    return np.array(lo), np.array(hi)


# ----------------------------------------------------------------------------------- calibration


@dataclass
class Calibration:
    composition: Composition
    names: list[tuple[str, str]]  # free amplitudes, in column order after the nuisance
    beta: np.ndarray  # nuisance then amplitudes
    cov: np.ndarray
    ar: ARModel
    X_full: np.ndarray  # nuisance + amplitude columns, full rate
    fixed_full: np.ndarray
    inputs: EffectInputs
    residual: np.ndarray  # full rate
    residual_avg: np.ndarray
    nonlinear_ci: dict[tuple[str, str], tuple[float, float]] = field(default_factory=dict)
    pinned: list[tuple[tuple[str, str], str]] = field(default_factory=list)  # (effect, amplitude), partner
    temperature_derivative: np.ndarray | None = None  # cache: ∂(drift)/∂(die temperature)

    @property
    def prediction_minus_applied(self) -> np.ndarray:
        return self.X_full @ self.beta + self.fixed_full


def _fit_linear(A: np.ndarray, b: np.ndarray, lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
    if A.shape[1] == 0:
        return np.zeros(0)
    scale = np.linalg.norm(A, axis=0)
    scale[scale == 0] = 1.0
    As = A / scale
    if np.all(np.isinf(lo)) and np.all(np.isinf(hi)):
        x = np.linalg.lstsq(As, b, rcond=None)[0]
    else:
        x = lsq_linear(As, b, bounds=(lo * scale, hi * scale), method="bvls", lsmr_tol="auto").x
    return x / scale


def _rss_for(problem: Problem, comp: Composition, pinned: frozenset = frozenset()) -> float:
    X, names, fixed, _ = _design(problem, comp, pinned)
    A = problem.avg(np.column_stack([problem.nuisance, X]))
    b = problem.avg(problem.y - fixed)
    lo, hi = _bounds(comp, names, problem.nuisance.shape[1])
    beta = _fit_linear(A, b, lo, hi)
    r = b - A @ beta
    return float(r @ r)


def _nonlinear_slots(comp: Composition) -> list[tuple[int, str]]:
    out = []
    for i, e in enumerate(comp.effects):
        for p in e.parameters:
            if p.role == "nonlinear" and p.free and len(p.grid) > 1:
                out.append((i, p.name))
    return out


def _with(comp: Composition, i: int, name: str, value: float) -> Composition:
    effects = list(comp.effects)
    effects[i] = effects[i].with_values(**{name: value})
    return Composition(effects)


def _exact_aliases(problem: Problem, comp: Composition) -> list[tuple[tuple[str, str], str]]:
    """Free amplitudes whose column the others (and the offsets) reproduce exactly; each is
    pinned at its current value, later effects first, and named with its partner."""
    X, names, _, _ = _design(problem, comp)
    A = problem.avg(np.column_stack([problem.nuisance, X]))
    labels = problem.nuisance_names + [f"{e}.{a}" for e, a in names]
    nn = problem.nuisance.shape[1]
    keep = list(range(A.shape[1]))
    out = []
    for j in range(A.shape[1] - 1, nn - 1, -1):
        others = [k for k in keep if k != j]
        if _novelty(A[:, [j]], _orthonormal(A[:, others])) < 1e-6:
            out.append((names[j - nn], _closest(A, j, others, labels)))
            keep.remove(j)
    return out


def _closest(A: np.ndarray, j: int, others: list[int], labels: list[str]) -> str:
    """Label of the column among ``others`` most correlated with column ``j``."""
    corr = [abs(np.corrcoef(A[:, j], A[:, k])[0, 1]) if np.std(A[:, k]) > 0 else 0.0 for k in others]
    return labels[others[int(np.argmax(corr))]] if corr else "the offsets"


def calibrate(problem: Problem, comp: Composition, config: DiagnosisConfig | None = None) -> Calibration:
    """Fit the model's free parameters to the measurement (see module docstring)."""
    config = config or problem.config
    aliases = _exact_aliases(problem, comp)
    pinned = frozenset(name for name, _ in aliases)
    slots = _nonlinear_slots(comp)
    for _ in range(2 if len(slots) > 1 else 1):
        for i, pname in slots:
            param = next(p for p in comp.effects[i].parameters if p.name == pname)
            grid = sorted(set(param.grid) | {comp.effects[i].values[pname]})
            rss = [_rss_for(problem, _with(comp, i, pname, v), pinned) for v in grid]
            k = int(np.argmin(rss))
            lo = grid[max(k - 1, 0)]
            hi = grid[min(k + 1, len(grid) - 1)]
            lo, hi = max(lo, param.bounds[0]), min(hi, param.bounds[1])
            best = grid[k]
            if hi > lo:
                res = minimize_scalar(lambda lv: _rss_for(problem, _with(comp, i, pname, float(np.exp(lv))), pinned),
                                      bounds=(np.log(max(lo, 1e-9)), np.log(hi)), method="bounded",
                                      options={"xatol": 1e-3})
                if res.fun <= rss[k]:
                    best = float(np.exp(res.x))
            comp = _with(comp, i, pname, best)
    X, names, fixed, inputs = _design(problem, comp, pinned)
    X_full = np.column_stack([problem.nuisance, X])
    A = problem.avg(X_full)
    b = problem.avg(problem.y - fixed)
    lo, hi = _bounds(comp, names, problem.nuisance.shape[1])
    beta = _fit_linear(A, b, lo, hi)
    r_avg = b - A @ beta
    ar = fit_ar(r_avg, problem.run_avg, config.max_ar_order)
    Aw = ar.prewhiten(A, problem.run_avg)
    rw = ar.prewhiten(r_avg, problem.run_avg)
    dof = max(1, A.shape[0] - A.shape[1])
    s2 = float(rw @ rw) / dof
    cov = s2 * np.linalg.pinv(Aw.T @ Aw)
    # write the fitted amplitudes back into the effects
    effects = list(comp.effects)
    nn = problem.nuisance.shape[1]
    for j, (eff, amp) in enumerate(names):
        idx = next(k for k, e in enumerate(effects) if e.name == eff)
        effects[idx] = effects[idx].with_values(**{amp: float(np.clip(beta[nn + j], lo[nn + j], hi[nn + j]))})
    comp = Composition(effects)
    residual = problem.y - X_full @ beta - fixed
    cal = Calibration(comp, names, beta, cov, ar, X_full, fixed, inputs, residual, r_avg)
    cal.nonlinear_ci = _profile_ci(problem, comp, ar, slots, pinned)
    cal.pinned = aliases
    return cal


def _profile_ci(problem: Problem, comp: Composition, ar: ARModel, slots, pinned: frozenset = frozenset()) -> dict:
    """95 % profile-likelihood interval of each nonlinear parameter: n ln(RSS/RSS_min) ≤ 3.84,
    RSS of the prewhitened averaged fit."""
    out = {}
    for i, pname in slots:
        v0 = comp.effects[i].values[pname]
        lo_b, hi_b = next(p.bounds for p in comp.effects[i].parameters if p.name == pname)
        # coarse ±1.2 in log for wide profiles, fine ±10 % for sharp ones
        steps = np.r_[np.linspace(-1.2, 1.2, 25), np.linspace(-0.1, 0.1, 21)]
        grid = np.unique(np.clip(v0 * np.exp(steps), lo_b, hi_b))
        rss = []
        for v in grid:
            c = _with(comp, i, pname, float(v))
            X, names, fixed, _ = _design(problem, c, pinned)
            A = problem.avg(np.column_stack([problem.nuisance, X]))
            b = problem.avg(problem.y - fixed)
            Aw, bw = ar.prewhiten(A, problem.run_avg), ar.prewhiten(b, problem.run_avg)
            beta = np.linalg.lstsq(Aw, bw, rcond=None)[0]
            r = bw - Aw @ beta
            rss.append(float(r @ r))
        n = problem.run_avg.size
        stat = n * np.log(np.array(rss) / min(rss))  # likelihood-ratio statistic, χ²(1) under H0
        k0 = int(np.argmin(stat))

        def crossing(ks):  # first grid step where the statistic passes 3.84, linearly interpolated
            for a, b in zip(ks[:-1], ks[1:]):
                if stat[b] > 3.84:
                    f = (3.84 - stat[a]) / (stat[b] - stat[a])
                    return float(grid[a] + f * (grid[b] - grid[a]))
            return float(grid[ks[-1]])

        lo_ci = crossing(list(range(k0, -1, -1))) if k0 > 0 else float(grid[0])
        hi_ci = crossing(list(range(k0, grid.size))) if k0 < grid.size - 1 else float(grid[-1])
        out[(comp.effects[i].name, pname)] = (lo_ci, hi_ci)
    return out


# ------------------------------------------------------------------------------------ screening


@dataclass
class CandidateResult:
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


def _screen_columns(problem: Problem, cal: Calibration, cls: type[Effect], values: dict[str, float]):
    """Full-rate candidate columns (n × m) and amplitude names."""
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
    cols = [np.broadcast_to(basis[a].output_g(problem.applied), (problem.n,)).astype(float) for a in names]
    return np.column_stack(cols), names


def _temperature_derivative(problem: Problem, cal: Calibration, h: float = 0.5) -> np.ndarray:
    """∂(model output)/∂(die temperature) of the calibrated drift effects [g/°C]."""
    def total(shift):
        inp = cal.inputs.replace(die_c=cal.inputs.die_c + shift, applied_g=problem.applied)
        out = np.zeros(problem.n)
        for e in cal.composition.drift_effects:
            out += np.broadcast_to(e.contribution(inp).output_g(problem.applied), (problem.n,))
        return out

    return (total(h) - total(-h)) / (2 * h)


def _orthonormal(Aw: np.ndarray) -> np.ndarray:
    """Orthonormal basis of the column space, rank-revealing (SVD of the column-normalised matrix).

    Plain QR is not: for a dependent column it still returns a unit vector, in an arbitrary
    direction outside the span, and the later columns are made orthogonal to it.
    """
    if Aw.shape[1] == 0:
        return np.zeros((Aw.shape[0], 0))
    norms = np.linalg.norm(Aw, axis=0)
    A = Aw[:, norms > 0] / norms[norms > 0]
    if A.shape[1] == 0:
        return np.zeros((Aw.shape[0], 0))
    u, sv, _ = np.linalg.svd(A, full_matrices=False)
    return u[:, sv > 1e-9 * sv[0]]


def _novelty(X: np.ndarray, Q: np.ndarray) -> float:
    """Share of a column's variance the design spanned by ``Q`` cannot mimic: 1 − R²(X ~ J).

    The smallest over the columns of X; 0 for a (numerically) constant column.
    """
    perp = X - Q @ (Q.T @ X)
    centred = X - X.mean(axis=0)
    denom = np.linalg.norm(centred, axis=0)
    scale = np.linalg.norm(X, axis=0)
    ok = denom > 1e-9 * np.maximum(scale, 1e-300)
    ratios = np.where(ok, (np.linalg.norm(perp, axis=0) / np.where(ok, denom, 1.0)) ** 2, 0.0)
    return float(np.clip(ratios.min(), 0.0, 1.0)) if ratios.size else 0.0


def _cv_folds(problem: Problem) -> np.ndarray:
    cfg = problem.config
    block = max(1, int(round(cfg.cv_block_s / cfg.average_s)))
    idx = np.arange(problem.run_avg.size)
    return (idx // block) % cfg.cv_folds


def _heldout_errors(A: np.ndarray, b: np.ndarray, folds: np.ndarray) -> np.ndarray:
    """Prediction errors of each block when its fold is held out (interleaved-block CV)."""
    err = np.empty_like(b)
    for f in np.unique(folds):
        test = folds == f
        beta = np.linalg.lstsq(A[~test], b[~test], rcond=None)[0]
        err[test] = b[test] - A[test] @ beta
    return err


def _heldout_sse(A: np.ndarray, b: np.ndarray, folds: np.ndarray) -> float:
    e = _heldout_errors(A, b, folds)
    return float(e @ e)


def _test_candidate(problem: Problem, J: np.ndarray, y: np.ndarray, X: np.ndarray, max_order: int):
    """GLS test of X on top of J, the AR noise model estimated under the alternative.

    Fitting the AR model to the base residual would let it learn a large missing effect and
    whiten it away; estimated from the residual of J + X it describes the noise that remains.
    Returns (delta_bic, F p-value, ERR, coefficients, their 95 % half-widths).
    """
    A1 = np.column_stack([J, X])
    r1 = y - A1 @ np.linalg.lstsq(A1, y, rcond=None)[0]
    ar = fit_ar(r1, problem.run_avg, max_order)
    runs = problem.run_avg
    Jw, Xw, yw = ar.prewhiten(J, runs), ar.prewhiten(X, runs), ar.prewhiten(y, runs)
    Q = _orthonormal(Jw)
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
    return float(n * np.log(rss0 / rss1) - m * np.log(n)), float(stats.f.sf(F, m, dof)), 1 - rss1 / rss0, coef, half


def refine_grid_value(problem: Problem, cal: Calibration, c: CandidateResult, J: np.ndarray,
                      y: np.ndarray) -> dict[str, float]:
    """The candidate's one varying nonlinear parameter (τ, play width) refined between its grid
    neighbours by maximising the screening ΔBIC on a log scale (diagnosis-methods §1 step 5);
    ``J``, ``y``: the calibrated model's design and target on averages, as in :func:`screen`."""
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
        X = problem.avg(_screen_columns(problem, cal, cls, {**c.grid_values, k: float(np.exp(log_v))})[0])
        return -_test_candidate(problem, J, y, X, problem.config.max_ar_order)[0]

    res = minimize_scalar(neg_dbic, bounds=(np.log(lo), np.log(hi)), method="bounded", options={"xatol": 0.01})
    best = float(np.exp(res.x)) if -res.fun > c.delta_bic else c.grid_values[k]
    return {**c.grid_values, k: best}


def screen(problem: Problem, cal: Calibration, candidates: list[str], extra: np.ndarray | None = None,
           n_tests: int | None = None) -> list[CandidateResult]:
    """Screen ``candidates`` on top of the calibrated model (plus ``extra`` full-rate columns)."""
    cfg = problem.config
    J_full = cal.X_full if extra is None else np.column_stack([cal.X_full, extra])
    J = problem.avg(J_full)
    y_avg = problem.avg(problem.y - cal.fixed_full)
    folds = _cv_folds(problem)
    Qraw = _orthonormal(J)
    if n_tests is None:
        n_tests = sum(len(get_effect(c).grid()) for c in candidates)
    results = []
    for name in candidates:
        cls = get_effect(name)
        best = None
        for g in cls.grid():
            X_full, amp_names = _screen_columns(problem, cal, cls, g)
            X = problem.avg(X_full)
            novelty = _novelty(X, Qraw)
            if novelty < 1e-6:  # what is left is round-off: regressing on it would be noise
                res = CandidateResult(name, cls.family, g, 0.0, 1.0, 1.0, 0.0, 0.0, novelty, {}, X_full)
            else:
                dbic, p, err, coef, half = _test_candidate(problem, J, y_avg, X, cfg.max_ar_order)
                amps = {a: (float(coef[j]), float(half[j])) for j, a in enumerate(amp_names)}
                res = CandidateResult(name, cls.family, g, dbic, p, min(1.0, p * n_tests), err, 0.0, novelty, amps,
                                      X_full)
            if best is None or res.delta_bic > best.delta_bic:
                best = res
        if best.delta_bic > 0:
            X = problem.avg(best.columns_full)
            # gain where the candidate acts: a power-on transient must not be diluted by hours of dwell
            act = np.abs(X - Qraw @ (Qraw.T @ X)).max(axis=1)
            support = act > 0.1 * act.max()
            e0 = _heldout_errors(J, y_avg, folds)[support]
            e1 = _heldout_errors(np.column_stack([J, X]), y_avg, folds)[support]
            sse0s, sse1s = float(e0 @ e0), float(e1 @ e1)
            best.heldout_gain = float(1 - np.sqrt(sse1s / sse0s)) if sse0s > 0 else 0.0
        best.significant = bool(best.p_adjusted < cfg.alpha and best.delta_bic > cfg.min_delta_bic
                                and best.heldout_gain > cfg.min_heldout_gain and cls.identifiable
                                and best.novelty >= cfg.alias_novelty)
        results.append(best)
    # what the data can test ranks before what it cannot, then by evidence
    results.sort(key=lambda r: (r.novelty >= cfg.alias_novelty and get_effect(r.effect).identifiable, r.delta_bic),
                 reverse=True)
    return results


# ---------------------------------------------------------------------------------- the report


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
    rivals: list[str] = field(default_factory=list)  # other families aliased with the named one, ≥ ½ its ΔBIC

    @property
    def rms_residual_g(self) -> float:
        return float(np.sqrt(np.mean(self.calibration.residual ** 2)))


def candidate_names(comp: Composition) -> list[str]:
    present = {e.name for e in comp.effects}
    has_slot = comp.temperature_effect is not None
    return sorted(n for n, c in REGISTRY.items()
                  if n not in present and n != "null" and not (c.slot == "temperature" and has_slot))


def _novelty_of_model(problem: Problem, cal: Calibration, cfg: DiagnosisConfig) -> list[dict]:
    """Model amplitudes this data cannot estimate (aliased with offsets or each other)."""
    A = problem.avg(cal.X_full)
    nn = problem.nuisance.shape[1]
    labels = problem.nuisance_names + [f"{e}.{a}" for e, a in cal.names]
    out = []
    for j, (eff, amp) in enumerate(cal.names):
        others = [k for k in range(A.shape[1]) if k != nn + j]
        novelty = _novelty(A[:, [nn + j]], _orthonormal(A[:, others]))
        if novelty < cfg.alias_novelty:
            out.append({"effect": eff, "parameter": amp, "novelty": novelty,
                        "aliased_with": _closest(A, nn + j, others, labels)})
    return out


def _segments(problem: Problem, residual: np.ndarray) -> dict:
    """Residual RMS per segment type, orientation, run and temperature bin."""
    m = problem.m
    temp = problem.inputs.die_c
    rate = np.gradient(uniform_filter1d(temp, max(1, int(60 * problem.rate_hz)), mode="nearest")) * problem.rate_hz
    kind = np.where(rate > 0.1 / 60, "heating", np.where(rate < -0.1 / 60, "cooling", "dwell"))
    rms = lambda x: float(np.sqrt(np.mean(x * x))) if x.size else float("nan")  # noqa: E731
    out = {"segment": {k: rms(residual[kind == k]) for k in ("dwell", "heating", "cooling") if np.any(kind == k)},
           "run": {str(r): rms(residual[m.run_index == r]) for r in range(m.runs)}}
    if m.applied_known:
        out["orientation"] = {f"{g:+g} g": rms(residual[np.isclose(problem.applied, g)])
                              for g in np.unique(np.round(problem.applied, 3))}
    bins = np.arange(np.floor(temp.min() / 5) * 5, temp.max() + 5, 5.0)
    which = np.digitize(temp, bins)
    out["temperature_bin_c"] = {f"{bins[k - 1]:g}..{bins[k - 1] + 5:g}": rms(residual[which == k])
                                for k in np.unique(which) if 0 < k <= bins.size}
    # loop area: ∮ r dT per run, in mg·°C (heating vs cooling difference)
    out["loop_area_mg_c"] = {str(r): float(np.sum(residual[m.run_index == r][:-1] * np.diff(temp[m.run_index == r])) * 1e3)
                             for r in range(m.runs)}
    out["kind"] = kind
    return out


def _slow_share(problem: Problem, before: np.ndarray, after: np.ndarray) -> float:
    w = max(1, int(round(problem.config.slow_window_s / problem.config.average_s)))
    s0 = uniform_filter1d(before, w, mode="nearest")
    s1 = uniform_filter1d(after, w, mode="nearest")
    v0 = float(np.var(s0))
    return float(1 - np.var(s1) / v0) if v0 > 0 else 0.0


def _run_consistency(problem: Problem, cal: Calibration, cand: CandidateResult) -> bool | None:
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
    return bool(stats.f.sf(F, k, dof) > 0.001)


def _testable(c: CandidateResult, cfg: DiagnosisConfig) -> bool:
    return c.novelty >= cfg.alias_novelty and get_effect(c.effect).identifiable


def _cross_family_partners(top: CandidateResult, aliases: list[dict], candidates: list[CandidateResult]) -> dict:
    """Effects of another family in an alias group with ``top`` (screened ones only) → their ΔBIC."""
    dbic = {c.effect: c.delta_bic for c in candidates}
    return {e: dbic[e] for a in aliases if "aliased_with" not in a and top.effect in a["effects"]
            for e in a["effects"] if e in dbic and get_effect(e).family != top.family}


def _next_selection(pool: list[CandidateResult], cfg: DiagnosisConfig):
    """The best-ranked significant testable candidate, and what outranks it if it cannot be claimed.

    A significant candidate ranked below a testable one of *another* family (more ΔBIC, but short
    of a threshold, e.g. held-out gain) is not claimed: the evidence prefers the other family, so
    naming either would be a guess. Returns (candidate or None, blocking candidate or None).
    """
    above: list[CandidateResult] = []
    for c in pool:
        if not _testable(c, cfg):
            continue
        if c.significant:
            return c, next((b for b in above if b.family != c.family), None)
        above.append(c)
    return None, None


def diagnose(problem: Problem, comp: Composition, noise_floor_model_g: float | None = None) -> Diagnosis:
    """Calibrate, audit, screen, select; see the module docstring."""
    cfg = problem.config
    cal = calibrate(problem, comp)
    names = candidate_names(cal.composition)
    if not problem.m.applied_known:
        names = [n for n in names if get_effect(n).family != "scale_factor"]
    n_tests = sum(len(get_effect(c).grid()) for c in names)
    first = screen(problem, cal, names, n_tests=n_tests)
    # forward selection
    selected: list[CandidateResult] = []
    pool = first
    extra = None
    withheld: list[dict] = []
    while pool and len(selected) < cfg.max_added:
        top, blocker = _next_selection(pool, cfg)
        if blocker is not None:
            withheld.append({"effect": top.effect, "family": top.family, "outranked_by": blocker.effect,
                             "outranked_by_family": blocker.family,
                             "delta_bic": [top.delta_bic, blocker.delta_bic]})
            break
        if top is None:
            break
        selected.append(top)
        extra = np.column_stack([extra, top.columns_full]) if extra is not None else top.columns_full
        rest = [c.effect for c in pool if c.effect != top.effect and c.family != top.family]
        pool = screen(problem, cal, rest, extra=extra, n_tests=n_tests) if rest else []
    A_full = cal.X_full
    A_avg = problem.avg(A_full)
    y_avg = problem.avg(problem.y - cal.fixed_full)
    if selected:  # the finding quotes the named effect's τ or width between grid points, not a grid point
        selected[0].refined_values = refine_grid_value(problem, cal, selected[0], A_avg, y_avg)
    # error after adding each candidate (linear refit at its best grid point), at the sample rate
    for c in first:
        X = c.columns_full
        beta = np.linalg.lstsq(np.column_stack([A_avg, problem.avg(X)]), y_avg, rcond=None)[0]
        r = problem.y - cal.fixed_full - np.column_stack([A_full, X]) @ beta
        c.rms_residual_g = float(np.sqrt(np.mean(r * r)))
    # audit: aliases among candidates, untestable effects, model amplitudes the data cannot fix
    untestable, aliases = [], []
    for c in first:
        cls = get_effect(c.effect)
        if not cls.identifiable or c.novelty < cfg.alias_novelty:
            why = ("structurally unidentifiable from residuals" if not cls.identifiable
                   else f"novelty {c.novelty:.3g}: what it would add, the calibrated model already absorbs")
            untestable.append({"effect": c.effect, "family": c.family, "reason": why,
                               "remedy": REMEDY.get(c.family, "")})
    if not problem.m.applied_known:
        for n in candidate_names(cal.composition):
            if get_effect(n).family == "scale_factor":
                untestable.append({"effect": n, "family": "scale_factor", "reason": "orientation not logged",
                                   "remedy": REMEDY["scale_factor"]})
    testable = [c for c in first if _testable(c, cfg)]
    J = problem.avg(cal.X_full)
    Q = _orthonormal(J)
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
    for g in groups:
        fams = sorted({get_effect(e).family for e in g})
        aliases.append({"effects": sorted(g), "families": fams,
                        "remedy": "; ".join(REMEDY.get(f, "") for f in fams if REMEDY.get(f))})
    model_aliased = [{"effect": e, "parameter": a, "novelty": 0.0, "aliased_with": partner, "pinned": True}
                     for (e, a), partner in cal.pinned]
    for a in _novelty_of_model(problem, cal, cfg):
        if all(a["effect"] != b["effect"] for b in model_aliased):
            model_aliased.append(a)
    confounded = [a for a in model_aliased if a["aliased_with"].startswith("offset_run")]
    m = problem.m
    if m.runs > 1 and not m.applied_known:
        temp = problem.inputs.die_c
        spans = [np.percentile(temp[s], 95) - np.percentile(temp[s], 5) for s in _run_slices(m.run_index)]
        medians = [np.median(temp[s]) for s in _run_slices(m.run_index)]
        between = max(medians) - min(medians)
        if between > 0 and max(spans) < 0.25 * between:
            entry = {"effects": ["orientation", "static_bias_tc"], "families": ["bias_tc"],
                     "aliased_with": "per-run offsets",
                     "remedy": (f"each run sits at a nearly constant temperature (within-run span ≤ {max(spans):.1f} °C, "
                                f"{between:.1f} °C between runs) and the orientation is not logged, so the per-run "
                                "offsets absorb gravity projection and temperature together: this data cannot separate "
                                "orientation from temperature; log the orientation, or ramp the temperature within a run "
                                "in a fixed orientation")}
            aliases.insert(0, entry)
            confounded.append(entry)
    for a in {a["effect"]: a for a in reversed(model_aliased)}.values():
        aliases.append({"effects": [a["effect"]], "families": [get_effect(a["effect"]).family],
                        "aliased_with": a["aliased_with"],
                        "remedy": ("the temperature is nearly constant within each run and the runs differ in "
                                   "orientation/offset: temperature and orientation cannot be separated; log the "
                                   "orientation and ramp the temperature within a run")
                        if a["aliased_with"].startswith("offset_run") else REMEDY.get(get_effect(a["effect"]).family, "")})
    # noise floor, confidence
    floor = white_noise_sigma_from_differences(cal.residual, problem.m.run_index)
    slow, consistent, rivals = None, None, []
    if selected:
        top = selected[0]
        X = problem.avg(top.columns_full)
        J2 = np.column_stack([problem.avg(cal.X_full), X])
        y2 = problem.avg(problem.y - cal.fixed_full)
        after = y2 - J2 @ np.linalg.lstsq(J2, y2, rcond=None)[0]
        slow = _slow_share(problem, cal.residual_avg, after)
        consistent = _run_consistency(problem, cal, top)
        # an aliased effect of another family with at least half the named one's ΔBIC is a rival
        # explanation: naming either is then a guess, however well it fits
        rivals = sorted(e for e, b in _cross_family_partners(top, aliases, first).items() if b >= 0.5 * top.delta_bic)
        confident = slow >= 0.5 and consistent is not False and not confounded and not rivals
        confidence = "confident" if confident else "uncertain"
    else:
        confidence = "uncertain" if confounded or withheld else "none"
    folds = _cv_folds(problem)
    heldout = float(np.sqrt(_heldout_sse(problem.avg(cal.X_full), problem.avg(problem.y - cal.fixed_full), folds)
                            / problem.run_avg.size))
    seg = _segments(problem, cal.residual)
    d = Diagnosis(cal, problem, first, selected, aliases, untestable, model_aliased, floor, noise_floor_model_g,
                  confidence, "", heldout, slow, consistent, seg, withheld, rivals)
    d.finding = finding_text(d)
    return d


# ------------------------------------------------------------------------------------ language


_SIGNATURE = {
    "thermal_lag": "The residual follows −dT/dt, changes sign between heating and cooling and settles in dwells",
    "hysteresis": "Heating and cooling branches of the residual differ at the same temperature (a loop in residual vs "
                  "temperature)",
    "scale_factor": "The residual flips sign with the orientation (odd in the applied g) and grows with temperature",
    "bias_tc": "The residual is a smooth function of temperature, the same on heating and cooling",
    "aging": "The residual drifts steadily in time, whatever the temperature",
    "warmup": "The residual has a transient after each power-on",
}


def _fmt_mg(x_g: float) -> str:
    return f"{x_g * 1e3:.3g} mg"


def finding_text(d: Diagnosis) -> str:
    """A plain-language finding for the report and the CLI."""
    rms = d.rms_residual_g
    parts = [f"This data cannot separate {' from '.join(a['effects'])}: {a['remedy']}." for a in d.aliases
             if a.get("aliased_with") == "per-run offsets"]
    if d.selected:
        top = d.selected[0]
        sig = _SIGNATURE.get(top.family, f"The residual has the signature of {top.family}")
        values = top.refined_values or top.grid_values
        param = ", ".join(f"{k} ≈ {v:.3g}" for k, v in values.items())
        phys = {"thermal_lag": f"the die lags the thermometer by ≈{values.get('tau_s', float('nan')):.0f} s"}.get(
            top.effect, f"best explanation: {top.effect}" + (f" ({param})" if param else ""))
        parts.append(f"{sig}: {phys}. Adding {top.effect} lowers the RMS from {_fmt_mg(rms)} to "
                     f"{_fmt_mg(top.rms_residual_g)}; noise floor {_fmt_mg(d.noise_floor_g)} "
                     f"(ΔBIC {top.delta_bic:.0f}, held-out gain {100 * top.heldout_gain:.0f} %).")
        if len(d.selected) > 1:
            parts.append("Also missing: " + ", ".join(c.effect for c in d.selected[1:]) + ".")
        if d.confidence == "uncertain":
            parts.append("Confidence is limited: " + ("structure remains after adding it (it removes "
                                                      f"{100 * (d.slow_share or 0):.0f} % of the slow residual)"
                                                      if (d.slow_share or 0) < 0.5 else "its coefficient differs between runs"
                                                      if d.run_consistent is False else
                                                      f"this data cannot tell it from {' / '.join(d.rivals)}"
                                                      if d.rivals else
                                                      "temperature is confounded with the per-run offsets") + ".")
    elif d.withheld:
        w = d.withheld[0]
        parts.append(f"{w['effect']} passes the significance tests, but {w['outranked_by']} ({w['outranked_by_family']}) "
                     f"explains more of the residual (ΔBIC {w['delta_bic'][1]:.0f} vs {w['delta_bic'][0]:.0f}) without "
                     f"passing them: the data do not say which effect is missing, so none is named. To separate "
                     f"them: {REMEDY.get(w['outranked_by_family'], 'a different test plan')}.")
    else:
        parts.append(f"No missing effect found: residual RMS {_fmt_mg(rms)} against a noise floor of "
                     f"{_fmt_mg(d.noise_floor_g)}.")
        if rms > 1.5 * d.noise_floor_g:
            parts.append(f"The residual is {rms / d.noise_floor_g:.1f}× the white-noise floor: slow correlated noise "
                         "or structure outside the library remains (see the Allan deviation and dwell plots).")
    remedies: dict[str, list[str]] = {}
    top_effects = {c.effect for c in d.selected}
    for a in d.aliases:
        if a.get("aliased_with") == "per-run offsets":
            continue
        if d.selected and not d.rivals:
            top = d.selected[0]
            others = _cross_family_partners(top, [a], d.candidates)
            if others:  # alike in shape, yet the evidence tells them apart: say so, not "not separable"
                best = max(others, key=others.get)
                parts.append(f"{' / '.join(a['effects'])} are alike in shape with this test plan, but the evidence "
                             f"separates them here: {top.effect} ΔBIC {top.delta_bic:.0f} against "
                             f"{others[best]:.0f} for {best}.")
                continue
        if "aliased_with" in a or top_effects & set(a["effects"]):
            remedies.setdefault(a["remedy"], []).append(" / ".join(a["effects"]) +
                                                        (f" (with {a['aliased_with']})" if "aliased_with" in a else ""))
    for u in d.untestable:
        if u["family"] in ("scale_factor", "probe"):
            remedies.setdefault(u["remedy"], []).append(u["effect"])
    for remedy, what in remedies.items():
        parts.append(f"Not separable or not testable with this data: {', '.join(dict.fromkeys(what))}. To fix: {remedy}.")
    return " ".join(parts)


def result_json(d: Diagnosis) -> dict:
    """The JSON contract of ``twin compare``."""
    cal = d.calibration
    params: dict[str, dict] = {}
    nn = d.problem.nuisance.shape[1]
    for e in cal.composition.effects:
        entry = {}
        for p in e.parameters:
            v = e.values[p.name]
            item = {"value": v, "unit": p.unit, "role": p.role, "free": p.free}
            if (e.name, p.name) in cal.names:
                j = nn + cal.names.index((e.name, p.name))
                half = 1.96 * float(np.sqrt(max(cal.cov[j, j], 0.0)))
                item["ci95"] = [v - half, v + half]
            if (e.name, p.name) in cal.nonlinear_ci:
                item["ci95"] = list(cal.nonlinear_ci[(e.name, p.name)])
            partner = next((pt for (en, an), pt in cal.pinned if (en, an) == (e.name, p.name)), None)
            if partner is not None:
                item["pinned"] = f"held at its default: aliased with {partner} in this data"
            lo, hi = p.bounds
            fitted = (e.name, p.name) in cal.names or (e.name, p.name) in cal.nonlinear_ci
            item["on_bound"] = bool(fitted and (np.isclose(v, lo, rtol=1e-6, atol=1e-12)
                                                                       or np.isclose(v, hi, rtol=1e-6, atol=1e-12)))
            item["outside_physical_range"] = bool(not lo <= v <= hi)
            entry[p.name] = item
        params[e.name] = entry
    params["nuisance"] = {name: {"value": float(cal.beta[j]), "unit": "g" if name.startswith("offset") else "1"}
                          for j, name in enumerate(d.problem.nuisance_names)}
    cands = [{
        "effect": c.effect, "family": c.family, "significant": c.significant, "rms_residual_g": c.rms_residual_g,
        "explained_fraction": c.explained_fraction, "delta_bic": c.delta_bic, "p_adjusted": c.p_adjusted,
        "heldout_gain": c.heldout_gain, "novelty": c.novelty, "parameters": c.grid_values,
        **({"parameters_refined": c.refined_values} if c.refined_values else {}),
        "amplitudes": {k: {"value": v, "ci95_half_width": w} for k, (v, w) in c.amplitudes.items()},
    } for c in d.candidates]
    seg = {k: v for k, v in d.segments.items() if k != "kind"}
    return {
        "rms_residual_g": d.rms_residual_g,
        "noise_floor_g": d.noise_floor_g,
        "noise_floor_model_g": d.noise_floor_model_g,
        "heldout_rms_g": d.heldout_rms_g,
        "effects": [e.name for e in cal.composition.effects],
        "parameters": params,
        "missing_effect_detected": bool(d.selected),
        "selected": [c.effect for c in d.selected],
        "withheld": d.withheld,
        "rivals": d.rivals,
        "confidence": d.confidence,
        "candidates": cands,
        "aliases": d.aliases,
        "untestable": d.untestable,
        "finding": d.finding,
        "noise_model": {"ar_order": cal.ar.order, "average_s": d.problem.config.average_s},
        "residual": seg,
        "samples": d.problem.n,
        "sample_rate_hz": d.problem.rate_hz,
        "runs": d.problem.m.runs,
    }
