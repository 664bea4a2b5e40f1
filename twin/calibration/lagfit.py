"""Variable-projection search for the lag-aware model's time constants, and its covariance.

For given time constants the model is linear, so every trial (τ_die, τ_rate) costs two cached
lags and one least-squares solve for the three axes at once (:class:`~twin.calibration.lagprofile.Profile`:
on block means of a fast log). Only the training rows' accelerations enter; the lags run over the
whole temperature log (an input). The candidates are scored (BIC) with the search's SSE and an
effective sample size from the full-rate residual; the final amplitudes and their covariance are
full rate (:func:`linear_fit`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.optimize import minimize

from twin.calibration.lagprofile import FullStats, Profile

Z95 = 1.959963984540054


@dataclass(frozen=True)
class LagCandidate:
    """One model structure tried during selection, scored on the training rows only.

    Attributes
    ----------
    name : str
        ``"shared"`` (one τ_die, one τ_rate for all axes) or ``"per-axis"``, and the rate terms.
    tau_die_s, tau_rate_s : tuple of 3 floats
        Time constants [s] per axis (equal when shared; NaN where the axis has no rate term).
    rms_mg : tuple of 3 floats
        Training RMS [mg].
    n_params : int
        Linear + nonlinear parameters.
    bic : float
        Σ_axes n_eff·ln(SSE/n) + n_params·ln(n_eff) (n_eff: AR(1)-effective sample size).
    """

    name: str
    tau_die_s: tuple
    tau_rate_s: tuple
    rms_mg: tuple
    n_params: int
    bic: float


def refine(objective, start: np.ndarray, bounds: list[tuple[float, float]]) -> np.ndarray:
    """Bounded quasi-Newton polish of a grid optimum (τ in units of 10 s for the step sizes).

    Parameters
    ----------
    objective : callable
        Function of the τ vector [s] to minimise.
    start : ndarray
        Grid optimum [s].
    bounds : list of (float, float)
        Bounds per τ [s].

    Returns
    -------
    ndarray
        The polished τ's [s] (``start`` when no better).
    """
    # a log sampled more coarsely than the τ bound puts the least resolvable τ (twice the step) above
    # it: the interval collapses to that τ instead of inverting (L-BFGS-B refuses lower > upper)
    scaled = [(lo / 10.0, max(lo, hi) / 10.0) for lo, hi in bounds]
    res = minimize(lambda v: objective(v * 10.0), np.asarray(start, float) / 10.0, method="L-BFGS-B",
                   bounds=scaled, options={"eps": 1e-4, "maxiter": 200})
    best, start = res.x * 10.0, np.asarray(start, float)
    if not np.all(np.isfinite(best)):  # a flat or exact (noise-free) objective can send L-BFGS to NaN
        return start
    return best if objective(best) <= objective(start) else start


def ar1_effective_n(residual: np.ndarray) -> np.ndarray:
    """n·(1 − ρ)/(1 + ρ) per column, ρ the lag-1 autocorrelation (clipped to [0, 0.95]).

    Parameters
    ----------
    residual : (n, k) ndarray
        Residuals per column.

    Returns
    -------
    (k,) ndarray
        Effective sample size per column.
    """
    r = residual - residual.mean(axis=0)
    power = np.maximum((r * r).sum(axis=0), np.finfo(float).tiny)  # a zero residual: ρ = 0, not NaN
    rho = np.clip((r[1:] * r[:-1]).sum(axis=0) / power, 0.0, 0.95)
    return r.shape[0] * (1 - rho) / (1 + rho)


def effective_n(stats: FullStats) -> np.ndarray:
    """:func:`ar1_effective_n` of a residual known by its sums (:meth:`Profile.full_stats`).

    Parameters
    ----------
    stats : FullStats

    Returns
    -------
    (3,) ndarray
        Effective sample size per axis.
    """
    n = stats.n
    m = stats.total / n  # about the residual's mean, as ar1_effective_n
    power = np.maximum(stats.sse - n * m * m, np.finfo(float).tiny)
    lag1 = stats.lag1 - m * (2 * stats.total - stats.first - stats.last) + (n - 1) * m * m
    rho = np.clip(lag1 / power, 0.0, 0.95)
    return n * (1 - rho) / (1 + rho)


def search(profile: Profile, bounds_s: tuple[float, float], min_rate_tau_s: float, n_grid: int,
           share: str, rate_term) -> tuple[LagCandidate, tuple[LagCandidate, ...]]:
    """Grid + refinement of every allowed structure; returns (selected by BIC, all candidates).

    Parameters
    ----------
    profile : Profile
        The training profile.
    bounds_s : (float, float)
        Range of τ [s].
    min_rate_tau_s : float
        Smallest rate-term τ [s].
    n_grid : int
        Grid points per τ.
    share : {"auto", "shared", "per_axis"}
        Structures tried.
    rate_term : "auto" or bool
        Whether the rate term is tried, forced or left out.

    Returns
    -------
    (LagCandidate, tuple of LagCandidate)
        The candidate with the lowest BIC, and all candidates.
    """
    lo, hi = bounds_s
    die_grid = np.r_[lo if lo > 0 else 0.0, np.geomspace(max(lo, min_rate_tau_s), hi, n_grid)]
    rate_grid = np.geomspace(max(lo, min_rate_tau_s), hi, n_grid)
    with_rate = np.array([[profile.sse(d, g) for g in rate_grid] for d in die_grid])  # (d, g, 3)
    no_rate = np.array([profile.sse(d, None) for d in die_grid])  # (d, 3)
    n, deg = profile.n, profile.degree
    i, j = np.unravel_index(np.argmin(np.log(with_rate).sum(-1)), with_rate.shape[:2])
    d, g = die_grid[i], rate_grid[j]
    n_eff = effective_n(profile.full_stats(d, g, profile.search_coef(d, g)))  # fixed across candidates
    ln_n = float(np.log(n_eff.mean()))
    b_die, b_rate = (lo, hi), (max(lo, min_rate_tau_s), hi)

    def score(sse: np.ndarray) -> float:
        return float((n_eff * np.log(sse / n)).sum())

    def make(name, tau_d, tau_g, sse, k) -> LagCandidate:
        return LagCandidate(name, tuple(map(float, tau_d)), tuple(map(float, tau_g)),
                         tuple(np.sqrt(sse / n) * 1e3), k, score(sse) + k * ln_n)

    out = []
    rates = [True, False] if rate_term == "auto" else [bool(rate_term)]
    if share in ("auto", "shared"):
        for use in rates:
            if use:
                i, j = np.unravel_index(np.argmin((n_eff * np.log(with_rate)).sum(-1)), with_rate.shape[:2])
                d, g = refine(lambda v: (n_eff * np.log(profile.sse(*v))).sum(), [die_grid[i], rate_grid[j]],
                              [b_die, b_rate])
                out.append(make("shared τ_die, τ_rate; rate term on all axes", [d] * 3, [g] * 3,
                                profile.sse(d, g), 3 * (deg + 2) + 2))
            else:
                i = int(np.argmin((n_eff * np.log(no_rate)).sum(-1)))
                (d,) = refine(lambda v: (n_eff * np.log(profile.sse(v[0], None))).sum(), [die_grid[i]], [b_die])
                out.append(make("shared τ_die; no rate term", [d] * 3, [np.nan] * 3, profile.sse(d, None),
                                3 * (deg + 1) + 1))
    if share in ("auto", "per_axis"):
        taus_d, taus_g, sse, k = np.zeros(3), np.full(3, np.nan), np.zeros(3), 0
        for a in range(3):
            options = []
            if True in rates:
                i, j = np.unravel_index(np.argmin(with_rate[..., a]), with_rate.shape[:2])
                d, g = refine(lambda v: np.log(profile.sse(*v)[a]), [die_grid[i], rate_grid[j]], [b_die, b_rate])
                options.append((d, g, profile.sse(d, g)[a], deg + 4))
            if False in rates:
                i = int(np.argmin(no_rate[:, a]))
                (d,) = refine(lambda v: np.log(profile.sse(v[0], None)[a]), [die_grid[i]], [b_die])
                options.append((d, np.nan, profile.sse(d, None)[a], deg + 2))
            # each axis keeps its rate term only if the term pays for itself in BIC
            d, g, s, ka = min(options, key=lambda o: n_eff[a] * np.log(o[2] / n) + o[3] * ln_n)
            taus_d[a], taus_g[a], sse[a], k = d, g, s, k + ka
        used = "".join(ax for ax, g in zip("xyz", taus_g) if np.isfinite(g)) or "no axis"
        out.append(make(f"per-axis τ's; rate term on {used}", taus_d, taus_g, sse, k))
    return min(out, key=lambda c: c.bic), tuple(out)


def linear_fit(profile: Profile, tau_d: np.ndarray, tau_g: np.ndarray, shared: bool):
    """The linear coefficients per axis at the given τ's on every full-rate training row, and the
    Gauss–Newton covariance of all parameters (linear and τ's), AR(1)-inflated per axis.

    Per distinct (τ_die, τ_rate) (one for all three axes when shared) two passes over the full-rate
    training rows, chunk by chunk — the coefficients, then the residual's power and lag-1
    autocorrelation — and JᵀJ, axis by axis, on the search's rows
    (:meth:`~twin.calibration.lagprofile.Profile.gauss_newton_blocks`): no full-length design or
    Jacobian is formed.

    Parameters
    ----------
    profile : Profile
        The training profile.
    tau_d, tau_g : (3,) ndarray
        Die and rate-term lags per axis [s] (NaN: no rate term).
    shared : bool
        Whether the τ's are shared by the axes.

    Returns
    -------
    (coef, rms_mg, lin_cov, se_die, se_rate) : list of ndarray, (3,) ndarray, list of ndarray, (3,) ndarray, (3,) ndarray
        Linear coefficients per axis, training RMS [mg], the covariance of each axis' linear
        coefficients, and standard errors [s] of τ_die and τ_rate per axis (NaN where unused).
    """
    n = profile.n
    rated = np.isfinite(tau_g)
    n_lin = [profile.degree + 1 + int(r) for r in rated]
    n_dtau = [1 + int(r) for r in rated]
    tau_idx, col = [], sum(n_lin)
    for a in range(3):  # shared: every axis's ∂/∂τ columns are the same parameters
        tau_idx.append(list(range(sum(n_lin), sum(n_lin) + n_dtau[a])) if shared else list(range(col, col + n_dtau[a])))
        col += 0 if shared else n_dtau[a]
    P = sum(n_lin) + (max(n_dtau) if shared else sum(n_dtau))
    groups: dict = {}  # axes sharing (τ_die, τ_rate) share their design and its passes
    for a in range(3):
        groups.setdefault((float(tau_d[a]), float(tau_g[a]) if rated[a] else None), []).append(a)
    coef, rms, parts = [None] * 3, np.zeros(3), []
    for (d, g), axes in groups.items():
        C = profile.full_coef(d, g)
        stats, blocks = profile.full_stats(d, g, C), profile.gauss_newton_blocks(d, g, C)
        for a in axes:
            coef[a] = C[:, a]
            rms[a] = np.sqrt(stats.sse[a] / n) * 1e3
            power = max(float(stats.sse[a]), np.finfo(float).tiny * n)  # an exact fit: zero-width intervals, not NaN
            rho = float(np.clip(stats.lag1[a] / power, 0.0, 0.95))
            sigma = np.sqrt(power / max(n - n_lin[a] - n_dtau[a], 1) * (1 + rho) / (1 - rho))
            start = sum(n_lin[:a])
            parts.append((list(range(start, start + n_lin[a])) + tau_idx[a], blocks[a], sigma))
    cov = _normalised_inverse(parts, P)
    lin_cov, se_d, se_g = [], np.full(3, np.nan), np.full(3, np.nan)
    for a in range(3):
        start = sum(n_lin[:a])
        lin_cov.append(cov[start:start + n_lin[a], start:start + n_lin[a]])
        se = np.sqrt(np.diag(cov)[tau_idx[a]])
        se_d[a] = se[0]
        if se.size > 1:
            se_g[a] = se[1]
    return coef, rms, lin_cov, se_d, se_g


def _normalised_inverse(parts, P: int) -> np.ndarray:
    """pinv(JᵀJ) for J stacked from blocks (columns ``cols``, ``AᵀA``, σ) as J = [A/σ …], computed
    as pinv((J/‖J‖)ᵀ(J/‖J‖)) / ‖J‖‖J‖ᵀ with every factor kept near 1: 1/σ² of an exact fit (σ at
    the floor, 10⁻¹⁵⁴) would overflow where 1/σ does not, and the interval of such a fit is zero."""
    contrib = []
    for cols, K, sigma in parts:
        d = np.sqrt(np.diag(K))
        contrib.append(d / sigma)  # ‖A column‖/σ: finite down to σ's floor
    norms = np.zeros(P)
    for (cols, _, _), c in zip(parts, contrib):
        norms[cols] = np.maximum(norms[cols], c)
    scale = np.where(norms > 0, norms, 1.0)
    squares = np.zeros(P)
    for (cols, _, _), c in zip(parts, contrib):
        squares[cols] += (c / scale[cols]) ** 2
    norms = scale * np.sqrt(squares)  # ‖J column‖, without squaring a large number
    norms[norms == 0] = 1.0
    G = np.zeros((P, P))
    for (cols, K, _), c in zip(parts, contrib):
        d = np.sqrt(np.diag(K))
        d[d == 0] = 1.0
        u = c / norms[cols]
        G[np.ix_(cols, cols)] += K / np.outer(d, d) * np.outer(u, u)
    with np.errstate(over="ignore"):  # ‖J‖‖J‖ᵀ of an exact fit is inf: its covariance is 0
        return np.linalg.pinv(G) / np.outer(norms, norms)
