"""Day- and week-long logs: the compiled play operator, decimated diagnosis and its error bound.

Fast versions only (small arrays); the speed-ups and the 8.6 M / 60 M-row figures are in
``benchmarks/bench_long.py``.
"""

from pathlib import Path

import numpy as np
import pytest
from scipy.signal import lfilter

import sim.play as play
from twin.diagnosis.sample_rate import block_sums, white_sigma_in_place
from twin.estimation.decimate import (
    MAX_MODEL_ROWS, block_aligned_factor, decimate, decimation_factor, model_factor, time_since_power_on_s,
)
from twin.estimation.noise import white_noise_sigma_from_differences, white_sigma_of_differences
from twin.estimation.problem import DiagnosisConfig, Problem
from twin.diagnosis.screen import screening_progress
from twin.effects import get_effect
from twin.measurement import Measurement


def _walk(n, seed=0):
    return np.cumsum(np.random.default_rng(seed).normal(size=n)) * 0.05


def _play_loop(x, r, p):
    out = np.empty_like(x)
    for k, v in enumerate(x):  # the definition, sample by sample
        p = min(max(p, v - r), v + r)
        out[k] = p
    return out


def test_play_operator_paths_are_identical_to_the_recursion():
    x = _walk(3000)
    ref = _play_loop(x, 0.7, x[0])
    assert np.array_equal(play.play_operator_scan(x, 0.7), ref)
    assert np.array_equal(play.play_operator(x, 0.7), ref)  # below COMPILED_MIN_SIZE: the blocked scan
    big = _walk(play.COMPILED_MIN_SIZE + 1234, seed=1)  # large enough for the compiled kernel
    compiled, blocked = play.play_operator(big, 1.5, initial=0.3), play.play_operator_blocked(big, 1.5, initial=0.3)
    # min/max only, no rounding: any correct order of evaluation gives the same bits
    assert np.max(np.abs(compiled - blocked)) <= 1e-12 and np.array_equal(compiled, blocked)


@pytest.mark.parametrize("n", [1, 2, 3, 8, 9, 10, 15, 16, 17, 99, 1000, 4097])
def test_blocked_play_operator_is_the_recursion_at_every_block_layout(n):
    # n = b·m exactly, one short, one over: a full and a partly padded last block
    x = _walk(n, seed=n)
    for r, p0 in ((0.7, None), (0.0, None), (3.0, -5.0), (0.05, 40.0)):
        ref = _play_loop(x, r, x[0] if p0 is None else p0)
        got = play.play_operator_blocked(x, r, initial=p0)
        assert got.shape == x.shape and np.array_equal(got, ref), (n, r, p0)
    assert play.play_operator_blocked(np.array([]), 1.0).size == 0


def test_play_operator_falls_back_to_the_scan_without_numba(monkeypatch):
    monkeypatch.setenv("TDE_TWIN_NO_NUMBA", "1")
    monkeypatch.setattr(play, "_KERNEL", [])
    x = _walk(play.COMPILED_MIN_SIZE + 10, seed=2)
    assert play._play_kernel() is None
    assert np.array_equal(play.play_operator(x, 0.5), play.play_operator_scan(x, 0.5))
    with pytest.raises(ValueError):
        play.play_operator(x, -1.0)


def test_long_or_fast_logs_are_diagnosed_on_at_most_max_model_rows_means(monkeypatch):
    assert [decimation_factor(r) for r in (1.0, 10.0, 11.0, 20.0)] == [1, 1, 1, 1]
    assert decimation_factor(100.0) == decimation_factor(99.99999999781721) == 10 and decimation_factor(50.0) == 5 and decimation_factor(1000.0) == 100
    # means tile the 1000-sample screening block exactly (a day of 100 Hz capped at 100 k means: 100-sample means)
    assert [block_aligned_factor(k, 1000) for k in (10, 31, 400, 2000)] == [10, 40, 500, 1000]
    assert model_factor(8_640_000, 100.0, 1000) == 100 and model_factor(360_000, 100.0, 1000) == 10
    # a slow log is decimated only when it is long: the 16-h paper export at 10 Hz on 1-s means
    assert model_factor(MAX_MODEL_ROWS, 10.0, 100) == 1 and model_factor(MAX_MODEL_ROWS + 1, 10.0, 100) == 2
    assert model_factor(583_501, 10.0, 100) == 10 and model_factor(583_501, 1.0, 10) == 10
    monkeypatch.setenv("TDE_TWIN_FULL_RATE", "1")
    assert decimation_factor(100.0) == 1 and model_factor(8_640_000, 100.0, 1000) == model_factor(583_501, 10.0, 100) == 1


def _chamber_log(hours, rate_hz, seed=3, runs=1):
    """The bench_long.py physics, small: die lags the board by 190 s, 0.8 mg/°C, 1.33 mg noise."""
    rng = np.random.default_rng(seed)
    dt = 1.0 / rate_hz
    t = np.arange(int(hours * 3600 * rate_hz)) * dt
    cyc = np.array([[0, -20], [1200, -20], [3300, 50], [4500, 50], [8700, -20], [9900, -20]], float)
    air = np.interp(np.mod(t, cyc[-1, 0]), cyc[:, 0], cyc[:, 1])
    lag = lambda u, tau: lfilter([1 - np.exp(-dt / tau)], [1, -np.exp(-dt / tau)], u,  # noqa: E731
                                 zi=[np.exp(-dt / tau) * u[0]])[0]
    board = lag(air, 300.0)
    die = lag(board, 190.0) - 25.0
    out = 1.0 + 100e-6 * die + 0.8e-3 * die + rng.normal(0, 1.33e-3, t.size)
    run = (np.arange(t.size) * runs // t.size).astype(np.int16)
    return Measurement(t, lag(board, 2.0) + rng.normal(0, 0.01, t.size), out, np.ones(t.size), run,
                       np.r_[True, np.diff(run) != 0])


@pytest.mark.parametrize("rate_hz,k", [(100.0, 10), (100.0, 40), (10.0, 10)])
@pytest.mark.parametrize("effect,values", [("thermal_hysteresis", {"half_width_c": 0.5}),
                                           ("thermal_lag", {"tau_s": 15.0}),
                                           ("thermal_gradient", {"tau_s": 30.0}),
                                           ("stress_relaxation", {"tau_s": 1800.0}),
                                           ("warmup", {"tau_s": 10.0})])
def test_history_columns_on_means_match_full_rate_on_screening_blocks(effect, values, rate_hz, k):
    """Each stateful column evaluated on k-sample means (a 100 Hz log on 0.1-s and 0.4-s means, a
    long 10 Hz log on 1-s means) instead of every sample, compared on the 10-s block means screening
    tests, at the shortest τ / narrowest play width of the grids."""
    m = _chamber_log(1.0, rate_hz, runs=2)
    m.power_on[len(m) // 4] = True  # a power cycle inside run 0
    dec, blocks = decimate(m, k)
    cfg = DiagnosisConfig()
    problems = [Problem(m, cfg), Problem(dec, cfg, time_since_power_on_s=time_since_power_on_s(m, blocks, dec))]
    eff = get_effect(effect)({}, **values)
    cols = []
    for p in problems:
        col = eff.die_temperature(p.inputs) - p.inputs.die_c if eff.slot == "temperature" else \
            next(iter(eff.basis(p.inputs).values())).output_g(p.applied)
        cols.append(p.avg(np.broadcast_to(col, (p.n,))))
    full, means = cols
    if effect == "thermal_hysteresis":
        # the play operator is 1-Lipschitz in the sup norm (Brokate & Sprekels 1996, §2.3), and
        # holding each mean over its block does not change its output: |Δ| ≤ 1e-3·sup|T − T̄_block|
        held = np.repeat(problems[1].inputs.die_c, blocks.lengths)
        assert np.max(np.abs(full - means)) <= 1e-3 * np.max(np.abs(problems[0].inputs.die_c - held)) * (1 + 1e-9)
    else:
        # inside runs the error is the input's curvature within a mean, O((0.1 s / τ)²) ≈ 1e-4 at
        # τ = 10 s on 0.1-s means; a run cut on a ramp adds, in its edge blocks, the change over
        # half a mean (0.4 % of the column there on 0.1-s means): 0.1 % in RMS holds both on 0.1-s
        # means (measured ≤ 0.05 %); the edge term grows with the mean's length: 0.2 % on 0.4-s
        # means (measured ≤ 0.1 %), 0.5 % on 1-s means (measured ≤ 0.2 %)
        bound = 1e-3 * max(1.0, k / rate_hz / 0.2)
        assert np.sqrt(np.mean((full - means) ** 2)) <= bound * np.sqrt(np.mean(full ** 2))


def test_block_sums_give_the_full_rate_residual_figures():
    m = _chamber_log(0.25, 40.0, runs=2)
    dec, blocks = decimate(m, 4)
    model = np.random.default_rng(5).normal(0, 1e-3, dec.time_s.size) + dec.output_g - 1.0
    sums = block_sums(m, blocks, dec.applied_g, model)
    r = m.output_g - m.applied_g - np.repeat(model, blocks.lengths)
    # S2 − 2mS1 + Lm²: cancellation of terms ~1e-3 of each other loses ~3 of 16 digits
    assert sums.rms(model) == pytest.approx(np.sqrt(np.mean(r * r)), rel=1e-9)
    # differences held in float32 (7 digits): the floor is quoted to 3
    assert sums.noise_floor_g == pytest.approx(white_noise_sigma_from_differences(r, m.run_index), rel=1e-5)


@pytest.mark.parametrize("rate_hz,hours,max_rows,k", [(30.0, 2.75, None, 3), (10.0, 3.0, 12_000, 10)])
def test_fast_or_long_log_diagnosed_on_means_names_the_same_lag_as_full_rate(monkeypatch, rate_hz, hours, max_rows, k):
    """A 30 Hz, 2.75-h lag log diagnosed on 10 Hz means, and a 10 Hz log on 1-s means as a log
    longer than the row cap is (the cap lowered so the test stays short), against full rate: the
    same effect, τ within 3 % (its profile is flat to ~10 % here) and the per-sample figures within
    0.5 %."""
    import twin.estimation.decimate as decimate_module
    from twin.finding.build import compare_measurement
    from twin.model.scenario import load_scenario

    if max_rows is not None:
        monkeypatch.setattr(decimate_module, "MAX_MODEL_ROWS", max_rows)
    loaded = load_scenario(Path(__file__).resolve().parents[1] / "scenarios/hidden_thermal_lag.yaml")
    m = _chamber_log(hours, rate_hz)
    ticks = []
    with screening_progress(ticks.append):  # the hook a progress bar hangs on
        fast = compare_measurement(loaded, m, [])[1].to_json()
    assert len(ticks) >= sum(len(get_effect(c["effect"]).grid()) for c in fast["candidates"])
    monkeypatch.setenv("TDE_TWIN_FULL_RATE", "1")
    full = compare_measurement(loaded, m, [])[1].to_json()
    assert fast["measurement"]["diagnosed_on_means_of"] == k and "diagnosed_on_means_of" not in full["measurement"]
    assert fast["selected"][:1] == full["selected"][:1] == ["thermal_lag"]
    tau = [next(c for c in r["candidates"] if c["effect"] == "thermal_lag")["parameters_refined"]["tau_s"]
           for r in (fast, full)]
    assert tau[0] == pytest.approx(tau[1], rel=0.03)
    # The die lags the thermometer by 190 − 2 = 188 s on the ramps (the twin calibrated with the
    # lag finds 188.05 s, 95 % profile interval ±0.05 s). The screening's τ, refined on its ΔBIC
    # atop a twin without the lag (whose tempco takes part of the lag's column), reads high:
    # measured over seeds 1–9, 199.9–203.8 s at full rate, mean +7.4 %, SD 0.77 % (this seed
    # 202.9 s). The mean plus 4 SD: 10.5 %, so within 11 % of 188 s.
    assert abs(tau[1] / 188.0 - 1) < 0.11, tau
    for key in ("rms_residual_g", "noise_floor_g", "rms_after_selected_g"):  # per sample on both paths
        assert fast[key] == pytest.approx(full[key], rel=5e-3), key
    assert fast["samples"] == full["samples"] == len(m)


@pytest.mark.parametrize("case", ["gaussian", "spikes", "mostly zero", "quantised", "all zero", "float64", "empty"])
def test_the_in_place_noise_floor_is_the_same_number(case):
    d = np.random.default_rng(3).normal(0, 1e-3, 20_001).astype(np.float32)
    if case == "spikes":
        d[::97] *= 50
    elif case == "mostly zero":  # the 75th percentile of |d| is 0: the fallback scale needs the sign
        d[np.random.default_rng(4).random(d.size) < 0.8] = 0
    elif case == "quantised":
        d = (np.round(d * 1e3) / 1e3).astype(np.float32)
    elif case == "all zero":
        d = np.zeros(10, np.float32)
    elif case == "float64":
        d = d.astype(float)
    elif case == "empty":
        d = d[:0]
    assert white_sigma_in_place(d.copy()) == white_sigma_of_differences(d)


def test_the_averaged_design_is_the_mean_of_the_full_design_whatever_the_cache_holds():
    """Fits assemble their block-mean design from averaged columns kept on the problem: it must be
    the mean of design_matrix's columns for every model, a changed temperature slot (which moves the
    die temperature every other effect reads) and a changed nonlinear parameter included."""
    from twin.effects import Composition
    from twin.estimation.problem import averaged_design, design_matrix

    p = Problem(_chamber_log(0.5, 5.0), DiagnosisConfig())

    def model(lag_tau, width):
        return Composition([get_effect("thermal_lag")(tau_s=lag_tau), get_effect("static_bias_tc")(),
                            get_effect("thermal_hysteresis")(half_width_c=width)])

    for lag_tau, width in [(60.0, 1.0), (120.0, 1.0), (60.0, 1.0), (60.0, 4.0), (240.0, 4.0), (60.0, 1.0)]:
        comp = model(lag_tau, width)
        A, b, names = averaged_design(p, comp)
        X, names_full, fixed, _ = design_matrix(p, comp)
        assert names == names_full
        np.testing.assert_allclose(A, p.avg(np.column_stack([p.nuisance, X])), rtol=1e-12, atol=1e-15)
        np.testing.assert_allclose(b, p.avg(p.y - fixed), rtol=1e-12, atol=1e-15)
    pinned = frozenset({names[-1]})  # a pinned amplitude moves from A to b
    A, b, _ = averaged_design(p, comp, pinned)
    X, _, fixed, _ = design_matrix(p, comp, pinned)
    np.testing.assert_allclose(b, p.avg(p.y - fixed), rtol=1e-12, atol=1e-15)
    assert A.shape[1] == p.nuisance.shape[1] + X.shape[1]
