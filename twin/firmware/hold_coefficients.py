"""C text of the first-order-hold coefficients, shared by the lag-aware and composed C headers
(:mod:`twin.firmware.lag_header`, :mod:`twin.firmware.composed_header`).

A first-order lag τ dy/dt = u − y driven by a piecewise-linear input (first-order hold, the
discretisation of ``sim.thermal.first_order_lag``) is, over a step of dt with h = dt/τ and
e = exp(−h), exactly

    y[n] = e·y[n−1] + b0·u[n] + b1·u[n−1],  b0 = 1 − (1 − e)/h,  b1 = (1 − e)/h − e

(integrate τ dy/dt = u − y with u linear over the step). For small h the closed form of b0
cancels, so the C code takes b0 and b1 from their Taylor series there (:func:`hold_coefficients_c`).
"""

from __future__ import annotations

import math

from twin.firmware.common import c_float

# Below this h = dt/τ the header takes b0, b1 from their Taylor series: 1 − (1 − e)/h cancels
# there, losing log2(1/b0) bits (3 of float32's 24 at h = 0.25, all of them for h < 1e-7).
SERIES_BELOW_H = 0.25
# Series terms h^1..h^K kept: the first one left out is ≤ 2h^K/(K + 2)! of b0 at h = 0.25, i.e.
# 3e-10 (float32 eps 1.2e-7) for K = 7 and 2e-20 (float64 eps 2.2e-16) for K = 13.
SERIES_TERMS = {"float": 7, "double": 13}


def c_literal(value: float, real: str) -> str:
    """A C literal of ``value`` as ``real`` ("float": the nearest float32 with ``f``; "double").

    Parameters
    ----------
    value : float
        The number [any unit].
    real : {"float", "double"}
        C type of the literal.

    Returns
    -------
    str
        The literal: ``c_float(value)`` for float, the shortest round-trip decimal for double.
    """
    if real == "float":
        return c_float(value)
    text = repr(float(value))
    return text if any(ch in text for ch in ".e") else text + ".0"


def series_text(coefficients, real: str) -> str:
    """``h * (c1 + h * (c2 + ...))``: Σ_k c_k h^k by Horner.

    Parameters
    ----------
    coefficients : sequence of float
        c_1 .. c_K, the coefficients of h^1 .. h^K [1].
    real : {"float", "double"}
        C type of the literals.

    Returns
    -------
    str
        The C expression in ``h``.
    """
    expr = c_literal(coefficients[-1], real)
    for c in reversed(coefficients[:-1]):
        expr = f"{c_literal(c, real)} + h * ({expr})"
    return f"h * ({expr})"


def hold_coefficients_c(prefix: str, real: str) -> str:
    """C of ``{prefix}_hold_coefficients(h, &b0, &b1)``: the first-order-hold coefficients over a
    step h = dt/τ, by their Taylor series where the closed form cancels (shared by every header).

    Parameters
    ----------
    prefix, real : str
        Prefix of the C names; C type of the arithmetic ("float" or "double").

    Returns
    -------
    str
        The C function.
    """
    n_terms = SERIES_TERMS[real]
    fact = [math.factorial(k + 1) for k in range(n_terms + 1)]
    b0_series = series_text([(-1) ** (k + 1) / fact[k] for k in range(1, n_terms + 1)], real)
    b1_series = series_text([(-1) ** (k + 1) * k / fact[k] for k in range(1, n_terms + 1)], real)
    (exp_fn, expm1_fn), r = ("expf", "expm1f") if real == "float" else ("exp", "expm1"), f"{prefix}_real"
    return f"""/* First-order-hold coefficients over a step of h = dt/tau >= 0 (+inf allowed):
 * b0 = 1 - (1 - e)/h, b1 = (1 - e)/h - e, e = exp(-h). Below h = {SERIES_BELOW_H:g}, 1 - (1 - e)/h
 * cancels (b0 ~ h/2, (1 - e)/h ~ 1), so the Taylor series, which keep full relative precision down
 * to h = 0 (b0 = b1 = 0 there: the lag holds):
 *   b0 = sum_k (-1)^(k+1) h^k/(k+1)! = h/2 - h^2/6 + h^3/24 - ...
 *   b1 = sum_k (-1)^(k+1) k h^k/(k+1)! = h/2 - h^2/3 + h^3/8 - ...
 * Above it, expm1 gives 1 - e without the cancellation of 1 - exp(-h), and b1 = q - e,
 * q = (1 - e)/h > e, has none either. */
static inline void {prefix}_hold_coefficients({r} h, {r} *b0, {r} *b1)
{{
    if (h < ({r}){c_literal(SERIES_BELOW_H, real)}) {{
        *b0 = {b0_series};
        *b1 = {b1_series};
    }} else {{
        const {r} q = -{expm1_fn}(-h) / h;
        *b0 = ({r})1 - q;
        *b1 = q - {exp_fn}(-h);
    }}
}}
"""
