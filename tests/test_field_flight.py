"""A messy flight log through the whole field workflow, as a user runs it: ``twin calibrate``,
``twin firmware``, ``twin compare`` and ``twin apply`` on a simulated ArduPilot DataFlash log in the
older field names (``TimeMS``, ``Temp``, messages ``IMU``/``IMU2``) whose truth is known
(:mod:`flightsim`: a warm-up on the ground with two handling tilts, a flight with vibration and
manoeuvres, a 2-s gap, a crash flip and the vehicle upside down to the end; a second IMU that
warms too little to calibrate).

And the firmware's side of a table calibration: PX4 matches a calibration to a sensor by device id
(``TemperatureCompensation::set_sensor_id``), so a table that records no id must be given one.
"""

import json
import re

import numpy as np
import pytest

from types import SimpleNamespace

from conftest import run_cli, run_in_process
from flightsim import (ACCEL_NOISE_MS2, CRASH_S, FLIGHT_S, GAP_AT_S, GAP_S, GROUND_S, GYRO_NOISE_RAD_S, HANDLING_AT_S,
                       HANDLING_S, gyro_bias_rad_s, simulate_flight)
from logfixtures import G_MS2, ImuTruth, chamber_run, cubic_offset_ms2, write_dataflash
from twin.firmware import cal_from_dict, parse_ardupilot_parm, parse_px4_params

RATE_HZ = 10.0  # a 10-Hz log keeps the test quick; the log-quality thresholds scale with the step


def cli(*args):
    """``twin args`` in this process (the module's flight fixture runs a real process, as a user does)."""
    code, out, err = run_in_process(list(args))
    return SimpleNamespace(returncode=code, stdout=out, stderr=err)


def write_table(path, time_s, temperature_c, accel_g, gyro_rad_s=None):
    """A tester's table: time [s], temperature [°C], acceleration [g] (and rate [rad/s]) per axis."""
    columns = [time_s, temperature_c, accel_g] + ([gyro_rad_s] if gyro_rad_s is not None else [])
    header = "time_s,temp_c,ax_g,ay_g,az_g" + (",wx,wy,wz" if gyro_rad_s is not None else "")
    np.savetxt(path, np.column_stack(columns), delimiter=",", header=header, comments="", fmt="%.9g")


def strict(text: str):
    """JSON that Python's reader accepts without NaN or Infinity."""
    def refuse(constant):
        raise AssertionError(f"non-strict JSON constant {constant}")
    return json.loads(text, parse_constant=refuse)


@pytest.fixture(scope="module")
def flight(tmp_path_factory):
    """The log written as an older ArduPilot's DataFlash, calibrated once by the CLI."""
    folder = tmp_path_factory.mktemp("flight")
    truth = simulate_flight(seed=3, rate_hz=RATE_HZ)
    imus = [ImuTruth(k, truth.device_ids[k], np.round(truth.time_s * 1e6).astype(np.uint64),
                     truth.temperature_c[k].astype(np.float32), truth.accel_ms2[k].astype(np.float32),
                     truth.gyro_rad_s[k].astype(np.float32), truth.gyro_device_ids[k]) for k in range(2)]
    log = write_dataflash(folder / "flight.bin", imus, old_names=True)
    cal = folder / "cal.json"
    done = run_cli("calibrate", str(log), "-o", str(cal), "--json", str(folder / "calibrate.json"))
    assert done.returncode == 0, done.stderr
    return truth, log, cal, done.stdout, strict(cal.read_text())


def phase_between(truth, t0: float, t1: float) -> set[str]:
    k = (truth.time_s >= t0) & (truth.time_s < t1)
    return set(truth.phase[k])


def test_calibration_fits_only_the_still_ground_rows_and_says_why_not_the_rest(flight):
    truth, _, _, stdout, doc = flight
    [imu] = doc["imus"]
    [quality] = imu["log_quality"]
    used = [s for s in quality["stretches"] if s["used"]]
    for s in used:  # no row of a handling tilt, the flight, the crash or the upside-down tail is fitted
        assert phase_between(truth, s["from_s"], s["to_s"]) == {"ground"}, s
    # what is used: all of the ground's still time but the margins around the moves (window 1 s + 2 s
    # each side of each 5-s tilt and before take-off: at most 3 × 2 × 3 s)
    ground_still_s = GROUND_S - len(HANDLING_AT_S) * HANDLING_S
    assert ground_still_s - 3 * 2 * 3 <= quality["static_s"] <= ground_still_s
    kinds = [s["kind"] for s in quality["stretches"] if not s["used"]]
    assert kinds.count("handling") == len(HANDLING_AT_S)
    assert kinds.count("gap") == 1
    [gap] = [s for s in quality["stretches"] if s["kind"] == "gap"]
    assert gap["from_s"] == pytest.approx(GAP_AT_S, abs=0.2) and gap["duration_s"] == pytest.approx(GAP_S, abs=0.2)
    excluded_motion = sum(s["duration_s"] for s in quality["stretches"] if s["kind"] in ("moving", "handling"))
    assert FLIGHT_S + CRASH_S - GAP_S < excluded_motion < FLIGHT_S + CRASH_S + 60
    # the tail is still but upside down: another attitude, which an offset fit cannot tell from drift
    [tail] = [s for s in quality["stretches"] if s["kind"] == "other_attitude"]
    assert tail["orientation"] == "+z" and phase_between(truth, tail["from_s"], tail["to_s"]) == {"inverted"}
    assert tail["to_s"] == pytest.approx(truth.time_s[-1] + 1 / RATE_HZ)
    assert "an offset fit cannot tell a change of attitude from drift" in tail["reason"]
    assert "orientations" not in imu  # two faces are not a multi-position test
    # the console says it too, a line per excluded stretch
    assert re.search(r"rows used: flight\.bin IMU0: \d+ s static, 25\.\d–4\d\.\d °C after excluding \d+ s of "
                     r"motion, 2 s of gaps, \d+ s of other attitudes", stdout)
    assert len(re.findall(r"^    excluded .*(handling|moving|gap|other_attitude) ", stdout, re.M)) == len(kinds)


def test_a_vehicle_put_down_at_another_attitude_is_not_fitted_as_drift(tmp_path):
    """No drift at all; level for 20 min, lifted and put down 2° rolled for 20 min, warming 20 → 50 °C:
    35 mg on y that an offset fit over the whole log would write into the file as drift."""
    rng = np.random.default_rng(11)
    t = np.arange(0.0, 2400.0, 0.5)
    temp = 20.0 + 30.0 * t / t[-1]
    roll = np.where(t < 1200, 0.0, np.radians(2.0))
    moving = (t >= 1195) & (t < 1205)
    roll[moving] = np.radians(15.0) * np.sin(np.pi * (t[moving] - 1195) / 10)
    accel = np.column_stack([0 * t, np.sin(roll), -np.cos(roll)]) + rng.normal(0, 1e-3, (t.size, 3))
    table = tmp_path / "replaced.csv"
    write_table(table, t, temp, accel)
    cal = tmp_path / "cal.json"
    done = cli("calibrate", str(table), "--columns", str(_columns(tmp_path)), "-o", str(cal))
    assert done.returncode == 0, done.stderr
    [imu] = strict(cal.read_text())["imus"]
    [quality] = imu["log_quality"]
    [other] = [s for s in quality["stretches"] if s["kind"] == "other_attitude"]
    assert other["from_s"] > 1200 and other["orientation"] == "-z"
    lo, hi = imu["temperature_span_c"]
    assert hi < 35.5  # only the first attitude's rows (20 → 35 °C) are fitted
    grid = np.linspace(lo, hi, 30)
    for name in ("px4", "ardupilot"):
        curve = cal_from_dict(imu["methods"][name]["firmware"]).offset_m_s2(grid) / G_MS2 * 1e3
        print(f"{name}: fitted drift over {lo:.1f}..{hi:.1f} °C spans {np.ptp(curve, axis=0)} mg")
        # the truth is no drift: 1 mg noise over 2400 rows fixes the curve to ~0.1 mg; 35 mg if fitted as drift
        assert np.all(np.ptp(curve, axis=0) < 0.5)


def test_the_imu_that_warmed_too_little_is_refused_with_the_numbers(flight):
    _, log, _, stdout, doc = flight
    [skipped] = doc["skipped"]
    assert skipped["instance"] == 1
    pattern = (r"flight\.bin IMU1: \d+ s static, 30\.\d–3\d\.\d °C after excluding \d+ s of motion, 2 s of gaps, "
               r"\d+ s of other attitudes: < 10 °C")
    assert re.fullmatch(pattern, skipped["reason"])
    assert "IMU 1: not calibrated: " in stdout
    asked = cli("calibrate", str(log), "--imu", "1", "-o", str(log.parent / "imu1.json"))
    assert asked.returncode == 2 and asked.stdout == ""
    assert re.fullmatch(r"twin: error: " + pattern + "\n", asked.stderr)
    assert not (log.parent / "imu1.json").exists()


def test_the_fits_recover_the_known_accelerometer_and_gyro_drift(flight):
    truth, _, _, _, doc = flight
    [imu] = doc["imus"]
    assert imu["device_id"] == truth.device_ids[0] and imu["gyro"]["device_id"] == truth.gyro_device_ids[0]
    lo, hi = imu["temperature_span_c"]
    grid = np.linspace(lo, hi, 50)

    def bound(noise):
        """A cubic least-squares fit on n evenly spread rows predicts its range ends with σ ≈ 4·noise/√n
        (leverage (p + 1)²/n); five of those cover the largest of 50 points × 3 axes × 2 methods."""
        return 5 * 4 * noise / np.sqrt(imu["samples"])

    for name in ("px4", "ardupilot"):
        cal = cal_from_dict(imu["methods"][name]["firmware"])
        # offsets are known up to the constant the ordinary calibration owns: compare about the mean
        err = cal.offset_m_s2(grid) - cubic_offset_ms2(grid)
        err_mg = (err - err.mean(axis=0)) / G_MS2 * 1e3
        print(f"{name}: accel offset curve vs truth, max {np.abs(err_mg).max(axis=0)} mg")
        assert np.all(np.abs(err_mg) < bound(ACCEL_NOISE_MS2 / G_MS2 * 1e3))
        gyro = cal_from_dict(imu["gyro"]["methods"][name]["firmware"])
        gerr = gyro.offset(grid) - gyro_bias_rad_s(grid)
        if name == "ardupilot":  # anchored at INS_GYRn_CALTEMP: compare about the mean
            gerr = gerr - gerr.mean(axis=0)
        print(f"{name}: gyro offset vs truth, max {np.abs(gerr).max(axis=0)} rad/s")
        assert np.all(np.abs(gerr) < bound(GYRO_NOISE_RAD_S))  # the bias moves 4 mrad/s over the span
        # held out, every method reaches the noise floor: nothing but temperature drift was fitted
        floor = np.array(list(imu["validation"]["noise_floor_mg"].values()))
        rms = np.array(list(imu["validation"]["heldout_rms_mg"][name].values()))
        assert np.all(rms < 1.05 * floor)
    assert not imu["flags"]


def test_firmware_files_carry_the_fitted_accel_and_gyro_and_nothing_for_the_refused_imu(flight):
    truth, _, cal, _, doc = flight
    [imu] = doc["imus"]
    params, parm = cal.parent / "tc.params", cal.parent / "tc.parm"
    for fmt, out in (("px4", params), ("ardupilot", parm)):
        done = cli("firmware", str(cal), "--format", fmt, "-o", str(out))
        assert done.returncode == 0, done.stderr
        assert "IMU 0: accel and gyro" in done.stdout
    values = parse_px4_params(params.read_text()).values
    assert values["TC_A0_ID"] == truth.device_ids[0] and values["TC_G0_ID"] == truth.gyro_device_ids[0]
    assert values["TC_A_ENABLE"] == 1 and values["TC_G_ENABLE"] == 1
    assert not any(k.startswith(("TC_A1", "TC_G1")) for k in values)
    px4_gyro = imu["gyro"]["methods"]["px4"]["firmware"]["coefficients"]
    for i, axis in enumerate("xyz"):
        for k in range(4):
            assert values[f"TC_G0_X{k}_{i}"] == pytest.approx(px4_gyro[axis]["values"][k], rel=1e-6)
            assert values[f"TC_G0_X{k}_{i}"] != 0
    ap = parse_ardupilot_parm(parm.read_text())
    ap_gyro = imu["gyro"]["methods"]["ardupilot"]["firmware"]["coefficients"]
    for i, axis in enumerate("XYZ"):
        for k in (1, 2, 3):
            assert ap[f"INS_TCAL1_GYR{k}_{axis}"] == pytest.approx(ap_gyro[axis.lower()]["values"][k - 1] * 1e6,
                                                                    rel=1e-6, abs=1e-9)
    assert ap["INS_TCAL1_ENABLE"] == 1 and not any(k.startswith("INS_TCAL2") for k in ap)


def test_compare_names_no_temperature_effect_for_the_motion(flight):
    _, log, cal, _, _ = flight
    out = cal.parent / "compare.json"
    done = cli("compare", "scenarios/paper_iis328dq.yaml", str(log), "--axes", "x,y,z", "--imu", "0",
                   "--json", str(out))
    assert done.returncode == 0, done.stderr
    result = strict(out.read_text())
    [imu] = result["imus"] if "imus" in result else [result]
    for axis, r in imu["axes"].items():
        assert r["selected"] == [], (axis, r["selected"])
    # the orientation came from each static stretch: −1 g on the ground, +1 g upside down
    z = {round(s["applied_g"]) for s in imu["orientation_per_stretch"]["z"] if s["applied_g"] is not None}
    assert z == {-1, 1}
    assert "between heating and cooling" not in done.stdout


def test_every_json_written_is_strict(flight):
    _, _, cal, _, _ = flight
    for path in cal.parent.glob("*.json"):
        strict(path.read_text())


# ---- a tester's table: no device id in the data ------------------------------------------------

def set_sensor_id(values: dict, device_id: int, base: str = "TC_A") -> int | None:
    """TemperatureCompensation::set_sensor_id (PX4 src/modules/temperature_compensation/
    TemperatureCompensation.cpp): the slot whose TC_An_ID equals the sensor's device_id, else −1
    (``for (int i = 0; i < ACCEL_COUNT_MAX; ++i) if (device_id == (uint32_t)params.id) return i``)."""
    for n in range(4):
        if f"{base}{n}_ID" in values and int(np.uint32(np.int64(values[f"{base}{n}_ID"]))) == device_id:
            return n
    return None


def calc_thermal_offsets_3d(values: dict, n: int, temperature_c: float) -> np.ndarray:
    """TemperatureCompensation::calc_thermal_offsets_3D transcribed with float32 scalars: ΔT from
    TREF clamped to [TMIN, TMAX], offset = X0 + X1·ΔT + X2·ΔT² + X3·ΔT³ per axis."""
    f = np.float32
    g = lambda k: f(values[f"TC_A{n}_{k}"])  # noqa: E731
    t = f(temperature_c)
    d = (g("TMAX") if t > g("TMAX") else g("TMIN") if t < g("TMIN") else t) - g("TREF")
    d2 = d * d
    d3 = d2 * d
    return np.array([g(f"X0_{i}") + g(f"X1_{i}") * d + g(f"X2_{i}") * d2 + g(f"X3_{i}") * d3 for i in range(3)])


def test_a_table_calibration_needs_a_device_id_for_px4_and_then_applies_as_twin_apply(tmp_path):
    imu = chamber_run(n=600, rate_hz=1.0, seed=5)[0]
    table = tmp_path / "tester.csv"
    write_table(table, imu.time_us * 1e-6, imu.temperature_c, imu.accel_ms2 / G_MS2)
    cal = tmp_path / "cal.json"
    cols = ["--time-col", "time_s", "--temperature-col", "temp_c", "--x-col", "ax_g", "--y-col", "ay_g",
            "--z-col", "az_g", "--output-unit", "g"]
    assert cli("calibrate", str(table), *cols, "-o", str(cal)).returncode == 0
    params = tmp_path / "tc.params"
    refused = cli("firmware", str(cal), "--format", "px4", "-o", str(params))
    assert refused.returncode == 2 and not params.exists()
    assert re.fullmatch(r"twin: error: IMU instance 0: no accel device id; PX4 applies TC_A0 only to the sensor "
                        r"whose device_id equals its ID, so this file would load and change nothing; pass "
                        r"--device-id .*\n", refused.stderr)
    device_id = 2424842
    assert cli("firmware", str(cal), "--format", "px4", "--device-id", str(device_id),
                   "-o", str(params)).returncode == 0
    values = parse_px4_params(params.read_text()).values
    assert set_sensor_id(values, device_id) == 0
    assert set_sensor_id(values, device_id + 1) is None  # another sensor: PX4 applies nothing to it
    applied = tmp_path / "applied.csv"
    assert cli("apply", str(cal), str(table), *[], "--method", "px4", "-o", str(applied),
                   "--columns", str(_columns(tmp_path))).returncode == 0
    out = np.genfromtxt(applied, delimiter=",", names=True)
    raw = imu.accel_ms2.astype(np.float32)
    vehicle = np.array([raw[j] - calc_thermal_offsets_3d(values, 0, temp) for j, temp in enumerate(imu.temperature_c)])
    ours = np.column_stack([out[f"{a}_compensated_g"] for a in "xyz"]) * G_MS2
    # float32 arithmetic on ~10 m/s² values: a few ulps of 9.8 m/s² (1 ulp ≈ 0.1 µg)
    err_ug = np.abs(vehicle.astype(float) - ours).max(axis=0) / G_MS2 * 1e6
    print(f"PX4 as transcribed vs twin apply: max {err_ug} µg")
    assert np.all(err_ug < 2.0)
    # and the file does change the output: by the fitted drift, not by nothing
    assert np.abs(vehicle - raw).max() > 1e-3


def _columns(folder):
    path = folder / "columns.yaml"
    path.write_text("time: time_s\ntemperature: temp_c\nx: ax_g\ny: ay_g\nz: az_g\noutput_unit: g\n")
    return path


def test_an_implausible_fit_is_flagged_not_recommended_and_not_exported_without_force(tmp_path):
    # x drifts 9 mg/°C over a 12 °C chamber cycle: beyond the limit of 10× the IIS328DQ's typical TCOff
    # (0.8 mg/°C), yet only ±3° of apparent tilt, so the rows stay still (a steeper drift reads as turning)
    rng = np.random.default_rng(6)
    t = np.arange(0.0, 1200.0, 1.0)
    temp = 26.0 - 6.0 * np.cos(2 * np.pi * t / 1200.0)
    accel = np.column_stack([0.009 * (temp - 26.0), 0 * t, -1 + 0 * t]) + rng.normal(0, 1e-3, (t.size, 3))
    table = tmp_path / "steep.csv"
    write_table(table, t, temp, accel)
    cal = tmp_path / "cal.json"
    done = cli("calibrate", str(table), "--columns", str(_columns(tmp_path)), "-o", str(cal))
    assert done.returncode == 0, done.stderr
    doc = strict(cal.read_text())
    [imu_doc] = doc["imus"]
    assert imu_doc["recommended"]["px4"] is None and imu_doc["recommended"]["ardupilot"] is None
    assert re.search(r"px4 x: offset slope up to 9\.\d mg/°C, beyond 8 mg/°C", " ".join(imu_doc["flags"]["px4"]))
    assert "flagged (not recommended, not exported without --force)" in done.stdout
    for fmt in ("px4", "ardupilot"):
        out = tmp_path / f"steep.{fmt}"
        refused = cli("firmware", str(cal), "--format", fmt, "--device-id", "7", "-o", str(out))
        assert refused.returncode == 2 and not out.exists()
        assert refused.stderr.count("\n") == 1 and "flagged" in refused.stderr and "--force" in refused.stderr
    forced = cli("firmware", str(cal), "--format", "px4", "--device-id", "7", "--force",
                     "-o", str(tmp_path / "forced.params"))
    assert forced.returncode == 0, forced.stderr


@pytest.mark.parametrize("instance", [-1, 4, 300])
def test_calibrate_refuses_an_imu_instance_no_firmware_has(instance):
    from twin.calibration.instances import CalibrationInputError
    from twin.calibration.workflow import calibrate_imu
    from twin.measurement import ImuLog

    imu = chamber_run(n=400, rate_hz=1.0, seed=7)[0]
    log = ImuLog(imu.time_us * 1e-6, imu.temperature_c.astype(float), imu.accel_ms2 / G_MS2, instance=instance,
                 source="table.csv")
    with pytest.raises(CalibrationInputError, match=rf"^table\.csv instance {instance}: IMU instance {instance}; "
                                                    r"PX4 has TC_A0\.\.TC_A3 and ArduPilot INS_TCAL1\.\.INS_TCAL3"):
        calibrate_imu([log])


def test_a_table_with_gyro_writes_the_gyro_for_px4_only_with_its_device_id(tmp_path):
    imu = chamber_run(n=600, rate_hz=1.0, seed=8, gyro=True)[0]
    table = tmp_path / "gyro.csv"
    write_table(table, imu.time_us * 1e-6, imu.temperature_c, imu.accel_ms2 / G_MS2, imu.gyro_rad_s)
    columns = _columns(tmp_path)
    columns.write_text(columns.read_text() + "gx: wx\ngy: wy\ngz: wz\n")
    cal = tmp_path / "cal.json"
    assert cli("calibrate", str(table), "--columns", str(columns), "-o", str(cal)).returncode == 0
    params = tmp_path / "tc.params"
    accel_only = cli("firmware", str(cal), "--format", "px4", "--device-id", "7", "-o", str(params))
    assert accel_only.returncode == 0, accel_only.stderr
    assert "accel only: the gyro calibration has no device id" in accel_only.stdout
    assert not any(k.startswith("TC_G") for k in parse_px4_params(params.read_text()).values)
    both = cli("firmware", str(cal), "--format", "px4", "--device-id", "7", "--gyro-device-id", "8",
                   "-o", str(params))
    assert both.returncode == 0, both.stderr
    values = parse_px4_params(params.read_text()).values
    assert values["TC_G0_ID"] == 8 and values["TC_A0_ID"] == 7 and values["TC_G_ENABLE"] == 1


def test_an_ardupilot_log_with_a_board_rotation_gives_no_ardupilot_file(tmp_path):
    """AHRS_ORIENTATION rotates the logged IMU axes into the vehicle's; INS_TCALn corrects before that
    rotation (AP_InertialSensor_Backend::_rotate_and_correct_accel), in the sensor's own axes."""
    log = write_dataflash(tmp_path / "rotated.bin", chamber_run(n=400, rate_hz=1.0, seed=9)[:1],
                          params={"AHRS_ORIENTATION": 2.0})  # ROTATION_YAW_90: x and y swap
    cal = tmp_path / "cal.json"
    done = cli("calibrate", str(log), "-o", str(cal))
    assert done.returncode == 0, done.stderr
    [imu] = strict(cal.read_text())["imus"]
    assert imu["board_orientation"] == 2 and imu["recommended"]["ardupilot"] is None
    assert any("AHRS_ORIENTATION is 2" in f for f in imu["flags"]["ardupilot"])
    for extra in ([], ["--force"]):
        out = tmp_path / "tc.parm"
        refused = cli("firmware", str(cal), "--format", "ardupilot", *extra, "-o", str(out))
        assert refused.returncode == 2 and not out.exists() and "AHRS_ORIENTATION" in refused.stderr
    assert cli("firmware", str(cal), "--format", "px4", "-o", str(tmp_path / "tc.params")).returncode == 0


def test_a_short_cooling_branch_trains_no_fold_and_says_why():
    """25 → 45 °C, then 6 °C of cooling: fitted on the cooling rows, ArduPilot's method (≥ 10 °C of
    range) refused and the whole calibration with it."""
    from twin.calibration.workflow import calibrate_imu
    from twin.measurement import ImuLog

    rng = np.random.default_rng(1)
    t = np.arange(0, 3600, 0.5)
    peak = 25 + 20 * (1 - np.exp(-4))
    temp = np.where(t < 2400, 25 + 20 * (1 - np.exp(-t / 600)), peak - 6 * (1 - np.exp(-(t - 2400) / 300)))
    accel = np.column_stack([0.001 * (temp - 30), -0.0005 * (temp - 30), -1 + 0.0008 * (temp - 30)])
    c = calibrate_imu([ImuLog(t, temp, accel + rng.normal(0, 0.002, accel.shape), 0, 1234, "bench.csv")])
    assert [s.fold for s in c.validation.scores if s.test == "overall"] == ["heating→cooling"] * 6
    assert any("cooling→heating not run: the cooling rows span 5.9 °C < 10 °C" in n for n in c.validation.notes)


def _chamber_log(instance=0, **changes):
    from twin.measurement import ImuLog

    imu = chamber_run(n=600, rate_hz=0.5, seed=10)[0]
    fields = dict(time_s=imu.time_us * 1e-6, temperature_c=imu.temperature_c.astype(float),
                  accel_g=imu.accel_ms2 / G_MS2, instance=instance, source="t.csv")
    return ImuLog(**{**fields, **changes})


@pytest.mark.parametrize("change, fragment", [
    ({"temperature_c": "kelvin"}, r"\(median 3\d\d\.\d\) is not an IMU's in °C \(a median above 150 looks like kelvin\)"),
    ({"accel_g": "zero"}, r"acceleration median \|a\| 0 g; expected about 1 g"),
])
def test_calibrate_refuses_temperatures_not_in_celsius_and_logs_without_gravity(change, fragment):
    from twin.calibration.instances import CalibrationInputError
    from twin.calibration.workflow import calibrate_imu

    log = _chamber_log()
    values = {"kelvin": log.temperature_c + 273.15, "zero": np.zeros_like(log.accel_g)}
    key = next(iter(change))
    with pytest.raises(CalibrationInputError, match=fragment):
        calibrate_imu([_chamber_log(**{key: values[change[key]]})])


def test_a_method_no_fold_can_fit_is_flagged_as_not_validated():
    """20 → 30.5 °C: the whole log passes the 10 °C gate, the interleaved training blocks do not."""
    from twin.calibration.workflow import calibrate_imu

    log = _chamber_log()
    t = log.time_s
    c = calibrate_imu([_chamber_log(temperature_c=20.0 + 10.5 * (t - t[0]) / np.ptp(t))])
    assert "ardupilot" not in c.validation.methods and c.recommended()["ardupilot"] is None
    assert any("not validated" in f for f in c.flags["ardupilot"])
    assert c.recommended()["px4"] == "px4"


def test_a_slowly_turning_board_is_not_still():
    from twin.measurement.quality import assess_log

    t = np.arange(0.0, 2000.0, 1.0)
    angle = np.radians(0.05 * t)  # 100° in 2000 s: σ and |a| stay steady
    a = np.column_stack([0 * t, np.sin(angle), -np.cos(angle)]) + np.random.default_rng(2).normal(0, 1e-3, (t.size, 3))
    q = assess_log(_chamber_log(time_s=t, temperature_c=5 + 0.03 * t, accel_g=a))
    assert q.static_s == 0 and "turning: the gravity direction moves" in q.stretches[0].reason


def test_apply_refuses_an_applied_g_the_log_contradicts(tmp_path):
    log = write_dataflash(tmp_path / "level.bin", chamber_run(n=400, rate_hz=1.0, seed=12)[:1])
    cal = tmp_path / "cal.json"
    assert cli("calibrate", str(log), "-o", str(cal)).returncode == 0
    out = tmp_path / "applied.csv"
    refused = cli("apply", str(cal), str(log), "--applied-g", "0,0,1", "-o", str(out))
    assert refused.returncode == 2 and not out.exists()
    assert re.search(r"--applied-g gives z = \+1 g, but the compensated log reads -1\.0\d g", refused.stderr)
    assert cli("apply", str(cal), str(log), "--applied-g", "0,0,-1", "-o", str(out)).returncode == 0


def test_a_dataflash_gyro_logged_as_zeros_is_no_gyro(tmp_path):
    imus = chamber_run(n=400, rate_hz=1.0, seed=13, gyro=True)[:1]
    zeros = [ImuTruth(**{**vars(imus[0]), "gyro_rad_s": np.zeros_like(imus[0].gyro_rad_s)})]
    log = write_dataflash(tmp_path / "zeros.bin", zeros)
    cal = tmp_path / "cal.json"
    assert cli("calibrate", str(log), "-o", str(cal)).returncode == 0
    assert "gyro" not in strict(cal.read_text())["imus"][0]
    parm = tmp_path / "tc.parm"
    assert cli("firmware", str(cal), "--format", "ardupilot", "-o", str(parm)).returncode == 0
    assert "GYR" not in parm.read_text()
