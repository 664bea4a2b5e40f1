"""The random-walk + AR noise model (``twin.estimation.noise.fit_walk_ar``), tested against known truth.

Local-level model y = ε + Σ η, Var η / Var ε = q: its first difference is an MA(1) whose parameter is
θ = ((q + 2) − √(q² + 4q)) / 2 (Harvey 1989, §2.3.2), the walk filter's exact whitening parameter.
"""

import numpy as np
import pytest

from twin.finding.build import compare_measurement
from twin.estimation.noise import WALK_THETAS, fit_walk_ar, walk_filter
from twin.datasets.outside import draw_outside

N = 2000
RUN = np.zeros(N, int)
T = np.linspace(0.0, 1.0, N)
TREND = np.column_stack([np.ones(N), T])  # an offset and a fitted trend, as screening's aging column


def _theta_exact(q: float) -> float:
    return ((q + 2) - np.sqrt(q * q + 4 * q)) / 2


def _local_level(seed: int, q: float, trend: float = 0.0) -> np.ndarray:
    rng = np.random.default_rng(seed)
    return rng.standard_normal(N) + np.sqrt(q) * np.cumsum(rng.standard_normal(N)) + trend * T


@pytest.mark.parametrize("q", [0.01, 0.05])
def test_restricted_likelihood_recovers_the_walk_parameter(q):
    """θ on its grid next to the exact value (0.905 for q = 0.01, 0.800 for 0.05), with the trend
    fitted: the restricted likelihood is not biased to "no walk" by the trend column."""
    grid = np.array(WALK_THETAS)
    nearest = grid[np.argsort(np.abs(grid - _theta_exact(q)))[:2]]
    thetas = [fit_walk_ar(TREND, _local_level(s, q), RUN).theta for s in range(10)]
    assert all(th in nearest for th in thetas), (thetas, nearest)


def test_no_walk_is_chosen_for_white_noise_with_a_real_trend():
    """A trend 10σ over the run, no walk: θ = 1 in every seed (the trend is in the design)."""
    assert {fit_walk_ar(TREND, _local_level(s, 0.0, trend=10.0), RUN).theta for s in range(10)} == {1.0}


def test_walk_filter_whitens_a_local_level_and_is_the_identity_at_one():
    y = _local_level(3, 0.01)
    e = walk_filter(y, RUN, _theta_exact(0.01))[1:]
    lag1 = float(np.corrcoef(e[:-1], e[1:])[0, 1])
    assert abs(lag1) < 3 / np.sqrt(N)  # white to 3σ of a sample autocorrelation
    raw = float(np.corrcoef(y[:-1], y[1:])[0, 1])
    assert raw > 0.5  # the walk made the raw series strongly correlated: the check above can fail
    assert np.array_equal(walk_filter(y, RUN, 1.0), y)


@pytest.mark.parametrize("seed", [20000, 20017])
def test_bias_random_walk_is_neither_aging_nor_a_discovered_trend(seed):
    """Null data seeds where an AR-only noise model named aging_drift (20000) or proposed
    t + t² terms (20017), before the walk was allowed into the noise model."""
    oc = draw_outside("null_coloured", seed)
    d, r = compare_measurement(oc.case.twin, oc.case.measurement, [], discover=True)
    assert not d.selected, [c.effect for c in d.selected]
    assert not r.discovery.proposed, r.discovery.equation
    assert "no missing effect" in r.finding.lower()
