"""twin.estimation.tails: the F and χ² upper tails the screening uses, against scipy.special;
and twin.arrays.moving_mean against scipy.ndimage (what a compare uses instead of scipy).

The grid covers what a diagnosis meets (1-30 numerator degrees of freedom; denominators from a
handful of 10-s blocks to a week of them and beyond) and statistics from 1e-8 to 1e5, so tails
from 1 down to the smallest normal float.
"""

import math

import numpy as np
import pytest
from scipy.special import chdtrc, fdtrc

from twin.estimation.tails import chi2_survival, f_survival, regularized_beta

DFN = [1, 2, 3, 4, 5, 7, 10, 30]
DFD = [1, 2, 2.5, 5, 10, 37, 100, 580, 5835, 60_480, 500_000]
STATS = np.logspace(-8, 5, 120)


def _relative(ours, ref):
    return abs(ours - ref) / ref


@pytest.mark.parametrize("dfd", DFD)
def test_f_tail_is_scipys(dfd):
    """Within 1e-10 relative wherever scipy's tail is above 1e-250 (measured ≤ 3e-11, at the
    largest denominator, where scipy's own value is off from a 40-digit reference by 1.3e-11);
    below that scipy loses digits itself (0.8 % at 5e-298 against the 40-digit value, ours 6e-14)."""
    worst = 0.0
    for dfn in DFN:
        for f in STATS:
            ref = float(fdtrc(dfn, dfd, f))
            ours = f_survival(dfn, dfd, f)
            assert 0.0 <= ours <= 1.0
            if ref > 1e-250:
                worst = max(worst, _relative(ours, ref))
            else:
                assert ours < 1e-240
    assert worst <= 1e-10, worst


@pytest.mark.parametrize("k", [1, 2, 3, 4, 5, 9, 10, 29, 40])
def test_chi2_tail_is_scipys(k):
    """Within 1e-12 relative (measured ≤ 3e-14) down to scipy's smallest normal values."""
    for x in np.r_[np.logspace(-8, 3.5, 150)]:
        ref, ours = float(chdtrc(k, x)), chi2_survival(k, x)
        if ref > 1e-300:
            assert _relative(ours, ref) <= 1e-12, (k, x, ours, ref)
        else:
            assert ours < 1e-290


def test_edges_are_scipys():
    cases_f = [(1, 10, 0.0), (1, 10, math.inf), (1, 10, -1.0), (0, 10, 1.0), (1, 0, 1.0), (1, 10, math.nan)]
    for dfn, dfd, f in cases_f:
        ref, ours = float(fdtrc(dfn, dfd, f)), f_survival(dfn, dfd, f)
        assert (math.isnan(ref) and math.isnan(ours)) or ref == ours, (dfn, dfd, f, ours, ref)
    cases_chi2 = [(2, 0.0), (2, math.inf), (2, -1.0), (0, 0.0), (0, 2.0), (-1, 1.0), (1.5, 0.0), (2, math.nan)]
    for k, x in cases_chi2:
        ref, ours = float(chdtrc(k, x)), chi2_survival(k, x)
        assert (math.isnan(ref) and math.isnan(ours)) or ref == ours, (k, x, ours, ref)


def test_incomplete_beta_identities():
    """I_x(a, b) + I_{1−x}(b, a) = 1; I_x(1, 1) = x; I_x(a, 1) = x^a; I_x(1, b) = 1 − (1 − x)^b."""
    for a, b, x in [(0.5, 0.5, 0.3), (2.5, 7.0, 0.6), (300.0, 1.5, 0.995), (4.0, 4.0, 0.5)]:
        assert regularized_beta(a, b, x) + regularized_beta(b, a, 1 - x) == pytest.approx(1.0, abs=1e-14)
    for x in (0.0, 0.1, 0.5, 0.9, 1.0):
        assert regularized_beta(1.0, 1.0, x) == pytest.approx(x, abs=1e-15)
        assert regularized_beta(3.0, 1.0, x) == pytest.approx(x ** 3, abs=1e-15)
        assert regularized_beta(1.0, 2.5, x) == pytest.approx(1 - (1 - x) ** 2.5, abs=1e-15)


def testlog_gamma_ratio_from_stirlings_series_is_the_lgamma_difference():
    """At 64 ≤ a ≤ 1000 the plain difference of math.lgamma is still good to ~1e-13 (values of a
    few thousand at most), so it checks the series' terms: a wrong coefficient of a⁻³ moves the
    result by ~5e-11 at a = 64."""
    from twin.estimation.tails import log_gamma_ratio

    for a in (64.0, 65.5, 100.0, 333.3, 1000.0):
        for b in (0.5, 1.0, 1.5, 2.5, 15.0):
            assert abs(log_gamma_ratio(a, b) - (math.lgamma(a + b) - math.lgamma(a))) <= 2e-12, (a, b)


@pytest.mark.parametrize("summed", [True, False])
@pytest.mark.parametrize("size", [1, 2, 3, 4, 10, 11, 180, 999])
@pytest.mark.parametrize("n", [1, 2, 7, 500])
def test_moving_mean_is_uniform_filter1d_nearest(size, n, summed, monkeypatch):
    """twin.arrays.moving_mean replaces scipy.ndimage.uniform_filter1d(mode="nearest") at the start
    of a compare: the same windows (size // 2 before each sample, ends repeated), each within
    `size` ulp of its exact mean (math.fsum) when summed on its own, within (size + n) ulp from a
    running sum (SUMMED_TERMS lowered to take that path), as scipy's own drifts; against scipy
    (size + n) ulp, still far below what a window shifted by one sample would change (|Δx| / size
    ≥ 1e-4 here). A constant stretch keeps its value exactly when summed window by window."""
    from scipy.ndimage import uniform_filter1d

    import twin.arrays
    from twin.arrays import moving_mean

    if not summed:
        monkeypatch.setattr(twin.arrays, "SUMMED_TERMS", 0)
    x = np.cumsum(np.random.default_rng(size * 1000 + n).normal(size=n)) + 25.0
    ours = moving_mean(x, size)
    left = size // 2
    padded = [x[0]] * left + list(x) + [x[-1]] * (size - 1 - left)
    exact = np.array([math.fsum(padded[i:i + size]) / size for i in range(n)])
    ulp = np.spacing(np.abs(x).max())
    bound = size if summed else size + n
    assert ours.shape == x.shape and np.all(np.abs(ours - exact) <= bound * ulp)
    if summed:
        dwell = np.r_[np.linspace(-20.0, 50.0, n), np.full(size + 5, 50.0)]
        assert np.all(moving_mean(dwell, size)[-(size // 2 + 1):] == 50.0)
    assert np.all(np.abs(ours - uniform_filter1d(x, size, mode="nearest")) <= (size + n) * ulp)
