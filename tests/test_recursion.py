"""sim.recursion: the one-pole recursion without scipy.signal, against lfilter and the analytic
impulse response; and the start of the commands stays free of scipy.signal and scipy.stats."""

import subprocess
import sys
import warnings

import numpy as np
import pytest
from scipy.signal import lfilter

from conftest import ROOT
from sim.recursion import first_order_filter, one_pole


@pytest.mark.parametrize("shape", [(1,), (2,), (4000,), (3000, 3)])
@pytest.mark.parametrize("pole", [0.0, 0.3, -0.7, 0.999999, 1.0])
def test_one_pole_is_lfilter_bit_for_bit(shape, pole):
    u = np.random.default_rng(7).standard_normal(shape)
    y = one_pole(u, pole)
    assert np.array_equal(y, lfilter([1.0], [1.0, -pole], u, axis=0)) and y.flags.c_contiguous


def test_one_pole_impulse_response_is_the_geometric_series():
    u = np.zeros(60)
    u[0] = 1.0
    np.testing.assert_allclose(one_pole(u, 0.9), 0.9 ** np.arange(60), rtol=1e-13)


@pytest.mark.parametrize("b0, b1, pole, initial", [(0.3, 0.0, 0.9, 0.0), (0.3, 0.0, 0.9, 0.4),
                                                   (1.0, -1.0, 0.95, 0.0), (0.2, 0.5, -0.3, 0.7)])
def test_first_order_filter_is_lfilter(b0, b1, pole, initial):
    """Bit for bit without the lagged term; a rounding apart (10 ulp of the output) with it."""
    x = np.random.default_rng(3).standard_normal((2000, 2))
    ref, _ = lfilter([b0, b1], [1.0, -pole], x, axis=0, zi=np.full((1, 2), initial))
    y = first_order_filter(x, b0, b1, pole, initial)
    if b1 == 0.0:
        assert np.array_equal(y, ref)
    np.testing.assert_allclose(y, ref, rtol=0, atol=10 * np.spacing(np.abs(ref).max()))


def test_empty_input():
    assert one_pole(np.zeros(0), 0.5).shape == (0,) and first_order_filter(np.zeros((0, 3)), 1, 0, 0.5).shape == (0, 3)


def test_the_compare_start_imports_neither_scipy_signal_nor_scipy_stats():
    """scipy.signal brings scipy.stats, which parses every distribution's docstring at import;
    scipy.optimize costs 0.3 s and numba 0.9 s with its cached kernel: nothing `twin compare` or
    `twin calibrate` loads at start needs them, and the play operator of a compare's means (below
    COMPILED_MIN_SIZE) does not load numba either."""
    code = ("import sys, numpy as np, twin.cli, twin.workflows.compare, twin.workflows.calibrate; "
            "from sim.play import play_operator; play_operator(np.arange(300_000.0), 2.0); "
            "print(sorted(m for m in ('scipy.signal', 'scipy.stats', 'scipy.optimize', 'numba') if m in sys.modules))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True, cwd=ROOT)
    assert out.stdout.strip() == "[]"


@pytest.mark.parametrize("n", [1, 30, 31, 32, 1000])
def test_px4_median_filter_is_medfilt(n):
    """PX4's script filters with scipy.signal.medfilt(x, 31); ours takes scipy.ndimage's median over
    the same zero-padded windows."""
    from scipy.signal import medfilt

    from twin.firmware.px4 import median_filter

    x = np.random.default_rng(n).standard_normal(n) * 3 + 9.8
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # medfilt warns when the window is longer than the series
        assert np.array_equal(median_filter(x), medfilt(x, 31))


def test_the_paper_simulation_is_lfilters_within_rounding(monkeypatch):
    """The thermal modes once ran through lfilter; through sim.recursion the temperatures move by
    rounding only (≤ 1e-12 °C) and the logged, quantised output not at all."""
    import yaml

    import sim.thermal
    from twin.model.scenario import parse_scenario
    from twin.model.simulate import simulate

    path = ROOT / "scenarios" / "paper_iis328dq.yaml"
    data = yaml.safe_load(path.read_text())
    data["test_plan"]["logger_rate_hz"] = 1.0
    text = yaml.safe_dump(data)
    ours = simulate(parse_scenario(text, str(path))).arrays
    monkeypatch.setattr(sim.thermal, "first_order_filter",
                        lambda x, b0, b1, pole, initial=0.0: lfilter([b0, b1], [1.0, -pole], x, zi=[initial])[0])
    before = simulate(parse_scenario(text, str(path))).arrays
    assert np.array_equal(ours["output/output_g"], before["output/output_g"])
    for key in ("temperature/air_c", "temperature/board_c", "temperature/die_c", "temperature/thermometer_c"):
        np.testing.assert_allclose(ours[key], before[key], rtol=0, atol=1e-12)
