"""One-dimensional bounded minimisation (Brent's method) without importing scipy.optimize.

Every nonlinear parameter of the twin (a time constant, a play width, a rate) is searched in
log-space between two grid points by Brent's method: golden-section steps, parabolic steps where
they are accepted. ``scipy.optimize.minimize_scalar(method="bounded")`` runs the same method, and
this module follows its arithmetic step for step, so the iterates are the same numbers
(tests/test_search.py checks that against scipy). It exists because importing scipy.optimize costs
about 0.3 s at the start of every ``twin compare`` and ``twin calibrate``, for three to eleven
searches of a few milliseconds each.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Callable

import numpy as np

_SQRT_EPS = math.sqrt(2.2e-16)
_GOLDEN = 0.5 * (3.0 - math.sqrt(5.0))  # the golden-section fraction (3 − √5)/2


@dataclass(frozen=True)
class ScalarMinimum:
    """The result of :func:`bounded_minimum`.

    Attributes
    ----------
    x : float
        The abscissa of the smallest value found [unit of the bounds].
    fun : float
        The function there.
    evaluations : int
        Function evaluations.
    converged : bool
        The interval shrank below the tolerance within ``max_evaluations`` (and no NaN was met).
    """

    x: float
    fun: float
    evaluations: int
    converged: bool


def bounded_minimum(fun: Callable[[float], float], lo: float, hi: float, xatol: float = 1e-5,
                    max_evaluations: int = 500) -> ScalarMinimum:
    """Minimum of ``fun`` on [lo, hi] by Brent's method (golden section with parabolic steps).

    Parameters
    ----------
    fun : callable
        ``fun(x)`` → float.
    lo, hi : float
        Finite bounds, ``lo ≤ hi``.
    xatol : float
        Absolute tolerance on x [unit of x].
    max_evaluations : int
        Most evaluations of ``fun``.

    Returns
    -------
    ScalarMinimum
        x, fun(x), the evaluation count and whether it converged.

    Raises
    ------
    ValueError
        Bounds not finite, or ``lo > hi``.

    References
    ----------
    R. P. Brent (1973), *Algorithms for Minimization without Derivatives*, ch. 5; G. E. Forsythe,
    M. A. Malcolm, C. B. Moler (1977), *Computer Methods for Mathematical Computations*, FMIN —
    as ``scipy.optimize.minimize_scalar(method="bounded")`` implements it.
    """
    if not (math.isfinite(lo) and math.isfinite(hi)):
        raise ValueError(f"bounds must be finite, got ({lo}, {hi})")
    if lo > hi:
        raise ValueError(f"lower bound {lo} exceeds upper bound {hi}")
    a, b = lo, hi
    # x: the best point so far; w: the second best; v: the previous w (Brent's names)
    v = w = x = a + _GOLDEN * (b - a)
    fx = fun(x)
    fv = fw = fx
    evaluations, fu = 1, np.inf
    step = previous = 0.0  # the last step, and the one before it
    middle = 0.5 * (a + b)
    tol1 = _SQRT_EPS * np.abs(x) + xatol / 3.0
    tol2 = 2.0 * tol1
    converged = True
    while np.abs(x - middle) > (tol2 - 0.5 * (b - a)):
        golden = True
        if np.abs(previous) > tol1:  # try a parabola through x, w and v
            golden = False
            r = (x - w) * (fx - fv)
            q = (x - v) * (fx - fw)
            p = (x - v) * q - (x - w) * r
            q = 2.0 * (q - r)
            if q > 0.0:
                p = -p
            q = np.abs(q)
            r, previous = previous, step
            if np.abs(p) < np.abs(0.5 * q * r) and p > q * (a - x) and p < q * (b - x):
                step = (p + 0.0) / q
                u = x + step
                if (u - a) < tol2 or (b - u) < tol2:  # not too near a bound
                    step = tol1 * (np.sign(middle - x) + ((middle - x) == 0))
            else:
                golden = True
        if golden:
            previous = (a - x) if x >= middle else (b - x)
            step = _GOLDEN * previous
        u = x + (np.sign(step) + (step == 0)) * np.maximum(np.abs(step), tol1)  # at least tol1 away
        fu = fun(u)
        evaluations += 1
        if fu <= fx:
            if u >= x:
                a = x
            else:
                b = x
            v, fv = w, fw
            w, fw = x, fx
            x, fx = u, fu
        else:
            if u < x:
                a = u
            else:
                b = u
            if fu <= fw or w == x:
                v, fv = w, fw
                w, fw = u, fu
            elif fu <= fv or v == x or v == w:
                v, fv = u, fu
        middle = 0.5 * (a + b)
        tol1 = _SQRT_EPS * np.abs(x) + xatol / 3.0
        tol2 = 2.0 * tol1
        if evaluations >= max_evaluations:
            converged = False
            break
    if np.isnan(x) or np.isnan(fx) or np.isnan(fu):
        converged = False
    return ScalarMinimum(float(x), float(fx), evaluations, converged)
