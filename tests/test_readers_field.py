"""Flight-log and table readers carry the gyro and both device ids, read older ArduPilot
DataFlash spellings (TimeMS, Temp), and turn bad fields or parameters into one line or a note."""

import dataclasses
import math

import numpy as np
import pytest

from logfixtures import (DEVICE_IDS, G_MS2, GYRO_DEVICE_IDS, chamber_run, rewrite_with_pyulog, write_dataflash,
                         write_ulog)
import twin.measurement as tm


@pytest.fixture(scope="module")
def truth():
    return chamber_run(n=150, gyro=True)


def _one_line(exc_info, path, *fragments):
    msg = str(exc_info.value)
    assert msg.startswith(str(path)) and "\n" not in msg, msg
    for fragment in fragments:
        assert fragment in msg, msg
    return msg


# ---- gyro and device ids come back exactly --------------------------------------------------

WRITERS = {
    "dataflash I": lambda d, t: write_dataflash(d / "g.bin", t, instance_field="I"),
    "dataflash IMU/IMU2/IMU3": lambda d, t: write_dataflash(d / "g.bin", t, instance_field=None),
    "ulog": lambda d, t: write_ulog(d / "g.ulg", t),
    "ulog (pyulog write_ulog)": lambda d, t: rewrite_with_pyulog(write_ulog(d / "g.ulg", t), d / "r.ulg"),
}


@pytest.mark.parametrize("writer", WRITERS)
def test_gyro_and_both_device_ids_round_trip(tmp_path, truth, writer):
    logs = tm.read_imu_logs(WRITERS[writer](tmp_path, truth))
    assert [g.device_id for g in logs] == list(DEVICE_IDS)
    assert [g.gyro_device_id for g in logs] == list(GYRO_DEVICE_IDS)
    for log, imu in zip(logs, truth):
        assert log.has_gyro and log.gyro_rad_s.shape == (150, 3)
        np.testing.assert_array_equal(log.gyro_rad_s.astype(np.float32), imu.gyro_rad_s)  # float32 as stored
        np.testing.assert_allclose(log.accel_g * G_MS2, imu.accel_ms2, rtol=2e-7, atol=0)
        assert not any("device id unknown" in n for n in log.notes)


def test_dataflash_tclr_keeps_the_sensor_type(tmp_path, truth):
    logs = tm.read_imu_logs(write_dataflash(tmp_path / "t.bin", truth, tclr_every=30))
    for log, imu in zip(logs, truth):
        tclr = log.records["TCLR"]
        gyro = tclr["sensor_type"] == 1
        assert set(np.unique(tclr["sensor_type"])) == {0.0, 1.0} and gyro.sum() == 5 and (~gyro).sum() == 5
        np.testing.assert_array_equal(tclr["x"][gyro].astype(np.float32), imu.gyro_rad_s[29::30, 0])
        np.testing.assert_array_equal(tclr["x"][~gyro].astype(np.float32), imu.accel_ms2[29::30, 0])
        assert any("10 TCLR record(s)" in n and "5 accelerometer, 5 gyro" in n for n in log.notes)


# ---- older ArduPilot spellings --------------------------------------------------------------

def test_old_dataflash_names_are_read_with_times_in_seconds(tmp_path, truth):
    logs = tm.read_imu_logs(write_dataflash(tmp_path / "old.bin", truth, old_names=True))
    assert [g.instance for g in logs] == [0, 1, 2]
    for log, imu in zip(logs, truth):
        np.testing.assert_allclose(log.time_s, (imu.time_us // 1000) * 1e-3, rtol=0, atol=1e-12)  # TimeMS [ms]
        assert 1.0 <= log.time_s[0] < 1.001 and np.diff(log.time_s).min() == pytest.approx(1.0)
        np.testing.assert_array_equal(log.temperature_c.astype(np.float32), imu.temperature_c)  # from Temp
        np.testing.assert_array_equal(log.gyro_rad_s.astype(np.float32), imu.gyro_rad_s)
        np.testing.assert_allclose(log.accel_g * G_MS2, imu.accel_ms2, rtol=2e-7, atol=0)


def test_an_old_log_without_temperature_is_one_line(tmp_path, truth, capfd):
    path = write_dataflash(tmp_path / "notemp.bin", truth, old_names=True, with_temperature=False)
    with pytest.raises(tm.MeasurementError) as exc:
        tm.read_imu_logs(path)
    _one_line(exc, path, "IMU messages have no field(s) T or Temp", "expected TimeUS (or TimeMS), AccX, AccY, AccZ, "
                                                                    "T (or Temp)")
    assert capfd.readouterr() == ("", "")


TEXT_LAYOUTS = {
    "AccX": ("QBNfff", "TimeUS,I,AccX,AccY,AccZ,T"),
    "T": ("QBfffN", "TimeUS,I,AccX,AccY,AccZ,T"),
    "GyrY": ("QBfffffnf", "TimeUS,I,AccX,AccY,AccZ,T,GyrX,GyrY,GyrZ"),
    "I": ("QNffff", "TimeUS,I,AccX,AccY,AccZ,T"),
}


@pytest.mark.parametrize("field", TEXT_LAYOUTS)
def test_a_text_typed_field_is_one_line(tmp_path, truth, field, capfd):
    path = write_dataflash(tmp_path / "text.bin", truth, imu_layout=TEXT_LAYOUTS[field])
    with pytest.raises(tm.MeasurementError) as exc:
        tm.read_imu_logs(path)
    _one_line(exc, path, f"field {field} holds text", "expected a")
    assert capfd.readouterr() == ("", "")


# ---- device-id parameters that cannot be ids -------------------------------------------------

@pytest.mark.parametrize("value", [math.nan, 1e20, -1.0, 2.5, math.inf, 2.0**33])
def test_a_bad_device_id_parameter_is_unknown_with_a_note(tmp_path, truth, value):
    path = write_dataflash(tmp_path / "ids.bin", truth, params={"INS_ACC_ID": value, "INS_GYR2_ID": value})
    logs = tm.read_imu_logs(path)
    assert logs[0].device_id is None and logs[0].gyro_device_id == GYRO_DEVICE_IDS[0]
    assert logs[1].device_id == DEVICE_IDS[1] and logs[1].gyro_device_id is None
    assert logs[2].device_id == DEVICE_IDS[2] and logs[2].gyro_device_id == GYRO_DEVICE_IDS[2]
    [note] = [n for n in logs[0].notes if "device id unknown" in n]
    assert "parameter INS_ACC_ID" in note and "expected a whole number from 0 to 4294967295" in note
    assert any("parameter INS_GYR2_ID" in n for n in logs[1].notes)
    assert not any("device id unknown" in n for n in logs[2].notes)


def test_a_zero_device_id_means_no_sensor_without_a_note(tmp_path, truth):
    [log, *_] = tm.read_imu_logs(write_dataflash(tmp_path / "zero.bin", truth, params={"INS_ACC_ID": 0.0}))
    assert log.device_id is None and not any("device id unknown" in n for n in log.notes)


# ---- ULog: the gyro onto the accelerometer rows ----------------------------------------------

def _ramp_gyro(imu, offset_us: int, rows: slice = slice(None)):
    """``imu`` with a gyro that is linear in time, sampled ``offset_us`` after the accelerometer."""
    t_us = (imu.time_us[rows] + offset_us).astype(np.uint64)
    t_s = t_us.astype(float) * 1e-6
    rate = np.column_stack([0.01 * t_s, -0.02 * t_s, 0.5 + 0.0 * t_s]).astype(np.float32)
    return dataclasses.replace(imu, gyro_rad_s=rate, gyro_time_us=t_us, gyro_device_id=77)


def test_ulog_gyro_is_interpolated_onto_the_accelerometer_rows(tmp_path, truth):
    shifted = [_ramp_gyro(imu, 400_000) for imu in truth]
    logs = tm.read_imu_logs(write_ulog(tmp_path / "shift.ulg", shifted))
    for log, imu in zip(logs, shifted):
        gyro_t = imu.gyro_time_us.astype(float) * 1e-6
        expected = np.column_stack([np.interp(log.time_s, gyro_t, imu.gyro_rad_s[:, k].astype(float))
                                    for k in range(3)])
        np.testing.assert_allclose(log.gyro_rad_s, expected, rtol=1e-12, atol=0)
        # the ramp is linear, so inside the gyro's span the interpolation is the ramp itself
        np.testing.assert_allclose(log.gyro_rad_s[1:, 0], 0.01 * log.time_s[1:], rtol=1e-6)
        assert log.gyro_device_id == 77 and log.device_id == imu.device_id
        assert not any("gyro" in n for n in log.notes)


def test_ulog_gyro_covering_too_few_rows_is_left_out_with_a_note(tmp_path, truth):
    short = [_ramp_gyro(truth[0], 0, slice(0, 120))]  # 80 % of the accelerometer rows
    [log] = tm.read_imu_logs(write_ulog(tmp_path / "short.ulg", short))
    assert log.gyro_rad_s is None and log.gyro_device_id == 77
    assert any("covers 80.0 % of the accelerometer rows" in n and "gyro left out" in n for n in log.notes)


def test_ulog_gyro_ending_early_leaves_nan_past_its_span(tmp_path, truth):
    mostly = [_ramp_gyro(truth[0], 0, slice(0, 140))]  # 93 % of the rows
    [log] = tm.read_imu_logs(write_ulog(tmp_path / "mostly.ulg", mostly))
    assert np.isfinite(log.gyro_rad_s[:140]).all() and np.isnan(log.gyro_rad_s[140:]).all()
    assert any("10 accelerometer row(s) outside the gyro's time span" in n for n in log.notes)


def test_ulog_gyro_matches_by_multi_id(tmp_path, truth):
    only_second = [dataclasses.replace(truth[0], gyro_rad_s=None), truth[1]]
    logs = tm.read_imu_logs(write_ulog(tmp_path / "one.ulg", only_second))
    assert logs[0].gyro_rad_s is None and logs[0].gyro_device_id is None
    np.testing.assert_array_equal(logs[1].gyro_rad_s.astype(np.float32), truth[1].gyro_rad_s)


# ---- logs without a gyro ---------------------------------------------------------------------

NO_GYRO = {
    "ulog without sensor_gyro": lambda d, t: write_ulog(d / "n.ulg", t, with_gyro=False),
    "ulog of a gyro-less run": lambda d, t: write_ulog(d / "n.ulg", chamber_run(n=150)),
    "dataflash layout without GyrX..Z": lambda d, t: write_dataflash(d / "n.bin", t, instance_field="Instance"),
}


@pytest.mark.parametrize("writer", NO_GYRO)
def test_a_log_without_gyro_has_gyro_none(tmp_path, truth, writer):
    logs = tm.read_imu_logs(NO_GYRO[writer](tmp_path, truth))
    assert len(logs) == 3 and all(g.gyro_rad_s is None and not g.has_gyro for g in logs)
    assert all(len(g) == 150 for g in logs)


# ---- delimited and Parquet tables with gyro columns -----------------------------------------

def _table(tmp_path, n=60):
    t = np.arange(n) * 0.5
    temp = np.linspace(-10.0, 50.0, n)
    acc = np.column_stack([0.001 * temp, -0.002 * temp, -1.0 + 1e-4 * temp])
    gyro_deg_s = np.column_stack([np.sin(t), 2.0 * np.cos(t), 0.1 * temp])
    path = tmp_path / "imu.csv"
    rows = np.column_stack([t, temp, acc, gyro_deg_s])
    header = "t,temp,ax,ay,az,wx,wy,wz"
    np.savetxt(path, rows, delimiter=",", header=header, comments="", fmt="%.9g")
    return path, np.loadtxt(path, delimiter=",", skiprows=1)  # the values as written


def test_delimited_gyro_columns_in_deg_s_become_rad_s(tmp_path):
    path, rows = _table(tmp_path)
    cmap_file = tmp_path / "columns.yaml"
    cmap_file.write_text("time: t\ntemperature: temp\nx: ax\ny: ay\nz: az\ngx: wx\ngy: wy\ngz: wz\n"
                         "gyro_unit: deg/s\n")
    [log] = tm.read_imu_logs(path, tm.ColumnMap.from_yaml(cmap_file))
    np.testing.assert_allclose(log.gyro_rad_s, np.deg2rad(rows[:, 5:8]), rtol=1e-14, atol=0)
    np.testing.assert_allclose(log.accel_g, rows[:, 2:5], rtol=1e-14, atol=0)
    [rad] = tm.read_imu_logs(path, tm.ColumnMap(time="t", temperature="temp", x="ax", y="ay", z="az",
                                                gx="wx", gy="wy", gz="wz"))
    np.testing.assert_allclose(rad.gyro_rad_s, rows[:, 5:8], rtol=1e-14, atol=0)  # rad/s is the default
    [none] = tm.read_imu_logs(path, tm.ColumnMap(time="t", temperature="temp", x="ax", y="ay", z="az"))
    assert none.gyro_rad_s is None


def test_parquet_gyro_columns_read_as_delimited_ones(tmp_path):
    import pyarrow.csv
    import pyarrow.parquet

    path, rows = _table(tmp_path)
    pq = tmp_path / "imu.parquet"
    pyarrow.parquet.write_table(pyarrow.csv.read_csv(path), pq)
    cmap = tm.ColumnMap(time="t", temperature="temp", x="ax", y="ay", z="az", gx="wx", gy="wy", gz="wz",
                        gyro_unit="deg/s")
    [log] = tm.read_imu_logs(pq, cmap)
    np.testing.assert_allclose(log.gyro_rad_s, np.deg2rad(rows[:, 5:8]), rtol=1e-14, atol=0)


@pytest.mark.parametrize("overrides, fragment", [
    (dict(gx="wx", gy="wy"), "column map sets gx, gy but not gz; a gyro needs gx, gy and gz"),
    (dict(gx="wx", gy="wy", gz="wz", gyro_unit="rpm"), "gyro_unit: got 'rpm', expected one of rad/s, deg/s"),
    (dict(gx="wx", gy="wy", gz="wzz"), "no z gyro column 'wzz'; did you mean 'wz'?"),
])
def test_bad_gyro_columns_are_one_line(tmp_path, overrides, fragment):
    path, _ = _table(tmp_path)
    cmap = tm.ColumnMap(time="t", temperature="temp", x="ax", y="ay", z="az", **overrides)
    with pytest.raises(tm.MeasurementError) as exc:
        tm.read_imu_logs(path, cmap)
    assert fragment in str(exc.value) and "\n" not in str(exc.value)


# ---- joining runs -----------------------------------------------------------------------------

def test_concatenated_runs_carry_the_gyro_only_when_every_run_has_one(tmp_path, truth):
    with_gyro = tm.read_imu_logs(write_dataflash(tmp_path / "a.bin", truth))[1]
    without = tm.read_imu_logs(write_dataflash(tmp_path / "b.bin", truth, instance_field="Instance"))[1]
    both = tm.concatenate_imu_logs([with_gyro, with_gyro])
    assert len(both) == 300 and both.gyro_device_id == GYRO_DEVICE_IDS[1] and both.device_id == DEVICE_IDS[1]
    np.testing.assert_array_equal(both.gyro_rad_s, np.concatenate([with_gyro.gyro_rad_s] * 2))
    assert (np.diff(both.time_s) > 0).all() and both.records["TCLR"]["time_s"].size == 2 * 6
    mixed = tm.concatenate_imu_logs([with_gyro, without])
    assert mixed.gyro_rad_s is None and any("1 of 2 runs have a gyro" in n for n in mixed.notes)
    np.testing.assert_array_equal(mixed.accel_g, np.concatenate([with_gyro.accel_g, without.accel_g]))
