"""Brent's bounded search (twin.estimation.search) against scipy's, which runs the same method."""

import math

import numpy as np
import pytest
from scipy.optimize import minimize_scalar

from twin.estimation.search import bounded_minimum

FUNCTIONS = {
    "parabola": (lambda x: (x - 0.3) ** 2, (-2.0, 5.0)),
    "minimum at a bound": (lambda x: x, (1.0, 4.0)),
    "quartic": (lambda x: (x - 1.5) ** 4 + 0.1 * x, (-3.0, 3.0)),
    "two wells": (lambda x: math.sin(3 * x) + 0.1 * x * x, (-4.0, 4.0)),
    "flat": (lambda x: 1.0, (0.0, 1.0)),
    "kink": (lambda x: abs(x - 2.2) + 0.01 * x, (np.log(15.0), np.log(1920.0))),
    "noisy rss": (lambda x: (x - 0.7) ** 2 + 1e-9 * math.sin(1e4 * x), (0.0, 1.0)),
}


@pytest.mark.parametrize("name", sorted(FUNCTIONS))
@pytest.mark.parametrize("xatol", [1e-5, 1e-3, 0.01])
def test_the_same_iterates_as_scipy(name, xatol):
    f, (lo, hi) = FUNCTIONS[name]
    seen_ours, seen_scipy = [], []
    ours = bounded_minimum(lambda x: seen_ours.append(float(x)) or f(x), lo, hi, xatol=xatol)
    ref = minimize_scalar(lambda x: seen_scipy.append(float(x)) or f(x), bounds=(lo, hi), method="bounded",
                          options={"xatol": xatol})
    assert seen_ours == seen_scipy  # every evaluated point, bit for bit
    assert (ours.x, ours.fun, ours.evaluations, ours.converged) == (float(ref.x), float(ref.fun), ref.nfev, ref.success)


def test_a_parabola_is_found_to_the_tolerance_and_bad_bounds_are_refused():
    r = bounded_minimum(lambda x: (x - 1.234) ** 2, 0.0, 10.0, xatol=1e-6)
    assert abs(r.x - 1.234) < 1e-5 and r.converged
    assert not bounded_minimum(lambda x: (x - 1.234) ** 2, 0.0, 10.0, max_evaluations=3).converged
    with pytest.raises(ValueError):
        bounded_minimum(abs, 1.0, 0.0)
    with pytest.raises(ValueError):
        bounded_minimum(abs, 0.0, math.inf)
