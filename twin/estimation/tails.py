"""Upper tails of the F and χ² distributions, for the screening's p-values, without scipy.

``scipy.special.fdtrc`` and ``chdtrc`` give the same numbers, but any scipy subpackage brings an
array-API layer that costs 0.25-0.3 s at the start of a command, and a compare needs nothing else
from scipy. Both tails are regularized incomplete functions evaluated the textbook way: a power
series where it converges fast, otherwise a continued fraction by the modified Lentz method, the
prefactor in logarithms so that tails far below the smallest float underflow to 0 rather than to
NaN. ``tests/test_tails.py`` holds them to scipy's values over the degrees of freedom and
statistics the diagnosis meets.
"""

from __future__ import annotations

import math

EPS = 2.220446049250313e-16  # machine epsilon: a series or fraction has converged when a step changes it by less
TINY = 1e-300  # Lentz's guard against a zero denominator
MAX_TERMS = 100_000  # far beyond need: the fractions converge in O(√(a + b)) terms


def _lentz_step(num: float, den: float, c: float, d: float) -> tuple[float, float]:
    """One more term num / (den + …) of a continued fraction by the modified Lentz method: the
    new (c, d), each kept away from 0 by :data:`TINY`; the fraction's value is multiplied by d·c
    (Press et al., *Numerical Recipes*, 3rd ed., §5.2)."""
    d = num * d + den
    d = 1.0 / (d if abs(d) > TINY else TINY)
    c = den + num / c
    return (c if abs(c) > TINY else TINY), d


def _beta_fraction(a: float, b: float, x: float) -> float:
    """The continued fraction of I_x(a, b) (Numerical Recipes §6.4, eq. 6.4.5), by modified Lentz;
    converges fast for x < (a + 1) / (a + b + 2)."""
    c, d = 1.0, 1.0 - (a + b) * x / (a + 1.0)
    d = 1.0 / (d if abs(d) > TINY else TINY)
    h = d
    for m in range(1, MAX_TERMS):
        for num in (m * (b - m) * x / ((a + 2 * m - 1) * (a + 2 * m)),
                    -(a + m) * (a + b + m) * x / ((a + 2 * m) * (a + 2 * m + 1))):
            c, d = _lentz_step(num, 1.0, c, d)
            h *= d * c
        if abs(d * c - 1.0) <= EPS:
            return h
    raise ArithmeticError(f"incomplete beta fraction did not converge (a={a:g}, b={b:g}, x={x:g})")  # pragma: no cover


def log_gamma_ratio(a: float, b: float) -> float:
    """log Γ(a + b) − log Γ(a): for a ≥ 64 from Stirling's series, so that two logarithms of
    size a·log a do not cancel to a number of size b·log a.

    Parameters
    ----------
    a, b : float
        Arguments (> 0) [1].

    Returns
    -------
    float
        log Γ(a + b) − log Γ(a) [1].

    References
    ----------
    Abramowitz & Stegun, *Handbook of Mathematical Functions* (1964), 6.1.41 (Stirling's series).
    """
    if a < 64.0:
        return math.lgamma(a + b) - math.lgamma(a)

    def correction(z: float) -> float:  # log Γ(z) − [(z − ½) log z − z + ½ log 2π], to z⁻⁹ (< 1e-19 here)
        w = 1.0 / (z * z)
        return (1.0 / 12.0 - w * (1.0 / 360.0 - w * (1.0 / 1260.0 - w * (1.0 / 1680.0)))) / z

    return ((a - 0.5) * math.log1p(b / a) + b * math.log(a + b) - b
            + correction(a + b) - correction(a))


def regularized_beta(a: float, b: float, x: float, one_minus_x: float | None = None) -> float:
    """The regularized incomplete beta function I_x(a, b) = B(x; a, b) / B(a, b).

    Parameters
    ----------
    a, b : float
        Shape parameters (> 0) [1].
    x : float
        Upper limit, 0 ≤ x ≤ 1 [1].
    one_minus_x : float, optional
        1 − x computed without cancellation (a caller that has it from a ratio): near x = 1 the
        difference 1 − x keeps only the digits x has beyond 1.

    Returns
    -------
    float
        I_x(a, b) in [0, 1].

    References
    ----------
    Press, Teukolsky, Vetterling & Flannery, *Numerical Recipes*, 3rd ed. (2007), §6.4;
    Thompson & Barnett, J. Comput. Phys. 64 (1986) 490 (modified Lentz method).
    """
    y = 1.0 - x if one_minus_x is None else one_minus_x
    if x <= 0.0:
        return 0.0
    if y <= 0.0:
        return 1.0
    big, small = (a, b) if a >= b else (b, a)
    log_x = math.log1p(-y) if y < 0.5 else math.log(x)  # the larger of x, 1 − x from the smaller one
    log_y = math.log1p(-x) if x < 0.5 else math.log(y)
    log_front = log_gamma_ratio(big, small) - math.lgamma(small) + a * log_x + b * log_y
    if x < (a + 1.0) / (a + b + 2.0):
        return math.exp(log_front) * _beta_fraction(a, b, x) / a
    return 1.0 - math.exp(log_front) * _beta_fraction(b, a, y) / b


def f_survival(dfn: float, dfd: float, f: float) -> float:
    """P(F > f) for F with ``dfn`` and ``dfd`` degrees of freedom: ``scipy.special.fdtrc``.

    Parameters
    ----------
    dfn, dfd : float
        Numerator and denominator degrees of freedom (> 0) [1].
    f : float
        The statistic (≥ 0; NaN otherwise, as scipy) [1].

    Returns
    -------
    float
        The upper tail probability.

    References
    ----------
    Abramowitz & Stegun, *Handbook of Mathematical Functions* (1964), 26.6.2:
    Q(F | ν1, ν2) = I_x(ν2/2, ν1/2), x = ν2 / (ν2 + ν1 F).
    """
    if not (dfn > 0 and dfd > 0 and f >= 0):
        return math.nan
    if math.isinf(f):
        return 0.0
    total = dfd + dfn * f
    return regularized_beta(dfd / 2.0, dfn / 2.0, dfd / total, dfn * f / total)


def chi2_survival(k: float, x: float) -> float:
    """P(χ² > x) for χ² with ``k`` degrees of freedom: ``scipy.special.chdtrc``.

    The regularized upper incomplete gamma Q(k/2, x/2): from the series of P when x/2 < k/2 + 1,
    else from its continued fraction (Numerical Recipes §6.2).

    Parameters
    ----------
    k : float
        Degrees of freedom (> 0) [1].
    x : float
        The statistic (≥ 0; NaN otherwise, and for k = 0 at x = 0, as scipy) [1].

    Returns
    -------
    float
        The upper tail probability.

    References
    ----------
    Press et al., *Numerical Recipes*, 3rd ed. (2007), §6.2; Abramowitz & Stegun (1964), 26.4.19.
    """
    if not (k >= 0 and x >= 0) or k == x == 0:
        return math.nan
    if k == 0:  # all the mass at 0
        return 0.0
    if x == 0.0:
        return 1.0
    if math.isinf(x):
        return 0.0
    a, z = k / 2.0, x / 2.0
    log_front = a * math.log(z) - z - math.lgamma(a)
    if z < a + 1.0:  # P by its series; Q = 1 − P is not small here
        term = total = 1.0 / a
        for n in range(1, MAX_TERMS):
            term *= z / (a + n)
            total += term
            if abs(term) <= abs(total) * EPS:
                return 1.0 - total * math.exp(log_front)
        raise ArithmeticError(f"incomplete gamma series did not converge (k={k:g}, x={x:g})")  # pragma: no cover
    b = z + 1.0 - a  # Q by its continued fraction, modified Lentz
    c, d = 1.0 / TINY, 1.0 / b
    h = d
    for n in range(1, MAX_TERMS):
        b += 2.0
        c, d = _lentz_step(-n * (n - a), b, c, d)
        h *= d * c
        if abs(d * c - 1.0) <= EPS:
            return math.exp(log_front) * h
    raise ArithmeticError(f"incomplete gamma fraction did not converge (k={k:g}, x={x:g})")  # pragma: no cover
