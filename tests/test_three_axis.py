"""A three-axis IIS328DQ in a six-position test at three temperatures (scenarios/six_position_3axis.yaml),
the die lagging the board thermometer: the calibration code recovers the truth the simulator put in.

What is fitted against what (run ``pytest -s`` for the numbers):

- Orientations: ``six_position`` on the whole log (the thermometer as the temperature) must find
  the six positions. Its offset/scale-factor fit over *every* static segment is biased by the
  die lag: segments on the ramps sit up to 3 °C (τ·dT/dt) off the die, so their residual is
  0.5-1.2 mg, not the 0.09 mg noise floor. The tempcos are therefore fitted on the settled
  segments only: those where τ̂·|dT/dt| < 0.05 °C, τ̂ being the lag-aware fit below and dT/dt
  the thermometer's slope over the segment (both from the log, no truth).
- The die lag: ``LagAwareCompensator(share="shared")`` on the log with gravity removed —
  ``accel − (1 + ŝ(T_die)) g`` on the static rows, g the detected position, ŝ the six-position
  scale factor, T_die = lag(T, τ̂) of the previous pass (first pass: the thermometer); the lags
  run over every row. True τ: the thermometer reads the board itself (``tau_s: 0``) and the die
  follows the board through C_die/G_board→die = ``die_tau_s``, so die = lag(thermometer, die_tau_s)
  exactly (first order; checked on the truth below). A thermometer with its own τ_th on the board
  would make it (1 + sτ_th)/(1 + sτ_die): not first order, ≈ τ_die − τ_th on ramps.
"""

import hashlib

import numpy as np
import pytest
import yaml

from conftest import ROOT, assert_one_clear_line
from twin.calibration import LagAwareCompensator, cluster_orientations, detect_static_segments, fit_offset_scale, make_X
from twin.calibration.lag import as_log, lagged_c
from twin.calibration.methods import Px4Method
from twin.calibration.orientation import LABELS, six_position
from twin.measurement import ImuLog
from twin.model.axes import AXIS_LAYOUT, imu_log_fields
from twin.model.dataset import read_hdf5, write_hdf5
from twin.model.scenario import load_scenario, parse_scenario
from twin.model.sections import AXES
from twin.model.simulate import simulate, summary

SCENARIO = ROOT / "scenarios" / "six_position_3axis.yaml"
SETTLED_GAP_C = 0.05  # a segment is settled when the die is within this of the thermometer (τ̂·|dT/dt|)
G0 = 9.80665


def imu_log_from_dataset(ds) -> ImuLog:
    """The logged columns of a three-axis dataset as the calibration's log (no truth)."""
    return ImuLog(**imu_log_fields(ds))


@pytest.fixture(scope="module")
def loaded():
    return load_scenario(SCENARIO)


@pytest.fixture(scope="module")
def ds(loaded):
    return simulate(loaded)


@pytest.fixture(scope="module")
def log(ds):
    return imu_log_from_dataset(ds)


def truth(loaded, effect, parameter):
    return np.array([getattr(loaded.scenario.device.axes, a).effects[effect][parameter] for a in AXES])


def nominal(segments, report):
    g = np.zeros((len(segments), 3))
    for o in report.orientations:
        g[list(o.segments)] = o.nominal_g
    return g


@pytest.fixture(scope="module")
def calibration(log):
    """Six-position detection, the lag-aware τ (two passes), the settled-segment fit."""
    report, fit_all = six_position(log.time_s, log.accel_g, log.temperature_c)
    segments = detect_static_segments(log.time_s, log.accel_g, log.temperature_c)
    found = cluster_orientations(segments)
    g_rows = np.full(log.accel_g.shape, np.nan)  # NaN off the static segments: those rows are not fitted
    for s, g in zip(segments, nominal(segments, found)):
        g_rows[s.start:s.stop] = g
    X = make_X(log.time_s, log.temperature_c)
    tau, lag = 0.0, None
    for _ in range(2):
        die = lagged_c(as_log(X), tau)
        s_die = (fit_all.scale_ppm[:, 0] + fit_all.scale_ppm[:, 1] * (die[:, None] - fit_all.reference_c)) * 1e-6
        lag = LagAwareCompensator(share="shared").fit(X, log.accel_g - g_rows * (1 + s_die))
        tau = float(lag.tau_die_s_[0])
    slope = np.array([np.polyfit(log.time_s[s.start:s.stop] - log.time_s[s.start], log.temperature_c[s.start:s.stop], 1)[0]
                      for s in segments])
    settled = [s for s, r in zip(segments, slope) if tau * abs(r) < SETTLED_GAP_C]
    settled_report = cluster_orientations(settled)
    return {"report": report, "fit_all": fit_all, "segments": segments, "found": found, "g_rows": g_rows,
            "lag": lag, "settled": settled, "settled_report": settled_report,
            "fit": fit_offset_scale(settled, settled_report)}


def test_scenario_is_a_three_axis_six_position_test(loaded, ds):
    scn = loaded.scenario
    assert loaded.axes == AXES and scn.test_plan.six_position is not None
    assert set(np.round(ds["program/setpoint_c"][ds["program/segment"] == 0])) == {-20.0, 25.0, 70.0}
    sf = truth(loaded, "scale_factor_tc", "tc1_ppm_per_c")
    assert len(set(sf)) == 3  # a different scale-factor tempco per axis
    g = np.column_stack([ds[f"test/gravity_{a}_g"] for a in AXES])
    np.testing.assert_allclose(np.linalg.norm(g, axis=1), 1.0, atol=1e-12)  # |g| = 1, turns included
    held = {tuple(r) for r in np.round(g, 9) + 0.0 if np.abs(r).max() == 1}  # the positions (and mid-half-turn points)
    assert {tuple(v) for v in np.vstack([np.eye(3), -np.eye(3)])} <= held


def test_simulation_is_vectorised_and_solves_the_thermal_chain_once(loaded, monkeypatch):
    """Fast by construction, counted rather than timed: one thermal solve shared by the three axes,
    and no Python loop over samples (the interpreter runs fewer lines than one axis has samples).

    Measured: 5,415 Python lines executed (NumPy's and SciPy's Python wrappers included) for 29,701
    samples per axis; a loop over the samples in any stage would alone add at least 29,701.
    """
    import sys

    import twin.model.simulate as simulate_module

    solves = []
    chain = simulate_module.simulate_chain

    def counted(*args, **kwargs):
        solves.append(1)
        return chain(*args, **kwargs)

    monkeypatch.setattr(simulate_module, "simulate_chain", counted)
    simulate(loaded)  # imports and caches warmed, as in the fixture's run
    solves.clear()
    lines = [0]

    def tracer(frame, event, arg):
        if event == "line":
            lines[0] += 1
        return tracer

    previous = sys.gettrace()
    sys.settrace(tracer)
    try:
        ds = simulate(loaded)
    finally:
        sys.settrace(previous)
    samples = ds["time_s"].size
    assert len(solves) == 1  # the thermal path is shared, not solved per axis
    assert lines[0] < samples, (lines[0], samples)


def test_each_axis_decomposes_exactly_and_the_thermal_path_is_shared(loaded, ds):
    for a in AXES:
        recon = sum(ds[p] for p in (f"test/gravity_{a}_g", f"truth/{a}/drift_g", f"truth/{a}/turn_on_bias_g",
                                    f"truth/{a}/noise_white_g", f"truth/{a}/noise_bias_instability_g",
                                    f"truth/{a}/quantisation_g"))
        np.testing.assert_allclose(ds[f"output/accel_{a}_g"], recon, atol=1e-12)
        np.testing.assert_allclose(ds[f"output/accel_{a}_g"], ds[f"output/accel_{a}_digits"] * 0.98e-3, atol=1e-12)
    # independent noise streams per axis
    noise = np.column_stack([ds[f"truth/{a}/noise_white_g"] for a in AXES])
    assert np.abs(np.corrcoef(noise.T) - np.eye(3)).max() < 0.05
    # the true lag: thermometer on the board with tau_s 0, die = lag(board, die_tau_s), first order
    from sim.drift import lowpass

    c = loaded.scenario.chamber
    assert c.thermometer.attached_to == "board" and c.thermometer.tau_s == 0
    np.testing.assert_array_equal(ds["temperature/thermometer_true_c"], ds["temperature/board_c"])
    np.testing.assert_allclose(lowpass(ds["temperature/board_c"], 1.0, c.lumped.die_tau_s), ds["temperature/die_c"],
                               atol=1e-4)


def test_same_seed_same_arrays_another_seed_other_noise(loaded, ds):
    again = simulate(loaded)
    assert again.arrays.keys() == ds.arrays.keys()
    for k in ds.arrays:
        np.testing.assert_array_equal(again[k], ds[k], err_msg=k)
    other = simulate(loaded, seed=loaded.scenario.seed + 1)
    np.testing.assert_array_equal(other["truth/x/drift_g"], ds["truth/x/drift_g"])
    assert not np.array_equal(other["truth/x/noise_white_g"], ds["truth/x/noise_white_g"])


def test_dataset_round_trip_summary_and_imu_log(ds, log, tmp_path):
    back = read_hdf5(write_hdf5(ds, tmp_path / "three.h5"))
    assert list(back.attrs["axes"]) == list(AXES)
    for k in ds.arrays:
        np.testing.assert_array_equal(back[k], ds[k], err_msg=k)
        assert ds[k].ndim == 1 and ds[k].size == len(ds)
    s = summary(back)
    assert list(s.axes) == list(AXES) and s.samples == len(ds) and 1.2 < s.output_rms_minus_truth_mg < 1.5
    assert log.accel_g.shape == (len(ds), 3) and np.array_equal(log.temperature_c, ds["temperature/thermometer_c"])
    assert "test/applied_g" not in ds.arrays and "output/output_g" not in ds.arrays


def test_three_axis_layout_is_documented():
    doc = (ROOT / "docs" / "dataset.md").read_text()
    assert [p for p in AXIS_LAYOUT if f"`{p}`" not in doc] == []


def test_six_positions_found_and_scale_factor_tempcos_recovered(loaded, calibration):
    report, fit = calibration["report"], calibration["fit"]
    assert report.kind == "six-position" and set(report.found) == set(LABELS) and not report.missing
    settled = calibration["settled_report"]
    assert settled.kind == "six-position"
    plateaus = (-20.0, 25.0, 70.0)
    for o in settled.orientations:  # every position at every plateau, settled
        near = [min(plateaus, key=lambda p: abs(p - t)) for t in o.temperatures_c]
        assert set(near) == set(plateaus) and max(abs(np.subtract(o.temperatures_c, near))) < 1.0, o.label
    sf = truth(loaded, "scale_factor_tc", "tc1_ppm_per_c")
    off = truth(loaded, "static_bias_tc", "tc1_mg_per_c")
    zero = np.array([getattr(loaded.scenario.device.axes, a).zero_g_offset_mg for a in AXES])
    fit_all = calibration["fit_all"]
    print(f"\nsix-position, {len(calibration['settled'])} settled of {len(calibration['segments'])} static segments "
          f"(τ̂·|dT/dt| < {SETTLED_GAP_C} °C), thermometer as T, reference {fit.reference_c:g} °C")
    print("axis  TCSo true  fitted [95 %]                 all segments   TCOff true  fitted [95 %]            "
          "zero-g true fitted")
    for k, a in enumerate(AXES):
        lo, hi = fit.scale_ci95_ppm[k, 1]
        olo, ohi = fit.offset_ci95_mg[k, 1]
        print(f"{a}     {sf[k]:+8.1f}  {fit.scale_ppm[k, 1]:+8.2f} [{lo:+8.2f}, {hi:+8.2f}] ppm/°C  "
              f"{fit_all.scale_ppm[k, 1]:+8.2f}      {off[k]:+6.3f}   {fit.offset_mg[k, 1]:+7.4f} [{olo:+7.4f}, "
              f"{ohi:+7.4f}] mg/°C  {zero[k]:+6.1f} {fit.offset_mg[k, 0]:+7.2f} mg")
        assert abs(fit.scale_ppm[k, 1] / sf[k] - 1) < 0.05, a
        assert lo <= sf[k] <= hi, a
        assert olo <= off[k] <= ohi, a
        assert abs(fit.offset_mg[k, 0] - zero[k]) < 0.3, a
    # the lag shows on the ramp segments: settled residual at the noise floor, all segments well above
    assert np.all(fit.residual_rms_mg < 0.15) and np.all(fit_all.residual_rms_mg > 3 * fit.residual_rms_mg)


def test_lag_aware_fit_recovers_the_shared_die_tau(loaded, calibration):
    lag = calibration["lag"]
    tau_true = loaded.scenario.chamber.lumped.die_tau_s  # thermometer reads the board (tau_s 0): exactly first order
    lo, hi = lag.tau_die_ci95_s_[0]
    print(f"\nlag-aware (shared): τ_die = {lag.tau_die_s_[0]:.2f} s [{lo:.2f}, {hi:.2f}] (95 %), true {tau_true:g} s; "
          f"structure {lag.selected_.name}; train RMS {np.round(lag.train_rms_mg_, 3)} mg")
    assert lag.shared_ and np.all(lag.tau_die_s_ == lag.tau_die_s_[0])
    assert abs(lag.tau_die_s_[0] / tau_true - 1) < 0.05
    assert lo <= tau_true <= hi
    off = truth(loaded, "static_bias_tc", "tc1_mg_per_c")
    np.testing.assert_allclose(lag.coef_mg_[:, 1], off, atol=0.01)  # d offset / d T_die per axis


def _left_mg(segments, report, model):
    """RMS [mg] per axis over the segment means of what ``model(T, g)`` leaves; a model without a
    level of its own (PX4: the level is the ordinary accelerometer calibration) gets the best one."""
    g = nominal(segments, report)
    mean = np.array([s.mean_g for s in segments])
    T = np.array([s.temperature_c for s in segments])
    r, level = model(T, g)
    r = mean - g - r
    if level:
        r = r - r.mean(axis=0)
    return np.sqrt(np.mean(r**2, axis=0)) * 1e3


def test_offset_only_px4_vs_six_position_table(log, ds, calibration):
    X = make_X(log.time_s, log.temperature_c)
    fit = calibration["fit"]

    def six(T, g):
        dT = T[:, None] - fit.reference_c
        return g * (fit.scale_ppm[:, 0] + fit.scale_ppm[:, 1] * dT) * 1e-6 + (
            fit.offset_mg[:, 0] + fit.offset_mg[:, 1] * dT) * 1e-3, False

    raw = Px4Method().fit(X, log.accel_g)                                # the whole log as logged, gravity in it
    known = Px4Method().fit(X, log.accel_g - calibration["g_rows"])     # static rows, detected gravity removed
    noise = np.column_stack([ds[f"truth/{a}/noise_white_g"] + ds[f"truth/{a}/noise_bias_instability_g"]
                             + ds[f"truth/{a}/quantisation_g"] for a in AXES])
    rows = {}
    for name, segs, rep in (("settled", calibration["settled"], calibration["settled_report"]),
                            ("all static", calibration["segments"], calibration["found"])):
        floor = np.sqrt(np.mean(np.array([noise[s.start:s.stop].mean(axis=0) for s in segs]) ** 2, axis=0)) * 1e3
        rows[name] = {
            "PX4 offset-only, raw log": _left_mg(segs, rep, lambda T, g: (raw.cal_.offset_m_s2(T) / G0, True)),
            "PX4 offset-only, gravity removed": _left_mg(segs, rep, lambda T, g: (known.cal_.offset_m_s2(T) / G0, True)),
            "six-position offset + scale factor": _left_mg(segs, rep, six),
            "noise floor (truth)": floor,
        }
    print("\nwhat each model leaves on the static segments' means [mg RMS]")
    print(f"{'segments':11s} {'model':36s} " + " ".join(f"{a:>8s}" for a in AXES))
    for name, table in rows.items():
        for model, v in table.items():
            print(f"{name:11s} {model:36s} " + " ".join(f"{x:8.3f}" for x in v))
    settled = rows["settled"]
    assert np.all(settled["six-position offset + scale factor"] < 1.5 * settled["noise floor (truth)"])
    assert np.all(settled["PX4 offset-only, gravity removed"] > 10 * settled["six-position offset + scale factor"])
    assert np.all(settled["PX4 offset-only, raw log"] > settled["PX4 offset-only, gravity removed"])


# ------------------------------------------------------------------ the one-axis scenarios are unchanged

# sha256 over the sorted arrays of simulate(paper_iis328dq.yaml at 1 Hz), recorded before device.axes existed
# (7ab6c0fd…), again when the thermal modes left lfilter for sim.recursion (2a66132f…: the temperatures
# moved by ≤ 42 ulp), and again when sim.recursion became the blocked NumPy recursion: the temperatures
# moved by ≤ 1.5e-12 °C, the logged output not at all (tests/test_recursion.py, against lfilter in the same run)
PAPER_1HZ_SHA256 = "ab03d1ac58c7b25ffa7ca70ad04193eb704e8667c6ac3f43ce3b619b6acd8155"


def test_one_axis_paper_scenario_is_unchanged():
    path = ROOT / "scenarios" / "paper_iis328dq.yaml"
    data = yaml.safe_load(path.read_text())
    data["test_plan"]["logger_rate_hz"] = 1.0
    ds = simulate(parse_scenario(yaml.safe_dump(data), str(path)))
    h = hashlib.sha256()
    for k in sorted(ds.arrays):
        a = np.ascontiguousarray(ds.arrays[k])
        h.update(k.encode())
        h.update(str(a.dtype).encode())
        h.update(a.tobytes())
    assert "axes" not in ds.attrs and "output/output_g" in ds.arrays
    assert h.hexdigest() == PAPER_1HZ_SHA256


# ------------------------------------------------------------------ one-line errors

G = "program:\n  steps:\n    - {type: hold, dwell_s: 600}\n"
AX = "device:\n  axes:\n    x: {}\n    y: {}\n    z: {}\n"
BAD = [
    (G + AX + "test_plan:\n  orientations:\n    - {at_s: 0, gravity_g: [0, 0, 0.95]}\n",
     ["<t>:11", "test_plan.orientations[0].gravity_g", "unit length (1 ± 0.01 g)"]),
    (G + AX + "test_plan:\n  orientations:\n    - {at_s: 0, gravity_g: [0, 1]}\n", ["three components [gx, gy, gz]"]),
    (G + AX + "test_plan:\n  orientations:\n    - {at_s: 0}\n", ["test_plan.orientations[0]", "got neither"]),
    (G + AX + "test_plan:\n  six_position: {block_s: 60}\n  tumble: {block_s: 60, applied_g: [1, -1]}\n",
     ["test_plan", "six_position and tumble: give one orientation source"]),
    (G + AX + "test_plan:\n  tumble: {block_s: 60, applied_g: [1, -1]}\n", ["<t>:10", "test_plan.tumble gives one-axis"]),
    (G + AX + "test_plan:\n  orientations:\n    - {at_s: 0, applied_g: 1}\n",
     ["test_plan.orientations[0].applied_g is one-axis", "takes gravity_g"]),
    (G + AX + "test_plan:\n  six_position: {block_s: 60, order: [+x, -x, +y, -y, +z]}\n",
     ["test_plan.six_position.order", "missing -z"]),
    (G + AX + "test_plan:\n  six_position: {block_s: 60, turn_s: 60}\n", ["turn_s 60 s must be shorter than block_s"]),
    (G + "test_plan:\n  six_position: {block_s: 60}\n", ["test_plan.six_position needs a three-axis device"]),
    (G + "test_plan:\n  orientations:\n    - {at_s: 0, gravity_g: [0, 0, 1]}\n",
     ["test_plan.orientations[0].gravity_g needs a three-axis device"]),
    (G + "device:\n  effects: {static_bias_tc: {}}\n  axes:\n    x: {}\n    y: {}\n    z: {}\n",
     ["device", "effects is for a one-axis device"]),
    (G + "device:\n  axes:\n    x: {}\n    y: {}\n", ["missing required key 'device.axes.z'"]),
    (G + "device:\n  axes:\n    x: {effects: {probe_offset: {}}}\n    y: {}\n    z: {}\n",
     ["<t>:6", "device.axes.x.effects", "acts on the thermometer"]),
    (G + "device:\n  axes:\n    x: {}\n    y: {effects: {static_bias_tc: {tc1_mg_per_c: 99}}}\n    z: {}\n",
     ["<t>:7", "device.axes.y.effects", "outside its bounds"]),
]


@pytest.mark.parametrize("text,fragments", BAD, ids=[f"bad{i}" for i in range(len(BAD))])
def test_bad_three_axis_scenario_gets_one_clear_line(text, fragments):
    assert_one_clear_line(text, fragments)


def test_default_three_axis_orientation_is_z_up():
    ds = simulate(parse_scenario(G + AX, "<t>"))
    g = np.column_stack([ds[f"test/gravity_{a}_g"] for a in AXES])
    assert np.all(g == [0.0, 0.0, 1.0])
