"""Variable-projection search for the lag-aware model's time constants, and its covariance.

For given time constants the model is linear, so every trial (τ_die, τ_rate) costs two cached
lags and one least-squares solve for the three axes at once. Only the training rows' accelerations
enter; the lags run over the whole temperature log (an input).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.optimize import minimize

from twin.calibration.lag import ThermalLog, lagged_c
from twin.calibration.models import poly_columns

Z95 = 1.959963984540054
LAG_CACHE = 64  # full-length lagged temperatures kept: the grid's and the current refinement's


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


class Profile:
    """Training SSE per axis as a function of (τ_die, τ_rate), linear parameters projected out.

    Parameters
    ----------
    log : ThermalLog
        The whole temperature log (the lags run over it).
    y : (n, 3) ndarray
        Readings [g].
    keep : (n,) ndarray of bool
        Training rows.
    degree : int
        Polynomial degree in the die temperature.
    reference_c : float
        Expansion point [°C].
    """

    def __init__(self, log: ThermalLog, y: np.ndarray, keep: np.ndarray, degree: int, reference_c: float):
        self.log, self.y, self.keep = log, y[keep], keep
        self.degree, self.reference_c = degree, reference_c
        self._lags: dict[float, np.ndarray] = {}

    def lag(self, tau_s: float) -> np.ndarray:
        """Lagged temperature ``lag(T, τ)`` [°C] of the whole log, cached (least recently used dropped).

        Parameters
        ----------
        tau_s : float
            Time constant [s].

        Returns
        -------
        (n,) ndarray
            Lagged temperature [°C].
        """
        key = round(float(tau_s), 9)
        if key in self._lags:
            self._lags[key] = self._lags.pop(key)  # most recent last
        else:
            if len(self._lags) >= LAG_CACHE:  # refinements revisit recent values: drop the oldest
                self._lags.pop(next(iter(self._lags)))
            self._lags[key] = lagged_c(self.log, key)
        return self._lags[key]

    def design(self, tau_die_s: float, tau_rate_s: float | None, rows=slice(None)) -> np.ndarray:
        """(n, degree + 1 [+ 1]) columns: (T_die − ref)/10 °C powers [+ (T − lag(T, τ_rate)) °C].

        Parameters
        ----------
        tau_die_s : float
            Die lag [s].
        tau_rate_s : float or None
            Rate-term lag [s]; None or NaN: no rate column.
        rows : slice or ndarray, optional
            Rows returned.

        Returns
        -------
        ndarray
            The design matrix.
        """
        cols = poly_columns(self.lag(tau_die_s)[rows] - self.reference_c, self.degree)
        if tau_rate_s is None or not np.isfinite(tau_rate_s):
            return cols
        rate = self.log.temperature_c[rows] - self.lag(tau_rate_s)[rows]
        return np.column_stack([cols, rate])

    def sse(self, tau_die_s: float, tau_rate_s: float | None) -> np.ndarray:
        """Training residual sum of squares per axis [g²], floored above zero.

        Parameters
        ----------
        tau_die_s, tau_rate_s : float, float or None
            Die and rate-term lags [s].

        Returns
        -------
        (3,) ndarray
            SSE per axis [g²].
        """
        F = self.design(tau_die_s, tau_rate_s, self.keep)
        coef, *_ = np.linalg.lstsq(F, self.y, rcond=None)
        # floored: an exact fit (a noise-free log) must not send log(SSE) to -inf in the scores
        return np.maximum(((self.y - F @ coef) ** 2).sum(axis=0), np.finfo(float).tiny * self.y.shape[0])

    def residual(self, tau_die_s: float, tau_rate_s: float | None) -> np.ndarray:
        """Training residual per axis [g] at the given lags.

        Parameters
        ----------
        tau_die_s, tau_rate_s : float, float or None
            Die and rate-term lags [s].

        Returns
        -------
        (n_train, 3) ndarray
            Residual [g].
        """
        F = self.design(tau_die_s, tau_rate_s, self.keep)
        coef, *_ = np.linalg.lstsq(F, self.y, rcond=None)
        return self.y - F @ coef


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
    n, deg = profile.y.shape[0], profile.degree
    i, j = np.unravel_index(np.argmin(np.log(with_rate).sum(-1)), with_rate.shape[:2])
    n_eff = ar1_effective_n(profile.residual(die_grid[i], rate_grid[j]))  # fixed across candidates
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


def covariance(profile: Profile, tau_d: np.ndarray, tau_g: np.ndarray, coef: list[np.ndarray],
               shared: bool) -> tuple[list[np.ndarray], np.ndarray, np.ndarray]:
    """Gauss–Newton covariance of all parameters (linear and τ's), AR(1)-inflated per axis.

    Parameters
    ----------
    profile : Profile
        The training profile.
    tau_d, tau_g : (3,) ndarray
        Die and rate-term lags per axis [s] (NaN: no rate term).
    coef : list of ndarray
        Linear coefficients per axis.
    shared : bool
        Whether the τ's are shared by the axes.

    Returns
    -------
    (lin_cov, se_die, se_rate) : list of ndarray, (3,) ndarray, (3,) ndarray
        Per-axis covariance of the linear coefficients, and standard errors [s] of
        τ_die and τ_rate per axis (NaN where unused).
    """
    keep, n = profile.keep, profile.y.shape[0]
    blocks = []
    for a in range(3):
        g = tau_g[a] if np.isfinite(tau_g[a]) else None
        F = profile.design(tau_d[a], g, keep)
        r = profile.y[:, a] - F @ coef[a]
        dcols = [_d_dtau(profile, tau_d[a], g, coef[a], keep, "die")]
        if g is not None:
            dcols.append(_d_dtau(profile, tau_d[a], g, coef[a], keep, "rate"))
        power = max(float(r @ r), np.finfo(float).tiny * n)  # an exact fit: zero-width intervals, not NaN
        rho = float(np.clip((r[1:] @ r[:-1]) / power, 0.0, 0.95))
        sigma = np.sqrt(power / max(n - F.shape[1] - len(dcols), 1) * (1 + rho) / (1 - rho))
        blocks.append((F / sigma, np.column_stack(dcols) / sigma))
    n_lin = [b[0].shape[1] for b in blocks]
    n_tau = 2 if shared and np.isfinite(tau_g[0]) else (1 if shared else 0)
    tau_idx, P = [], sum(n_lin) + (n_tau if shared else sum(b[1].shape[1] for b in blocks))
    J = np.zeros((3 * n, P))
    col = sum(n_lin)
    for a, (F, D) in enumerate(blocks):
        rows = slice(a * n, (a + 1) * n)
        start = sum(n_lin[:a])
        J[rows, start:start + n_lin[a]] = F
        idx = list(range(sum(n_lin), sum(n_lin) + D.shape[1])) if shared else list(range(col, col + D.shape[1]))
        col += 0 if shared else D.shape[1]
        J[rows, idx] = D
        tau_idx.append(idx)
    norms = np.linalg.norm(J, axis=0)
    norms[norms == 0] = 1.0
    cov = np.linalg.pinv((J / norms).T @ (J / norms)) / np.outer(norms, norms)
    lin_cov, se_d, se_g = [], np.full(3, np.nan), np.full(3, np.nan)
    for a in range(3):
        start = sum(n_lin[:a])
        lin_cov.append(cov[start:start + n_lin[a], start:start + n_lin[a]])
        se = np.sqrt(np.diag(cov)[tau_idx[a]])
        se_d[a] = se[0]
        if se.size > 1:
            se_g[a] = se[1]
    return lin_cov, se_d, se_g


def _d_dtau(profile: Profile, tau_d: float, tau_g: float | None, coef: np.ndarray, rows, which: str) -> np.ndarray:
    """∂prediction/∂τ [g/s] by central differences of the lag (forward at τ = 0)."""
    tau = tau_d if which == "die" else tau_g
    h = max(1e-3 * tau, 0.05)
    lo = max(tau - h, 0.0)
    hi = tau + h
    if which == "die":
        up, down = profile.design(hi, tau_g, rows) @ coef, profile.design(lo, tau_g, rows) @ coef
    else:
        up, down = profile.design(tau_d, hi, rows) @ coef, profile.design(tau_d, lo, rows) @ coef
    return (up - down) / (hi - lo)
