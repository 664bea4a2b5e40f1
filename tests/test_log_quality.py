"""The log-quality stage on a flight log whose truth is known: a 30-min warm-up at −1 g on z (25 → 40 °C)
with two 20° handling tilts, a 3-min flight (vibration ±0.5 g at 80 Hz aliased into a 50 Hz log,
manoeuvres at ±1 rad/s), a 2-s gap, a crash (a 6 g spike, a tumble) and 20 min upside down (+1 g on z,
cooling). Compare's use of it: per-stretch orientation, refusals, heating/cooling statements."""

import json
import re

import numpy as np
import pytest

from conftest import run_in_process
from twin.calibration import cluster_orientations, detect_static_segments
from twin.diagnosis.axes import OrientationError, axis_rows
from twin.measurement import ImuLog, Measurement
from twin.measurement.log_quality import LogQualityError
from twin.measurement.quality import assess_log, assess_measurement, cluster_directions, thermal_directions

RATE_HZ = 50.0
MARGIN_S, WINDOW_S = 2.0, 1.0  # the stage's defaults: a found stretch may lose this much beside each move
SLACK = int((MARGIN_S + WINDOW_S) * RATE_HZ) + 2


def _rolled(phi):
    """Gravity seen by a board at −1 g on z rolled by ``phi`` [rad] about x."""
    return np.column_stack([np.zeros_like(phi), np.sin(phi), -np.cos(phi)])


def flight_log(with_gyro=True, seed=1):
    """The log and its truth: row ranges of each phase and the row after the gap."""
    rng = np.random.default_rng(seed)
    n_of = lambda s: int(round(s * RATE_HZ))  # noqa: E731
    parts, truth = [], {}

    def add(name, g, w):
        truth.setdefault(name, []).append((sum(len(p[0]) for p in parts), sum(len(p[0]) for p in parts) + len(g)))
        parts.append((g, w))

    def still(seconds, sign):
        add("static", np.tile([0.0, 0.0, sign], (n_of(seconds), 1)), np.zeros((n_of(seconds), 3)))

    def tilt():  # 1 s up to 20°, 3 s held, 1 s down
        u = np.linspace(0, 1, n_of(5.0))
        phi = np.radians(20.0) * (0.5 - 0.5 * np.cos(np.pi * np.clip(np.minimum(u, 1 - u) * 5, 0, 1)))
        add("handling", _rolled(phi), np.column_stack([np.gradient(phi, 1 / RATE_HZ), np.zeros((phi.size, 2))]))

    still(600, -1.0), tilt(), still(600, -1.0), tilt(), still(600, -1.0)
    tt = np.arange(n_of(180)) / RATE_HZ
    wx = np.sin(2 * np.pi * 0.5 * tt)  # ±1 rad/s roll manoeuvres
    vib = 0.5 * np.sin(2 * np.pi * 80.0 * tt)[:, None] * np.array([0.3, 0.3, 1.0])  # 80 Hz seen at 50 Hz
    add("flight", _rolled(np.cumsum(wx) / RATE_HZ) + vib, np.column_stack([wx, 0.3 * np.cos(tt), 0 * tt]))
    crash = _rolled(np.linspace(0, np.pi, n_of(1.0)))
    crash[5:10, 2] += 6.0  # the impact
    add("crash", crash, np.tile([np.pi, 0.0, 0.0], (n_of(1.0), 1)))
    still(1200, +1.0)
    g, w = np.vstack([p[0] for p in parts]), np.vstack([p[1] for p in parts])
    t = np.arange(len(g)) / RATE_HZ
    crash0 = truth["crash"][0][0]
    t[crash0:] += 2.0  # no sample for 2 s before the crash
    flight0 = truth["flight"][0][0]
    temp = np.empty(t.size)
    temp[:flight0] = 25 + 15 * t[:flight0] / t[flight0 - 1]  # warm-up on the ground
    temp[flight0:crash0] = np.linspace(40, 38, crash0 - flight0)  # air flow in flight
    temp[crash0:] = 30 + 8 * np.exp(-(t[crash0:] - t[crash0]) / 900)  # upside down, cooling
    temp += rng.normal(0, 0.02, t.size)
    accel = g + rng.normal(0, 3e-3, g.shape) + np.array([0.01, -0.005, 0.02])  # offsets: z reads −0.98 / +1.02 g
    gyro = w + rng.normal(0, 0.005, w.shape) + 0.01
    log = ImuLog(t, temp, accel, instance=3, source="flight.csv", gyro_rad_s=gyro if with_gyro else None)
    return log, truth


@pytest.fixture(scope="module", params=[True, False], ids=["gyro", "no_gyro"])
def flight(request):
    log, truth = flight_log(with_gyro=request.param)
    return log, truth, assess_log(log)


def test_static_ground_stretches_are_found_by_row_within_the_margins(flight):
    log, truth, q = flight
    static = q.static_stretches()
    expected = truth["static"]
    assert len(static) == len(expected) == 4, [(s.kind, s.start, s.stop) for s in q.stretches]
    for s, (lo, hi) in zip(static, expected):
        assert lo <= s.start <= lo + (0 if lo == 0 else SLACK), (s.start, lo)
        assert hi - (0 if hi == len(log) else SLACK) <= s.stop <= hi, (s.stop, hi)
    assert [s.label for s in static] == ["-z", "-z", "-z", "+z"]  # the flip found
    assert static[-1].gravity_g[2] == pytest.approx(1.02, abs=0.01)
    assert [s.ramp for s in static] == ["heating", "heating", "heating", "cooling"]
    mask = np.zeros(len(log), bool)
    for s in static:
        mask[s.start:s.stop] = True
    np.testing.assert_array_equal(q.usable_static, mask)
    # nothing of the flight, the crash or the tilts is usable
    for name in ("flight", "crash", "handling"):
        for lo, hi in truth[name]:
            assert not q.usable_static[lo:hi].any(), name


def test_handling_gap_and_thermal_directions(flight):
    log, truth, q = flight
    handling = [s for s in q.stretches if s.kind == "handling"]
    assert len(handling) == 2
    for s, (lo, hi) in zip(handling, truth["handling"]):
        assert s.start <= lo and s.stop >= hi and "tilted 2" in s.reason  # tilted ≈20°
    gaps = [s for s in q.stretches if s.kind == "gap"]
    assert len(gaps) == 1 and gaps[0].start == truth["crash"][0][0]
    assert gaps[0].t1_s - gaps[0].t0_s == pytest.approx(2.0, abs=0.05)
    assert q.excluded_s("gap") == pytest.approx(2.0, abs=0.05)
    assert q.has_heating and q.has_cooling
    assert q.static_min_c == pytest.approx(25.0, abs=0.1) and q.static_max_c == pytest.approx(40.0, abs=0.2)
    assert q.static_s == pytest.approx(600 + 600 + 600 + 1200 - 4 * 2 * (MARGIN_S + WINDOW_S), abs=20)


def test_table_and_strict_json(flight):
    log, truth, q = flight
    rows = q.table_rows()
    assert [r.kind for r in rows if r.used] == ["static"] * 4
    assert all(r.reason for r in rows) and {r.kind for r in rows if not r.used} >= {"handling", "moving", "gap"}
    doc = json.loads(q.to_json())  # allow_nan=False inside: a NaN would have raised
    assert doc["has_heating"] and doc["excluded_s"]["gap"] == pytest.approx(2.0, abs=0.05)
    assert doc["stretches"][0]["orientation"] == "-z" and doc["thresholds"]["sigma_mg"] > 1.0


def test_clipping_is_found_where_the_converter_saturates():
    log, truth = flight_log()
    clipped = ImuLog(log.time_s, log.temperature_c, np.clip(log.accel_g, -4.0, 4.0), instance=3, source="flight.csv",
                     gyro_rad_s=log.gyro_rad_s)
    q = assess_log(clipped)
    spike = truth["crash"][0][0] + 5
    clips = [s for s in q.stretches if s.kind == "clipping"]
    assert clips and any(s.start <= spike < s.stop for s in clips)
    assert q.excluded_s("clipping") > 0 and not q.usable_static[spike]


def test_frozen_and_jumping_temperature_and_time_reset():
    log, _ = flight_log()
    T = log.temperature_c.copy()
    T[10_000:15_000] = T[10_000]  # stuck for 100 s
    T[20_000] += 5.0  # one sample 5 °C off
    t = log.time_s.copy()
    t[40_000:] -= 100.0  # the clock goes back 100 s
    q = assess_log(ImuLog(t, T, log.accel_g, instance=3, source="flight.csv"))
    kinds = {s.kind: s for s in q.stretches}
    assert kinds["temperature_frozen"].start <= 10_001 and kinds["temperature_frozen"].stop >= 15_000
    assert kinds["temperature_jump"].start <= 20_000 < kinds["temperature_jump"].stop
    assert kinds["time_reset"].start == 40_000 and "back to" in kinds["time_reset"].reason
    assert not q.usable_static[[12_000, 20_000]].any()


def test_refusal_names_the_numbers():
    log, _ = flight_log()
    q = assess_log(log)
    with pytest.raises(LogQualityError) as exc:
        q.require_calibratable(min_static_s=60, min_span_c=20)
    msg = str(exc.value)
    assert "\n" not in msg
    assert re.fullmatch(r"flight\.csv IMU3: \d+ s static, 2\d\.\d–4\d\.\d °C after excluding \d+ s of motion, "
                        r"2 s of gaps: < 20 °C", msg), msg
    q.require_calibratable(min_static_s=60, min_span_c=10)  # 15 °C of usable static rows: enough
    # 68 s still, then vibration: too little of either
    n = int(300 * RATE_HZ)
    t = np.arange(n) / RATE_HZ
    a = np.tile([0.0, 0.0, -1.0], (n, 1)) + np.random.default_rng(2).normal(0, 3e-3, (n, 3))
    a[int(70 * RATE_HZ):, 2] += 0.5 * np.sin(2 * np.pi * 80 * t[int(70 * RATE_HZ):])
    short = assess_log(ImuLog(t, 25.5 + 7.5 * t / 300, a, instance=3))
    with pytest.raises(LogQualityError, match=r"^IMU3: 6\d s static, 25\.5–2\d\.\d °C after excluding 2\d\d s of "
                                              r"motion: < 100 s static, < 10 °C$"):
        short.require_calibratable(min_static_s=100)


def test_one_orientation_clustering_serves_calibration():
    log, truth = flight_log()
    segments = detect_static_segments(log.time_s, log.accel_g, log.temperature_c)
    report = cluster_orientations(segments)
    assert {o.label for o in report.orientations} == {"-z", "+z"}
    static = assess_log(log).static_stretches()
    assert all(any(s.start <= g.start and g.stop <= s.stop for s in static) for g in segments)
    clusters = cluster_directions([[0, 0, -1], [0.02, 0, -1], [0, 0, 1], [0.5, 0, -0.866]], tol_deg=10)
    assert clusters.member_of == (0, 0, 1, 2) and clusters.labels == ("-z", "+z", "tilted")


def test_compare_rows_get_the_g_of_their_own_stretch():
    log, truth = flight_log()
    q = assess_log(log)
    z = axis_rows(q, "z", None)
    first, last = truth["static"][0], truth["static"][-1]
    assert z.applied_g[first[0] + 100] == -1.0 and z.applied_g[last[1] - 100] == 1.0
    assert not z.keep[truth["flight"][0][0]:truth["crash"][0][1]].any()
    assert {s.applied_g for s in z.stretches} == {-1.0, 1.0} and {r.kind for r in z.excluded} >= {"moving", "gap"}
    assert set(axis_rows(q, "x", None).applied_g[z.keep]) == {0.0}
    with pytest.raises(OrientationError, match=r"z: --applied-g -1 but the static rows at 199\d–3193 s read \+1\.02 g"):
        axis_rows(q, "z", -1.0)  # the flip: one value for the whole log is refused
    unknown = axis_rows(q, "z", "unknown")
    assert unknown.applied_g is None and unknown.keep.sum() == q.usable_static.sum()


def test_an_orientation_nobody_gave_and_the_data_cannot_give_is_refused(tmp_path):
    n = int(600 * RATE_HZ)
    t = np.arange(n) / RATE_HZ
    g = np.tile([0.5, 0.0, -0.866], (n, 1)) + np.random.default_rng(3).normal(0, 2e-3, (n, 3))  # 30° tilted
    temp = 25 + 15 * t / t[-1]
    with pytest.raises(OrientationError, match="x: orientation not given and not estimable"):
        axis_rows(assess_log(ImuLog(t, temp, g, instance=0)), "x", None)
    f = tmp_path / "tilted.csv"
    f.write_text("time_s,temperature_c,x,y,z\n" + "".join(f"{a:.3f},{b:.3f},{c:.5f},{d:.5f},{e:.5f}\n"
                                                           for a, b, (c, d, e) in zip(t[::5], temp[::5], g[::5])))
    code, out, err = run_in_process(["compare", "scenarios/paper_iis328dq.yaml", f, "--axes", "x", "--time-col", "time_s",
                                     "--temperature-col", "temperature_c", "--x-col", "x", "--y-col", "y",
                                     "--z-col", "z"])
    assert code == 2 and err.count("\n") == 1 and "not estimable" in err and "--applied-g" in err, err


def test_cli_refuses_an_applied_g_the_static_rows_contradict(tmp_path):
    rng = np.random.default_rng(4)
    t = np.arange(0, 1800, 1.0)
    f = tmp_path / "one_axis.csv"
    f.write_text("time_s,temperature_c,output_g\n" + "".join(
        f"{a:g},{b:.3f},{c:.6f}\n" for a, b, c in zip(t, 25 + 10 * t / 1800, -0.98 + rng.normal(0, 1e-3, t.size))))
    code, out, err = run_in_process(["compare", "scenarios/paper_iis328dq.yaml", f, "--applied-g", "0"])
    assert code == 2 and err.count("\n") == 1, err
    assert "--applied-g 0 but the static rows at 0–1800 s read −0.98 g" in err


def _drift_log(knots_t, knots_c, seed=5, tau_s=400.0):
    """A +1 g single-axis log whose die lags the thermometer by ``tau_s`` (the twin does not model it)."""
    rng = np.random.default_rng(seed)
    t = np.arange(0, knots_t[-1], 1.0)
    T = np.interp(t, knots_t, knots_c)
    die = np.empty_like(T)
    die[0], k = T[0], np.exp(-1.0 / tau_s)
    for i in range(1, T.size):
        die[i] = k * die[i - 1] + (1 - k) * T[i]
    y = 1.0 + 0.8e-3 * (die - 25) + 2e-6 * (die - 25) ** 2 + rng.normal(0, 0.3e-3, t.size)
    n = t.size
    return Measurement(t, T + rng.normal(0, 0.01, n), y, np.ones(n), np.zeros(n, np.int16), np.zeros(n, bool), True,
                       ["drift.csv"], 0, [])


def test_heating_versus_cooling_is_said_only_when_both_are_in_the_data(paper_path):
    from twin.finding.build import compare_measurement
    from twin.model.scenario import load_scenario

    loaded = load_scenario(paper_path)
    heating = _drift_log([0, 1800, 3600, 7200, 10800, 14400], [-10, -10, 20, 20, 50, 50])
    q = assess_measurement(heating)
    assert q.has_heating and not q.has_cooling
    _, result = compare_measurement(loaded, heating, [])
    assert result.selected[:1] == ("thermal_lag",)
    assert "between heating and cooling" not in result.finding, result.finding
    cycle = _drift_log([0, 1800, 3600, 7200, 9000, 12600], [-10, -10, 20, 20, -10, -10])
    d = thermal_directions(cycle.time_s, cycle.temperature_c)
    assert d.has_heating and d.has_cooling and d.heating_c == pytest.approx(30, abs=1)
    _, result = compare_measurement(loaded, cycle, [])
    assert "changes sign between heating and cooling" in result.finding, result.finding


def test_a_log_that_is_mostly_flight_does_not_call_its_vibration_still():
    """150 s on the ground, then 1050 s of 50–400 mg vibration: the quietest quarter is flight, and a
    threshold derived from it alone ran away to ~1 g; the ceiling keeps it at 50 mg at most."""
    rng = np.random.default_rng(4)
    t = np.arange(0.0, 1200.0, 0.02)
    flying = t >= 150
    amp = np.where(flying, 0.05 + 0.35 * rng.random(t.size), 0.0)
    a = np.tile([0.0, 0.0, -1.0], (t.size, 1)) + rng.normal(0, 2e-3, (t.size, 3))
    a += (amp * np.sin(2 * np.pi * 17.0 * t))[:, None] * [0.3, 0.3, 1.0]
    q = assess_log(ImuLog(t, 25 + 10 * t / t[-1], a, instance=0))
    assert q.thresholds.sigma_mg <= 50.0
    assert q.usable_static[flying].mean() < 0.02
    assert 140 < q.static_s < 150


@pytest.mark.parametrize("drift_rad_s", [0.06, 0.2])
def test_a_still_gyro_whose_bias_drifts_with_temperature_is_still(drift_rad_s):
    """A still board whose gyro bias moves 0.06–0.2 rad/s over a warm-up: the bias is not motion."""
    rng = np.random.default_rng(5)
    t = np.arange(0.0, 2400.0, 0.1)
    a = np.tile([0.0, 0.0, -1.0], (t.size, 1)) + rng.normal(0, 2e-3, (t.size, 3))
    w = np.outer(t / t[-1], [drift_rad_s, -drift_rad_s / 2, drift_rad_s / 3]) + rng.normal(0, 3e-3, (t.size, 3))
    q = assess_log(ImuLog(t, 20 + 25 * t / t[-1], a, instance=0, gyro_rad_s=w))
    assert q.excluded_s() == 0 and q.static_min_c == pytest.approx(20, abs=0.01)


def test_rows_without_a_gyro_sample_are_judged_by_the_accelerometer():
    log, truth = flight_log(with_gyro=True)
    gyro = log.gyro_rad_s.copy()
    gyro[:3000] = np.nan  # the gyro topic started late
    q = assess_log(ImuLog(log.time_s, log.temperature_c, log.accel_g, instance=3, gyro_rad_s=gyro))
    ref = assess_log(log)
    assert abs(q.static_s - ref.static_s) < 5
