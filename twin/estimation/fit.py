"""Calibrate the twin's effects to the measurement (docs/diagnosis.md §1 step 2).

Bounded linear least squares for amplitudes, profile search and bounded refinement for nonlinear
parameters, 95 % intervals from the prewhitened (GLS) fit and the profile likelihood; amplitudes
the others reproduce exactly are held at their current values and named with their partner.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from twin.estimation.linalg import (
    closest_column,
    fit_bounded_linear,
    novelty,
    orthonormal_basis,
)
from twin.estimation.noise import ARModel, fit_ar
from twin.estimation.problem import (
    DiagnosisConfig,
    Problem,
    amplitude_bounds,
    averaged_design,
    design_matrix,
)
from twin.estimation.search import bounded_minimum
from twin.effects import Composition, EffectInputs


@dataclass
class TwinFit:
    """The twin calibrated to a measurement (docs/diagnosis.md §1 step 2).

    Attributes
    ----------
    composition : Composition
        The model with its fitted values.
    names : list of (effect, amplitude)
        Free amplitudes, in column order after the nuisance.
    beta, cov : np.ndarray
        Nuisance then amplitudes [g per column unit], and their covariance from the prewhitened fit.
    ar : ARModel
        The residual's noise model.
    X_full, fixed_full : np.ndarray
        Nuisance + amplitude columns, and the output of everything not free [g], full rate.
    inputs : EffectInputs
        The inputs with the model's die temperature.
    residual, residual_avg : np.ndarray
        The residual at full rate and on block means [g].
    rss_prewhitened : float
        Σ of the prewhitened residual on block means squared: the BIC's RSS [g²].
    nonlinear_ci : dict
        (effect, parameter) → 95 % profile-likelihood interval [the parameter's unit].
    pinned : list of ((effect, amplitude), partner)
        Amplitudes held at their values, exactly aliased with ``partner``.
    temperature_derivative : np.ndarray, optional
        Cache: ∂(drift)/∂(die temperature) [g/°C].
    """

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
    rss_prewhitened: float  # Σ of the prewhitened residual on block means squared: the BIC's RSS
    nonlinear_ci: dict[tuple[str, str], tuple[float, float]] = field(default_factory=dict)
    pinned: list[tuple[tuple[str, str], str]] = field(default_factory=list)  # (effect, amplitude), partner
    temperature_derivative: np.ndarray | None = None  # cache: ∂(drift)/∂(die temperature)

    @property
    def free_parameters(self) -> int:
        """Offsets, free amplitudes and free nonlinear parameters: the k of an information criterion."""
        return self.beta.size + len(_nonlinear_slots(self.composition))

    @property
    def prediction_minus_applied(self) -> np.ndarray:
        """The calibrated twin's output minus the applied acceleration, full rate [g]."""
        return self.X_full @ self.beta + self.fixed_full

    def equation(self, nuisance_names: list[str] | None = None) -> str:
        """The calibrated twin: each effect with its fitted parameters, units and 95 % intervals.

        Parameters
        ----------
        nuisance_names : list of str, optional
            Names of the nuisance columns (default ``nuisance0`` …).

        Returns
        -------
        str
            One line per offset [g] and per effect.
        """
        n_nuisance = self.beta.size - len(self.names)
        lines = ["output − applied = Σ offsets + Σ effects, with"]
        for j, name in enumerate(nuisance_names or [f"nuisance{j}" for j in range(n_nuisance)]):
            lines.append(f"  {name} = {self.beta[j]:+.6g}")
        for e in self.composition.effects:
            values = []
            for p in e.parameters:
                v = e.values[p.name]
                text = f"{p.name} = {v:.6g} {p.unit}"
                if (e.name, p.name) in self.names:
                    k = n_nuisance + self.names.index((e.name, p.name))
                    text += f" ± {1.96 * np.sqrt(max(self.cov[k, k], 0.0)):.2g}"
                elif (e.name, p.name) in self.nonlinear_ci:
                    lo, hi = self.nonlinear_ci[(e.name, p.name)]
                    text += f" [{lo:.4g}, {hi:.4g}]"
                elif not p.free:
                    text += " (fixed)"
                values.append(text)
            lines.append(f"  {e.name}: {'; '.join(values) or 'no parameters'}")
        return "\n".join(lines)


def _rss_for(problem: Problem, comp: Composition, pinned: frozenset = frozenset()) -> float:
    A, b, names = averaged_design(problem, comp, pinned)
    lo, hi = amplitude_bounds(names, problem.nuisance.shape[1])
    beta = fit_bounded_linear(A, b, lo, hi)
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


def exact_aliases(problem: Problem, comp: Composition) -> list[tuple[tuple[str, str], str]]:
    """Free amplitudes whose column the others (and the offsets) reproduce exactly; each is
    pinned at its current value, later effects first, and named with its partner.

    Parameters
    ----------
    problem : Problem
    comp : Composition

    Returns
    -------
    list of ((effect, amplitude), partner label)
    """
    X, names, _, _ = design_matrix(problem, comp)
    A = problem.avg(np.column_stack([problem.nuisance, X]))
    labels = problem.nuisance_names + [f"{e}.{a}" for e, a in names]
    nn = problem.nuisance.shape[1]
    keep = list(range(A.shape[1]))
    out = []
    for j in range(A.shape[1] - 1, nn - 1, -1):
        others = [k for k in keep if k != j]
        if novelty(A[:, [j]], orthonormal_basis(A[:, others])) < 1e-6:
            out.append((names[j - nn], closest_column(A, j, others, labels)))
            keep.remove(j)
    return out


def fit_twin(problem: Problem, comp: Composition, config: DiagnosisConfig | None = None,
              intervals: bool = True) -> TwinFit:
    """Fit the model's free parameters to the measurement (see the module docstring).

    Parameters
    ----------
    problem : Problem
        The prepared measurement.
    comp : Composition
        The model; its values start the nonlinear search.
    config : DiagnosisConfig, optional
        Defaults to ``problem.config``.
    intervals : bool
        Profile-likelihood intervals of the nonlinear parameters (most of the cost); without
        them ``nonlinear_ci`` is empty.

    Returns
    -------
    TwinFit
    """
    config = config or problem.config
    aliases = exact_aliases(problem, comp)
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
                res = bounded_minimum(lambda lv: _rss_for(problem, _with(comp, i, pname, float(np.exp(lv))), pinned),
                                      np.log(max(lo, 1e-9)), np.log(hi), xatol=1e-3)
                if res.fun <= rss[k]:
                    best = float(np.exp(res.x))
            comp = _with(comp, i, pname, best)
    X, names, fixed, inputs = design_matrix(problem, comp, pinned)
    X_full = np.column_stack([problem.nuisance, X])
    A = problem.avg(X_full)
    b = problem.avg(problem.y - fixed)
    lo, hi = amplitude_bounds(names, problem.nuisance.shape[1])
    beta = fit_bounded_linear(A, b, lo, hi)
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
    cal = TwinFit(comp, names, beta, cov, ar, X_full, fixed, inputs, residual, r_avg, float(rw @ rw))
    if intervals:
        cal.nonlinear_ci = profile_ci(problem, comp, ar, slots, pinned)
    cal.pinned = aliases
    return cal


def profile_ci(problem: Problem, comp: Composition, ar: ARModel, slots, pinned: frozenset = frozenset()) -> dict:
    """95 % profile-likelihood interval of each nonlinear parameter: n ln(RSS/RSS_min) ≤ 3.84,
    RSS of the prewhitened averaged fit (3.84: the 95 % point of χ²(1); Wilks 1938, Ann. Math. Stat. 9:60).

    Parameters
    ----------
    problem : Problem
    comp : Composition
        The calibrated model.
    ar : ARModel
        The noise model used for prewhitening.
    slots : list of (effect index, parameter name)
        The free nonlinear parameters.
    pinned : frozenset of (effect, amplitude)
        Amplitudes held at their values.

    Returns
    -------
    dict
        (effect, parameter) → (low, high).
    """
    out = {}
    for i, pname in slots:
        v0 = comp.effects[i].values[pname]
        lo_b, hi_b = next(p.bounds for p in comp.effects[i].parameters if p.name == pname)
        # coarse ±1.2 in log for wide profiles, fine ±10 % for sharp ones
        steps = np.r_[np.linspace(-1.2, 1.2, 25), np.linspace(-0.1, 0.1, 21)]
        grid = np.unique(np.clip(v0 * np.exp(steps), lo_b, hi_b))
        rss = []
        for v in grid:
            A, b, _ = averaged_design(problem, _with(comp, i, pname, float(v)), pinned)
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
