"""Least squares of polynomials in temperature from Gram matrices, for logs of millions of rows.

:class:`~twin.calibration.models.TemperaturePolynomial` chooses each axis' degree by leaving out
contiguous blocks of its training rows, degree by degree. Here every block is reduced once to the
Gram matrix of ``[T_0(u) … T_top(u) | y − level]``: Chebyshev polynomials of the temperature mapped
to u ∈ [−1, 1] over the training range (in that basis the normal equations stay well conditioned
up to degree 7, where the powers (ΔT/10)^k reach a condition number of 10¹²), and the readings
about their training mean. Every degree and every held-out block is then a small solve: the
training Gram is the sum of the other blocks', the held-out SSE is ``yᵀy − 2cᵀb + cᵀGc`` of the
block (recomputed from its rows when that difference cancels to under 10⁻⁶ of ``yᵀy``: a fit
close to exact). One pass over the rows per fit, whatever the degrees tried; the coefficients are
turned into the powers (ΔT/10)^k at the end, the covariance with them.
"""

from __future__ import annotations

import numpy as np
from numpy.polynomial import chebyshev
from numpy.polynomial import polynomial as power

SCALE_C = 10.0  # (ΔT / 10 °C)^k: the power basis the coefficients are reported in (and the lag-aware design's)
CANCELLED = 1e-6  # a held-out SSE under this share of yᵀy is recomputed from the block's rows
CHUNK = 1 << 16  # rows per step of the residual pass


def chebyshev_columns(u: np.ndarray, degree: int, out: np.ndarray | None = None) -> np.ndarray:
    """Columns ``T_k(u)``, k = 0…degree, by the three-term recurrence (column-major).

    Parameters
    ----------
    u : (n,) ndarray
        Argument, in [−1, 1] for a well-conditioned basis.
    degree : int
        Highest degree.
    out : (≥ degree + 1, n) ndarray, optional
        Filled in its first degree + 1 rows.

    Returns
    -------
    (n, degree + 1) ndarray
        The columns (a transposed view of ``out`` when given).
    """
    u = np.asarray(u, float)
    cols = np.empty((degree + 1, u.size)) if out is None else out[: degree + 1]
    cols[0] = 1.0
    if degree >= 1:
        cols[1] = u
    for k in range(2, degree + 1):
        np.multiply(cols[k - 1], u, out=cols[k])
        cols[k] *= 2.0
        cols[k] -= cols[k - 2]
    return cols.T


def solve_gram(G: np.ndarray, B: np.ndarray) -> np.ndarray:
    """``C`` minimising ``‖Y − F·C‖`` from ``G = FᵀF`` and ``B = FᵀY``: the equilibrated normal
    equations (a least-squares solve of them when singular).

    Parameters
    ----------
    G : (p, p) ndarray
    B : (p,) or (p, k) ndarray

    Returns
    -------
    (p,) or (p, k) ndarray
    """
    s = np.sqrt(np.diag(G))
    s[s == 0] = 1.0
    Gs, Bs = G / np.outer(s, s), (B.T / s).T
    try:
        C = np.linalg.solve(Gs, Bs)
        if np.all(np.isfinite(C)):
            return (C.T / s).T
    except np.linalg.LinAlgError:
        pass
    return (np.linalg.lstsq(Gs, Bs, rcond=None)[0].T / s).T


def chebyshev_to_power(degree: int, centre_c: float, half_c: float) -> np.ndarray:
    """M with ``Σ_j c_j T_j((ΔT − centre)/half) = Σ_k (M·c)_k (ΔT/10)^k``.

    Parameters
    ----------
    degree : int
    centre_c, half_c : float
        The map of ΔT [°C] onto u ∈ [−1, 1].

    Returns
    -------
    (degree + 1, degree + 1) ndarray
    """
    line = np.array([-centre_c / half_c, SCALE_C / half_c])  # u as a polynomial in ΔT/10
    powers = [np.ones(1)]
    for _ in range(degree):
        powers.append(power.polymul(powers[-1], line))
    M = np.zeros((degree + 1, degree + 1))
    for j in range(degree + 1):
        for k, p in enumerate(chebyshev.cheb2poly(np.eye(degree + 1)[j])):
            M[: powers[k].size, j] += p * powers[k]
    return M


class PolyGrams:
    """The training rows of a polynomial fit, reduced to Gram matrices block by block.

    Parameters
    ----------
    delta_c : (n,) ndarray
        Training temperatures minus the reference [°C].
    y : (n, 3) ndarray
        Training readings.
    top : int
        Highest degree fitted.
    bounds : sequence of int
        Block edges (rows), from 0 to n.
    """

    def __init__(self, delta_c: np.ndarray, y: np.ndarray, top: int, bounds):
        self.delta_c, self.y, self.top, self.bounds = delta_c, y, top, list(bounds)
        lo, hi = float(delta_c.min()), float(delta_c.max())
        self.centre_c, self.half_c = 0.5 * (lo + hi), (0.5 * (hi - lo) or 1.0)
        self.level = y.mean(axis=0)
        self.grams = []
        for a, b in zip(self.bounds[:-1], self.bounds[1:]):
            A = self._table(a, b)
            self.grams.append(A @ A.T)

    def _table(self, a: int, b: int, degree: int | None = None) -> np.ndarray:
        """Rows a:b as the (degree + 4, b − a) table [T_0(u) … T_degree(u) | y − level]ᵀ."""
        degree = self.top if degree is None else degree
        A = np.empty((degree + 4, b - a))
        chebyshev_columns((self.delta_c[a:b] - self.centre_c) / self.half_c, degree, A)
        np.subtract(self.y[a:b], self.level, out=A[degree + 1:].T)
        return A

    def held_out_sse(self, degree: int) -> np.ndarray:
        """Σ over blocks of the SSE per axis of the fit on the other blocks, scored on the block.

        Parameters
        ----------
        degree : int

        Returns
        -------
        (3,) ndarray
            [unit of y, squared].
        """
        p, ys = degree + 1, slice(self.top + 1, self.top + 4)
        sse = np.zeros(3)
        for k, G in enumerate(self.grams):
            train = sum(g for j, g in enumerate(self.grams) if j != k)
            C = solve_gram(train[:p, :p], train[:p, ys])
            yy = np.diag(G[ys, ys])
            s = yy - 2 * np.einsum("ij,ij->j", C, G[:p, ys]) + np.einsum("ij,ik,kj->j", C, G[:p, :p], C)
            if np.any(s <= CANCELLED * yy):  # nearly exact: the difference above has lost its digits
                A = self._table(self.bounds[k], self.bounds[k + 1], degree)
                r = A[p:] - C.T @ A[:p]
                s = np.einsum("ij,ij->i", r, r)
            sse += s
        return sse

    def fit(self, degrees) -> list[tuple[np.ndarray, np.ndarray]]:
        """Each axis at its degree on all blocks: coefficients of (ΔT/10)^k and their standard
        errors, AR(1)-inflated by the lag-1 autocorrelation ρ of the residual (clipped to [0, 0.95]).

        Parameters
        ----------
        degrees : sequence of 3 int

        Returns
        -------
        list of (coef, stderr)
            Per axis, each (degree + 1,) [unit of y per (ΔT/10)^k].
        """
        G, dmax, out = sum(self.grams), int(max(degrees)), []
        n = self.delta_c.size
        coef = [solve_gram(G[: d + 1, : d + 1], G[: d + 1, self.top + 1 + axis]) for axis, d in enumerate(degrees)]
        sse, lag1, prev = np.zeros(3), np.zeros(3), None
        for a in range(0, n, CHUNK):  # the residuals chunk by chunk: their power and lag-1 sum, in order
            A = self._table(a, min(a + CHUNK, n), dmax)
            r = np.array([A[dmax + 1 + axis] - c @ A[: c.size] for axis, c in enumerate(coef)])
            sse += np.einsum("ij,ij->i", r, r)
            lag1 += np.einsum("ij,ij->i", r[:, 1:], r[:, :-1]) + (prev * r[:, 0] if prev is not None else 0.0)
            prev = r[:, -1].copy()
        for axis, d in enumerate(degrees):
            p, c = d + 1, coef[axis]
            rho = float(np.clip(lag1[axis] / max(sse[axis], 1e-300), 0.0, 0.95))
            sigma2 = sse[axis] / max(n - p, 1) * (1 + rho) / (1 - rho)
            M = chebyshev_to_power(d, self.centre_c, self.half_c)
            power_coef = M @ c
            power_coef[0] += self.level[axis]
            cov = M @ (sigma2 * np.linalg.pinv(G[:p, :p])) @ M.T
            out.append((power_coef, np.sqrt(np.diag(cov))))
        return out
