"""sim.recursion: the one-pole recursion in NumPy alone, against lfilter and the analytic impulse
response; and the start of the commands stays free of scipy.signal and scipy.stats (a compare's of
scipy altogether)."""

import subprocess
import sys
import warnings

import numpy as np
import pytest
from scipy.signal import lfilter

from conftest import ROOT
from sim.recursion import first_order_filter, one_pole


def _rounding_bound(u, pole):
    """Rounding of the blocked evaluation: an output is the end of a chain of at most
    rows + blocks + 2 ≤ 4.25√n + 3 additions and multiplications (√(n/16) row steps, 4√n block
    steps, the power and the final addition), each off by half an ulp of a partial sum no larger
    than the recursion of |u| with |pole| (Higham, *Accuracy and Stability of Numerical
    Algorithms*, 2nd ed., §3.1: |Δ| ≤ γ_k Σ|terms|): (5√n + 4) ulp of that envelope."""
    envelope = lfilter([1.0], [1.0, -abs(pole)], np.abs(u), axis=0)
    return (5 * np.sqrt(u.shape[0]) + 4) * np.finfo(float).eps * envelope


@pytest.mark.parametrize("shape", [(1,), (2,), (3,), (4,), (5,), (16,), (17,), (63,), (64,), (65,), (4000,), (3000, 3),
                                   (58_351,)])
@pytest.mark.parametrize("pole", [0.0, 0.3, -0.7, 0.999999, 1.0])
def test_one_pole_is_lfilter_within_rounding(shape, pole):
    u = np.random.default_rng(7).standard_normal(shape) + 3.0
    y = one_pole(u, pole)
    ref = lfilter([1.0], [1.0, -pole], u, axis=0)
    assert y.shape == u.shape and y.flags.c_contiguous
    assert np.all(np.abs(y - ref) <= _rounding_bound(u, pole))
    rows = int(np.sqrt((shape[0] - 1) / 16.0)) + 1  # the first block is the sequential arithmetic itself
    assert np.array_equal(y[:rows], ref[:rows])


def test_one_pole_blocks_chain_exactly_on_integers():
    """Integer inputs with pole 1 (a running sum) and pole −1 are exact in every evaluation order:
    any slip in the chaining of the blocks (an entering state off by one block, a power off by
    one) shows as a wrong integer."""
    u = np.random.default_rng(1).integers(-50, 50, size=(10_007, 2)).astype(float)
    assert np.array_equal(one_pole(u, 1.0), np.cumsum(u, axis=0))
    assert np.array_equal(one_pole(u, -1.0), lfilter([1.0], [1.0, 1.0], u, axis=0))


def test_one_pole_impulse_response_is_the_geometric_series():
    u = np.zeros(60)
    u[0] = 1.0
    np.testing.assert_allclose(one_pole(u, 0.9), 0.9 ** np.arange(60), rtol=1e-13)


@pytest.mark.parametrize("b0, b1, pole, initial", [(0.3, 0.0, 0.9, 0.0), (0.3, 0.0, 0.9, 0.4),
                                                   (1.0, -1.0, 0.95, 0.0), (0.2, 0.5, -0.3, 0.7)])
def test_first_order_filter_is_lfilter(b0, b1, pole, initial):
    """A rounding apart: the drive b0·x[n] + b1·x[n−1] (+ initial) is formed first, then the
    blocked recursion (its bound, on the drive, plus 10 ulp of the output for the drive's sum)."""
    x = np.random.default_rng(3).standard_normal((2000, 2))
    ref, _ = lfilter([b0, b1], [1.0, -pole], x, axis=0, zi=np.full((1, 2), initial))
    y = first_order_filter(x, b0, b1, pole, initial)
    drive = np.abs(b0 * x) + np.abs(np.r_[np.zeros((1, 2)), b1 * x[:-1]]) + abs(initial)
    assert np.all(np.abs(y - ref) <= _rounding_bound(drive, pole) + 10 * np.spacing(np.abs(ref).max()))


def test_empty_input():
    assert one_pole(np.zeros(0), 0.5).shape == (0,) and first_order_filter(np.zeros((0, 3)), 1, 0, 0.5).shape == (0, 3)


def test_the_compare_start_imports_neither_scipy_signal_nor_scipy_stats():
    """scipy.signal brings scipy.stats, which parses every distribution's docstring at import;
    scipy.optimize costs 0.3 s and numba 0.9 s with its cached kernel: nothing `twin compare` or
    `twin calibrate` loads at start needs them, and the play operator of a compare's means (below
    COMPILED_MIN_SIZE) does not load numba either. A compare imports no scipy module at all,
    neither at start nor while it diagnoses (the array-API layer every scipy subpackage shares
    costs 0.25-0.3 s)."""
    code = ("import sys, numpy as np, twin.cli, twin.workflows.compare, twin.workflows.calibrate; "
            "from sim.play import play_operator; play_operator(np.arange(300_000.0), 2.0); "
            "print(sorted(m for m in ('scipy.signal', 'scipy.stats', 'scipy.optimize', 'numba') if m in sys.modules))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True, cwd=ROOT)
    assert out.stdout.strip() == "[]"


def test_a_compare_runs_without_importing_scipy(tmp_path):
    """The paper scenario's twin against a simulated hidden-lag log, through the CLI in one
    process: no ``scipy`` module is loaded from start to JSON (fails if the one-pole recursion,
    the F / χ² tails or the moving mean go back to scipy)."""
    from twin.model.scenario import load_scenario
    from twin.model.simulate import simulate
    from twin.measurement import from_dataset, write_canonical_csv

    loaded = load_scenario(ROOT / "scenarios" / "hidden_thermal_lag.yaml")
    m = from_dataset(simulate(loaded, seed=1))
    keep = slice(0, len(m) // 4)
    csv = tmp_path / "log.csv"
    write_canonical_csv(csv, m.time_s[keep], m.temperature_c[keep], m.output_g[keep], m.applied_g[keep],
                        m.run_index[keep], m.power_on[keep])
    code = ("import sys, json; from twin.cli import main\n"
            "try:\n    main(['compare', sys.argv[1], sys.argv[2], '--json', sys.argv[3]])\n"
            "except SystemExit as e:\n    assert e.code == 0, e.code\n"
            "print(json.dumps(sorted(m for m in sys.modules if m == 'scipy' or m.startswith('scipy.'))))")
    out = subprocess.run([sys.executable, "-c", code, str(ROOT / "scenarios" / "hidden_thermal_lag.yaml"), str(csv),
                          str(tmp_path / "c.json")], capture_output=True, text=True, check=True, cwd=ROOT)
    assert out.stdout.strip().splitlines()[-1] == "[]"
    assert (tmp_path / "c.json").stat().st_size > 1000


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
    rounding only and the logged, quantised output not at all. The bound is that of
    :func:`_rounding_bound` on temperatures of at most 50 °C: (5√n + 4) ulp of 50 °C (8.6e-12 °C
    at the 58,351 samples here; measured 1.5e-12 °C)."""
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
        bound = (5 * np.sqrt(ours[key].size) + 4) * np.spacing(np.abs(before[key]).max())
        np.testing.assert_allclose(ours[key], before[key], rtol=0, atol=bound)
