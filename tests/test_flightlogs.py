"""Flight logs: PX4 ULog and ArduPilot DataFlash read back known arrays, every IMU instance, and
bad files fail in one line naming the file."""

import numpy as np
import pytest

from conftest import SHARED
from logfixtures import (DEVICE_IDS, G_MS2, chamber_run, cubic_offset_ms2, rewrite_with_pyulog, write_dataflash,
                         write_ulog)
import twin.measurement as tm

REAL_ULOG = SHARED / "data" / "real" / "px4_pyulog_sample" / "sample_log_small.ulg"


@pytest.fixture(scope="module")
def truth():
    return chamber_run()


def _ulog(tmp_path, truth):
    return write_ulog(tmp_path / "chamber.ulg", truth)


WRITERS = {
    "ulog (spec writer)": _ulog,
    "ulog (pyulog write_ulog)": lambda d, t: rewrite_with_pyulog(_ulog(d, t), d / "rewritten.ulg"),
    "dataflash I (ArduPilot >= 4.1)": lambda d, t: write_dataflash(d / "chamber.bin", t, instance_field="I"),
    "dataflash Instance": lambda d, t: write_dataflash(d / "chamber.bin", t, instance_field="Instance"),
    "dataflash IMU/IMU2/IMU3 (pre-4.1)": lambda d, t: write_dataflash(d / "chamber.bin", t, instance_field=None),
}


@pytest.mark.parametrize("writer", WRITERS)
def test_round_trip_of_known_arrays(tmp_path, truth, writer):
    logs = tm.read_imu_logs(WRITERS[writer](tmp_path, truth))
    assert [g.instance for g in logs] == [0, 1, 2]
    assert [g.device_id for g in logs] == list(DEVICE_IDS)
    for log, imu in zip(logs, truth):
        np.testing.assert_array_equal(np.round(log.time_s * 1e6).astype(np.uint64), imu.time_us)
        np.testing.assert_array_equal(log.temperature_c.astype(np.float32), imu.temperature_c)
        np.testing.assert_allclose(log.accel_g * G_MS2, imu.accel_ms2, rtol=2e-7, atol=0)  # float32 precision
        assert log.accel_g.shape == (400, 3) and log.axes == ("x", "y", "z")


def test_the_known_physics_survives_the_round_trip(tmp_path, truth):
    logs = tm.read_imu_logs(_ulog(tmp_path, truth))
    heated = logs[0].temperature_c.mean() - logs[1].temperature_c.mean()
    assert heated == pytest.approx(15.0, abs=0.5)  # instance 0 sits on the heater
    for log in logs:
        expected = cubic_offset_ms2(log.temperature_c) + np.array([0.0, 0.0, -G_MS2])
        assert np.std(log.accel_g * G_MS2 - expected) < 3e-3  # only the simulated 2e-3 m/s² noise is left
        assert tm.usable_for_calibration(log) == (True, f"{log.source} instance {log.instance}: 400 samples over "
                                                        f"{log.temperature_range_c:.2f} °C")


def test_an_axis_is_a_single_axis_measurement(tmp_path, truth):
    [log, *_] = tm.read_imu_logs(_ulog(tmp_path, truth))
    z = log.axis("z")
    assert isinstance(z, tm.Measurement) and not z.applied_known and np.isnan(z.applied_g).all()
    assert z.output_g.mean() == pytest.approx(-1.0, abs=0.01) and z.runs == 1
    assert log.axis("x", applied_g=0.0).applied_known
    with pytest.raises(tm.MeasurementError, match="no axis 'w'"):
        log.axis("w")


def test_load_measurements_picks_an_axis_and_an_instance(tmp_path, truth):
    f = write_dataflash(tmp_path / "chamber.bin", truth)
    m = tm.load_measurements([f], applied_g=-1.0)
    np.testing.assert_allclose(m.output_g * G_MS2, truth[0].accel_ms2[:, 2], rtol=2e-7)
    assert any("3 IMU instances; compared instance 0, axis z" in n for n in m.notes)
    y2 = tm.load_measurements([f], applied_g="unknown", axis="y", instance=2)
    np.testing.assert_allclose(y2.output_g * G_MS2, truth[2].accel_ms2[:, 1], rtol=2e-7)
    with pytest.raises(tm.MeasurementError, match="no IMU instance 5; instances are 0, 1, 2"):
        tm.load_measurements([f], instance=5)


def test_dataflash_keeps_tclr_records(tmp_path, truth):
    logs = tm.read_imu_logs(write_dataflash(tmp_path / "chamber.bin", truth, tclr_every=40))
    for log, imu in zip(logs, truth):
        tclr = log.records["TCLR"]
        assert tclr["time_s"].size == 10 and any("10 TCLR record(s)" in n for n in log.notes)
        np.testing.assert_array_equal(tclr["temperature_c"].astype(np.float32), imu.temperature_c[39::40])
    assert "TCLR" not in tm.read_imu_logs(write_dataflash(tmp_path / "plain.bin", truth, tclr_every=0))[0].records


def test_usable_for_calibration_refuses_short_or_flat_logs(tmp_path, truth):
    log = tm.read_imu_logs(_ulog(tmp_path, truth))[1]
    short = tm.ImuLog(log.time_s[:50], log.temperature_c[:50], log.accel_g[:50], 1, log.device_id, log.source)
    ok, reason = tm.usable_for_calibration(short)
    assert not ok and "50 samples < 100" in reason and "°C < 10 °C" not in reason
    with pytest.raises(tm.MeasurementError, match="not usable for temperature calibration"):
        tm.usable_for_calibration(short, raise_error=True)
    flat = tm.ImuLog(log.time_s, np.full(len(log), 25.0), log.accel_g, 1, None, log.source)
    assert "temperature range 0.00 °C < 10 °C" in tm.usable_for_calibration(flat)[1]


def _cut(path, n_bytes):
    data = path.read_bytes()
    path.write_bytes(data[:n_bytes])
    return path


BAD = {
    "ulog without sensor_accel": (lambda d, t: write_ulog(d / "b.ulg", t, with_accel=False),
                                  "no 'sensor_accel' topic (accelerometer data); the log has cpuload"),
    "bin without IMU": (lambda d, t: write_dataflash(d / "b.bin", t, with_imu=False), "no IMU messages"),
    "empty ulog": (lambda d, t: _cut(write_ulog(d / "b.ulg", t), 0), "empty file; expected a PX4 ULog file"),
    "empty bin": (lambda d, t: _cut(write_dataflash(d / "b.bin", t), 0), "empty file; expected a DataFlash"),
    "ulog cut in its signature": (lambda d, t: _cut(write_ulog(d / "b.ulg", t), 5), "truncated: 5 byte(s)"),
    "ulog cut before its data": (lambda d, t: _cut(write_ulog(d / "b.ulg", t), 200), "no logged data (truncated"),
    "bin cut in its signature": (lambda d, t: _cut(write_dataflash(d / "b.bin", t), 1), "truncated: 1 byte(s)"),
    "bin cut before its data": (lambda d, t: _cut(write_dataflash(d / "b.bin", t), 300), "no IMU messages"),
    "a .bin named .ulg": (lambda d, t: write_dataflash(d / "b.ulg", t), "not a PX4 ULog file (starts with a395"),
}


@pytest.mark.parametrize("case", BAD)
def test_bad_flight_logs_fail_in_one_line(tmp_path, truth, case, capfd):
    make, fragment = BAD[case]
    path = make(tmp_path, truth)
    with pytest.raises(tm.MeasurementError) as exc:
        tm.read_imu_logs(path)
    msg = str(exc.value)
    assert msg.startswith(str(path)) and fragment in msg and "\n" not in msg
    out, err = capfd.readouterr()
    assert out == "" and err == ""  # pyulog's and pymavlink's own prints are kept out of the terminal


@pytest.mark.parametrize("suffix", [".ulg", ".bin"])
def test_a_log_cut_mid_data_keeps_its_complete_messages(tmp_path, truth, suffix):
    writer = write_ulog if suffix == ".ulg" else write_dataflash
    path = writer(tmp_path / f"cut{suffix}", truth)
    _cut(path, path.stat().st_size // 2 + 7)  # a power loss mid-message
    logs = tm.read_imu_logs(path)
    assert len(logs) == 3 and all(150 < len(g) < 250 for g in logs)


@pytest.mark.skipif(not REAL_ULOG.is_file(), reason="shared real data not present")
def test_real_px4_ulog_is_read_and_refused_for_calibration():
    logs = tm.read_imu_logs(REAL_ULOG)
    assert [(g.instance, g.device_id, len(g)) for g in logs] == [(0, 2424842, 6), (1, 3670050, 6), (2, 2621474, 6)]
    ranges = [(round(g.temperature_c.min(), 2), round(g.temperature_c.max(), 2)) for g in logs]
    assert ranges == [(40.03, 40.36), (28.25, 28.37), (29.43, 29.72)]  # instance 0: the heated IMU
    assert all(np.abs(g.accel_g[:, 2] + 1.0).max() < 0.03 for g in logs)  # static board, z ≈ −1 g (FRD)
    ok, reason = tm.usable_for_calibration(logs[0])
    assert not ok
    assert reason == (f"{REAL_ULOG} instance 0: not usable for temperature calibration: 6 samples < 100, "
                      "temperature range 0.34 °C < 10 °C")
