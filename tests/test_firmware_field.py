"""twin.firmware in the field: values checked as the firmware holds them, gyro calibrations, files
verified as the loader reads them, and what the vehicle applies (PX4's republish rule).

Sources followed: PX4/PX4-Autopilot Tools/process_sensor_caldata.py (gyro fit, no median removed),
src/modules/temperature_compensation/TemperatureCompensation.cpp (calc_thermal_offsets_3D,
update_offsets_accel/_gyro, set_sensor_id) and TemperatureCompensationModule.cpp (1 s schedule);
ArduPilot/ardupilot Tools/scripts/tempcal_IMU.py and
libraries/AP_InertialSensor/AP_InertialSensor_tempcal.cpp (TCal::correct_sensor, correct_gyro).
"""

import numpy as np
import pytest

from twin.errors import TwinError
from twin.firmware import (
    FLOAT32_MAX,
    ArduPilotAccelCal,
    ArduPilotGyroCal,
    FirmwareValueError,
    FirmwareVerifyError,
    Px4AccelCal,
    Px4GyroCal,
    applied_vs_ideal,
    ardupilot_cal_from_parm,
    ardupilot_parm_text,
    ardupilot_vehicle_correct,
    ardupilot_vehicle_offsets,
    c_header,
    checked_ardupilot_parm_text,
    checked_px4_params_text,
    firmware_offset_px4,
    fit_ardupilot,
    fit_ardupilot_gyro,
    fit_polynomial_heldout,
    fit_px4,
    fit_px4_gyro,
    parse_ardupilot_parm,
    parse_px4_params,
    px4_cal_from_params,
    px4_cal_from_polynomial,
    px4_params_text,
    px4_republish_lag_c,
    px4_vehicle_offsets,
    read_ardupilot_parm,
    read_px4_params,
    verify_ardupilot_parm,
    verify_px4_params,
    write_ardupilot_parm,
    write_c_header,
    write_json_cal,
    write_px4_params,
)

EPS32 = float(np.finfo(np.float32).eps)
# known gyro bias per axis, ascending powers of (T − 15 °C), rad/s/°C^k; X0 is the absolute bias
TRUE_G = np.array([[2e-3, 1e-4, -2e-6, 3e-8],
                   [-1e-3, -5e-5, 1e-6, -2e-8],
                   [5e-4, 2e-4, 3e-6, 1e-8]])
TREF_C = 15.0
# known ArduPilot gyro terms: coefficients of (T − 35 °C)^1..3, rad/s/°C^k
TRUE_AP_G = np.array([[1e-4, -2e-6, 3e-8], [-5e-5, 1e-6, -2e-8], [2e-4, 3e-6, 1e-8]])


def chamber(t_lo=-20.0, t_hi=50.0, n=30000, soak=2000, rate_hz=10.0):
    """Soak, linear ramp, soak (the PX4 procedure's cold soak then warm-up)."""
    temp = np.concatenate([np.full(soak, t_lo), np.linspace(t_lo, t_hi, n - 2 * soak), np.full(soak, t_hi)])
    return np.arange(n) / rate_hz, temp


def cubic(coef, dt):
    return sum(coef[:, k][None, :] * dt[:, None] ** k for k in range(coef.shape[1]))


@pytest.fixture(scope="module")
def gyro_log():
    time_s, temp = chamber()
    return time_s, temp, cubic(TRUE_G, temp - TREF_C)


@pytest.fixture(scope="module")
def px4_cals(gyro_log):
    _, temp, gyro = gyro_log
    accel = 100.0 * gyro + [0.1, -0.2, 9.80665]
    return fit_px4(temp, accel, device_id=2753036), fit_px4_gyro(temp, gyro, device_id=2753037, instance=0)


@pytest.fixture(scope="module")
def ap_cals():
    time_s, temp = chamber(-10.0, 60.0)
    accel = cubic(np.column_stack([np.zeros(3), 10 * TRUE_AP_G]), temp - 35.0) + [0.1, -0.2, 9.80665]
    gyro = cubic(np.column_stack([[0.01, -0.02, 0.005], TRUE_AP_G]), temp - 35.0)
    return (fit_ardupilot(temp, accel, cal_temp_c=25.0),
            fit_ardupilot_gyro(temp, gyro, cal_temp_c=30.0), (time_s, temp, gyro))


def one_line(info) -> str:
    assert isinstance(info.value, TwinError)
    msg = str(info.value)
    assert "\n" not in msg and msg
    return msg


def replace_x(cal, axis, k, value):
    x = [list(r) for r in cal.x]
    x[axis][k] = value
    return type(cal)(**{**cal.__dict__, "x": tuple(tuple(r) for r in x)})


# ---------------------------------------------------------------- refusals (no file written)

def px4_bad(cal):
    return {
        "inf": (replace_x(cal, 0, 0, float("inf")), r"TC_A0_X0_0 = inf is not finite"),
        "nan_tref": (type(cal)(**{**cal.__dict__, "tref_c": float("nan")}), r"TC_A0_TREF = nan is not finite"),
        "1e45": (replace_x(cal, 1, 1, 1e45), r"TC_A0_X1_1 = 1e\+45 is beyond float32"),
        "tmin_gt_tmax": (type(cal)(**{**cal.__dict__, "tmin_c": 60.0}), r"TC_A0_TMIN = 60 °C is not below"),
        "tmin_eq_tmax": (type(cal)(**{**cal.__dict__, "tmin_c": 50.0}), r"TC_A0_TMIN = 50 °C is not below"),
        # equal once stored: 50 and 50 + 1e-6 are one float32
        "tmin_eq_tmax_f32": (type(cal)(**{**cal.__dict__, "tmin_c": 50.0, "tmax_c": 50.000001}), r"as float32"),
        "degree4": (type(cal)(**{**cal.__dict__, "x": tuple(tuple(r) + (1e-9,) for r in cal.x)}),
                    r"axis x holds 5 coefficients; PX4 applies X0\.\.X3"),
        "degree9": (type(cal)(**{**cal.__dict__, "x": tuple(tuple(r) + (0.0,) * 6 for r in cal.x)}),
                    r"holds 10 coefficients.*never truncated"),
        "instance4": (type(cal)(**{**cal.__dict__, "instance": 4}), r"instance 4 has no TC_A4_\* parameters.*0\.\.3"),
        "instance300": (type(cal)(**{**cal.__dict__, "instance": 300}), r"instance 300 has no TC_A300_\*"),
        "instance-1": (type(cal)(**{**cal.__dict__, "instance": -1}), r"instance -1 has no TC_A-1_\*"),
        "device0": (type(cal)(**{**cal.__dict__, "device_id": 0}),
                    r"TC_A0_ID is 0: PX4 never applies a calibration whose TC_An_ID is 0.*"
                    r"calibrate from a log that records device_id, or pass --device-id"),
        "device_big": (type(cal)(**{**cal.__dict__, "device_id": 2**32}), r"TC_A0_ID = 4294967296 is outside uint32"),
    }


@pytest.mark.parametrize("case", sorted(px4_bad(Px4AccelCal(0, 1, 0.0, 1.0, 0.5, ((0.0,) * 4,) * 3))))
def test_px4_params_refusals_are_one_line_and_write_nothing(px4_cals, tmp_path, case):
    cal, pattern = px4_bad(px4_cals[0])[case]
    path = tmp_path / "tc.params"
    with pytest.raises(FirmwareValueError, match=pattern) as info:
        write_px4_params(path, cal)
    one_line(info)
    assert not path.exists()
    with pytest.raises(FirmwareValueError):  # the text itself is never produced
        px4_params_text(cal)


def test_px4_gyro_refusals_name_the_gyro_parameter(px4_cals, tmp_path):
    accel, gyro = px4_cals
    path = tmp_path / "tc.params"
    with pytest.raises(FirmwareValueError, match=r"TC_G0_X3_2 = inf") as info:
        write_px4_params(path, accel, gyro=replace_x(gyro, 2, 3, float("inf")))
    one_line(info)
    with pytest.raises(FirmwareValueError, match=r"TC_G0_ID is 0: PX4 never applies"):
        write_px4_params(path, accel, gyro=Px4GyroCal(**{**gyro.__dict__, "device_id": 0}))
    assert not path.exists()


def test_a_high_degree_polynomial_is_refused_not_truncated(gyro_log):
    time_s, temp, gyro = gyro_log
    rng = np.random.default_rng(0)
    wiggle = 1e-4 * np.sin(temp / 3.0)[:, None] + rng.normal(0, 1e-7, gyro.shape)  # needs a high order
    fit = fit_polynomial_heldout(time_s, temp, gyro + wiggle, max_order=9)
    assert fit.order > 3
    with pytest.raises(FirmwareValueError, match=rf"holds {fit.order + 1} coefficients; PX4 applies X0\.\.X3") as info:
        px4_cal_from_polynomial(fit, instance=0, device_id=5, sensor="gyro")
    one_line(info)
    low = fit_polynomial_heldout(time_s, temp, gyro[:, :3], max_order=2)  # degree ≤ 3: padded, kept exact
    cal = px4_cal_from_polynomial(low, instance=1, device_id=5)
    t = np.linspace(-30, 60, 91)
    np.testing.assert_array_equal(cal.offset(t), low.offset_m_s2(t))
    values = parse_px4_params(checked_px4_params_text(cal)).values
    assert values["TC_A1_X3_0"] == 0.0


def ap_bad(cal):
    def acc(axis, k, value):
        rows = [list(r) for r in cal.acc]
        rows[axis][k] = value
        return ArduPilotAccelCal(**{**cal.__dict__, "acc": tuple(tuple(r) for r in rows)})

    return {
        "inf": (acc(0, 0, float("inf")), r"INS_TCAL1_ACC1_X = inf is not finite"),
        "1e45": (acc(2, 1, 1e39), r"INS_TCAL1_ACC2_Z = 1e\+45 is beyond float32"),  # 1e39 × 1e6 is stored
        "tmin_gt_tmax": (ArduPilotAccelCal(**{**cal.__dict__, "tmin_c": 70.0}),
                         r"INS_TCAL1_TMIN = 70 °C is not below"),
        "tmin_eq_tmax": (ArduPilotAccelCal(**{**cal.__dict__, "tmin_c": 60.0}),
                         r"INS_TCAL1_TMIN = 60 °C is not below"),
        "degree4": (ArduPilotAccelCal(**{**cal.__dict__, "acc": tuple(tuple(r) + (1e-9,) for r in cal.acc)}),
                    r"holds 4 coefficients; ArduPilot applies exactly ACC1\.\.ACC3.*never truncated"),
        "degree2": (ArduPilotAccelCal(**{**cal.__dict__, "acc": tuple(tuple(r)[:2] for r in cal.acc)}),
                    r"holds 2 coefficients.*expected exactly 3"),
        "instance0": (ArduPilotAccelCal(**{**cal.__dict__, "instance": 0}), r"instance 0 has no INS_TCAL0_\*.*1\.\.3"),
        "instance4": (ArduPilotAccelCal(**{**cal.__dict__, "instance": 4}), r"instance 4 has no INS_TCAL4_\*"),
        "caltemp_inf": (ArduPilotAccelCal(**{**cal.__dict__, "cal_temp_c": float("-inf")}), r"INS_ACC1_CALTEMP = -inf"),
    }


@pytest.mark.parametrize("case", sorted(ap_bad(ArduPilotAccelCal(1, 0.0, 1.0, ((0.0,) * 3,) * 3))))
def test_ardupilot_parm_refusals_are_one_line_and_write_nothing(ap_cals, tmp_path, case):
    cal, pattern = ap_bad(ap_cals[0])[case]
    path = tmp_path / "tcal.parm"
    with pytest.raises(FirmwareValueError, match=pattern) as info:
        write_ardupilot_parm(path, cal)
    one_line(info)
    assert not path.exists()


def test_ardupilot_gyro_must_share_the_imus_range(ap_cals, tmp_path):
    accel, gyro, _ = ap_cals
    other = ArduPilotGyroCal(**{**gyro.__dict__, "tmin_c": gyro.tmin_c + 1.0})
    with pytest.raises(FirmwareValueError, match=r"INS_TCAL1_TMIN/TMAX: accel .* one range for both") as info:
        write_ardupilot_parm(tmp_path / "t.parm", accel, gyro=other)
    one_line(info)
    assert not (tmp_path / "t.parm").exists()


def test_json_and_c_header_refuse_what_a_float32_cannot_hold(px4_cals, tmp_path):
    cal = replace_x(px4_cals[0], 0, 2, 1e45)
    with pytest.raises(FirmwareValueError, match="beyond float32") as info:
        write_json_cal(tmp_path / "c.json", cal)
    one_line(info)
    with pytest.raises(FirmwareValueError, match="beyond float32"):
        write_c_header(tmp_path / "c.h", cal, 100.0)
    with pytest.raises(FirmwareValueError, match="is not below"):
        c_header(Px4AccelCal(**{**px4_cals[0].__dict__, "tmin_c": 50.0}), 100.0)
    assert not (tmp_path / "c.json").exists() and not (tmp_path / "c.h").exists()
    # a JSON record may keep device id 0 (it is not loaded by PX4); FLOAT32_MAX itself is a float32
    write_json_cal(tmp_path / "ok.json", replace_x(Px4AccelCal(**{**px4_cals[0].__dict__, "device_id": 0}),
                                                   0, 3, -FLOAT32_MAX))


# ---------------------------------------------------------------- gyro fits

def test_px4_gyro_fit_recovers_the_known_cubic_with_its_absolute_bias(gyro_log):
    _, temp, gyro = gyro_log
    cal = fit_px4_gyro(temp, gyro, device_id=9, instance=2)
    assert (cal.prefix, cal.tmin_c, cal.tmax_c, cal.tref_c) == ("TC_G2_", -20.0, 50.0, 15.0)
    # Tolerance: the noise-free ramp is monotonic, so medfilt returns the samples (the soaks absorb
    # its zero padding); the only approximation is the 2000-bin resampling, whose bin mean of a
    # smooth f differs from f(mean T) by at most max|f''|·w²/24 for bins of width w = 70/2000 °C.
    w = 70.0 / 2000
    f2 = np.max(np.abs(2 * TRUE_G[:, 2][None, :] + 6 * TRUE_G[:, 3][None, :] * (temp - TREF_C)[:, None]))
    bound = f2 * w ** 2 / 24
    t = np.linspace(-20, 50, 701)
    err = np.max(np.abs(cal.offset_rad_s(t) - cubic(TRUE_G, t - TREF_C)))
    print(f"PX4 gyro fit: max error {err:.2e} rad/s, resampling bound {bound:.2e} rad/s")
    assert err <= 2 * bound  # × 2: the least-squares cubic through the bin means may amplify their bias
    # X0 is the absolute bias at TREF: the script does not subtract the median for the gyro
    np.testing.assert_allclose(np.array(cal.x)[:, 0], TRUE_G[:, 0], atol=2 * bound)
    accel = fit_px4(temp, gyro)  # the accel fit of the same numbers removes the median
    assert np.max(np.abs(np.array(accel.x)[:, 0] - TRUE_G[:, 0])) > 100 * bound


def test_ardupilot_gyro_fit_recovers_the_known_terms_and_anchors_at_gyr_caltemp(ap_cals, tmp_path):
    accel, gyro, (time_s, temp, rate) = ap_cals
    np.testing.assert_allclose(np.array(gyro.gyr), TRUE_AP_G, rtol=1e-7)  # exact cubic, polyfit exact to rounding
    assert (gyro.tmin_c, gyro.tmax_c, gyro.cal_temp_c) == (-10.0, 60.0, 30.0)
    # with the script's 2 s moving average (20 samples of a 0.0027 °C step): the window mean of a
    # smooth f differs from f(window-mean T) by at most max|f''|·var(T in window)/2
    filtered = fit_ardupilot_gyro(temp, rate, time_s=time_s, cal_temp_c=30.0)
    step = 70.0 / 26000
    var = (20 ** 2 - 1) * step ** 2 / 12
    f2 = np.max(np.abs(2 * TRUE_AP_G[:, 1][:, None] + 6 * TRUE_AP_G[:, 2][:, None] * np.array([-45.0, 25.0])))
    t = np.linspace(-10, 60, 301)
    err = np.max(np.abs(filtered.offset_rad_s(t) - gyro.offset_rad_s(t)))
    print(f"ArduPilot gyro fit with the 2 s average: {err:.2e} rad/s, bound {f2 * var / 2:.2e} rad/s")
    assert err <= 2 * f2 * var / 2  # × 2 as for PX4: the least-squares cubic may amplify the bias
    # the firmware removes P(T − 35) − P(INS_GYR1_CALTEMP − 35): nothing at the gyro's own cal temperature
    text = checked_ardupilot_parm_text(accel, gyro=gyro, write_caltemp=True)
    values = parse_ardupilot_parm(text)
    assert values["INS_GYR1_CALTEMP"] == 30.0 and values["INS_ACC1_CALTEMP"] == 25.0
    at_cal = ardupilot_vehicle_correct(values, np.zeros(3), 30.0, sensor="gyro")
    assert np.all(at_cal == 0)
    raw = cubic(np.column_stack([np.zeros(3), TRUE_AP_G]), t - 35.0)
    fw = ardupilot_vehicle_correct(values, raw, t, sensor="gyro").astype(float)
    expected = cubic(np.column_stack([np.zeros(3), TRUE_AP_G]), np.full(1, 30.0 - 35.0))  # the bias at CALTEMP stays
    assert np.max(np.abs(fw - expected)) < 1e-7  # terms ≤ 1e-2 rad/s, float32 ulp ≤ 1e-9: 100 ulp of room


# ---------------------------------------------------------------- writers: gyro lines only with a gyro cal

def test_parm_without_gyro_has_no_gyr_line_and_with_gyro_the_fitted_values(ap_cals, tmp_path):
    accel, gyro, _ = ap_cals
    without = write_ardupilot_parm(tmp_path / "a.parm", accel, write_caltemp=True).read_text()
    assert "GYR" not in without
    assert "INS_TCAL1_ENABLE 1\n" in without
    values = read_ardupilot_parm(write_ardupilot_parm(tmp_path / "g.parm", accel, gyro=gyro))
    for k in (1, 2, 3):
        for i, a in enumerate("XYZ"):
            v = values[f"INS_TCAL1_GYR{k}_{a}"]
            assert v != 0 and v == np.float32(gyro.gyr[i][k - 1] * 1e6)
    back = ardupilot_cal_from_parm(values, 1, cal_temp_c=gyro.cal_temp_c, sensor="gyro")
    t = np.linspace(-30, 80, 221)
    assert np.max(np.abs(back.offset_rad_s(t) - gyro.offset_rad_s(t))) < 1e-9
    fw = ardupilot_vehicle_offsets(values, t, 1, gyro.cal_temp_c, "gyro").astype(float)
    table = applied_vs_ideal(fw, gyro.offset_rad_s(t))
    assert all(row["max_abs"] < 1e-8 for row in table.values())
    assert "GYR" in ardupilot_parm_text(accel, zero_gyro=True)  # erasing the board's gyro terms only on request


def test_params_with_gyro_enable_both_and_never_write_an_uncalibrated_kind(px4_cals, tmp_path):
    accel, gyro = px4_cals
    path = write_px4_params(tmp_path / "tc.params", accel, gyro=gyro)
    back = read_px4_params(path)
    assert back.values["TC_A_ENABLE"] == 1 and back.values["TC_G_ENABLE"] == 1
    assert back.values["TC_G0_ID"] == 2753037 and back.types["TC_G0_X3_2"] == 9
    assert {n for n in back.values if n.startswith("TC_G0_")} == {
        "TC_G0_" + k for k in ["ID", "TMIN", "TMAX", "TREF"] + [f"X{k}_{i}" for k in range(4) for i in range(3)]}
    rows = [ln.split("\t")[2] for ln in path.read_text().splitlines() if not ln.startswith("#")]
    gyro_rows = rows[rows.index("TC_G_ENABLE") + 1:]
    assert gyro_rows == sorted(gyro_rows)  # the script sorts the gyro keys (key_list_gyro.sort())
    t = np.linspace(-40, 70, 441)
    fw = firmware_offset_px4(back.values, t, 0, sensor="gyro").astype(float)
    ideal = gyro.offset_rad_s(t)
    assert np.max(np.abs(fw - ideal)) <= 8 * EPS32 * np.max(np.abs(ideal))  # a few float32 ulp of the offset
    assert px4_cal_from_params(back.values, 0, sensor="gyro").device_id == 2753037
    accel_only = read_px4_params(write_px4_params(tmp_path / "a.params", accel)).values
    assert not any(n.startswith("TC_G") for n in accel_only)
    gyro_only = parse_px4_params(checked_px4_params_text([], gyro=gyro)).values
    assert not any(n.startswith("TC_A") for n in gyro_only) and gyro_only["TC_G_ENABLE"] == 1


# ---------------------------------------------------------------- verification catches a tampered text

def tamper(text, name):
    """``text`` with the first non-zero digit of ``name``'s value changed (a change any float32 sees)."""
    lines = text.split("\n")
    for i, line in enumerate(lines):
        sep = "\t" if "\t" in line else " "
        fields = line.split(sep)
        if name in fields:
            j = fields.index(name) + 1
            d = next(k for k, ch in enumerate(fields[j]) if ch in "123456789")
            fields[j] = fields[j][:d] + str(int(fields[j][d]) % 9 + 1) + fields[j][d + 1:]
            lines[i] = sep.join(fields)
            return "\n".join(lines)
    raise AssertionError(f"{name} not in the text")


def test_verify_functions_catch_one_changed_digit(px4_cals, ap_cals):
    accel, gyro = px4_cals
    text = checked_px4_params_text(accel, gyro=gyro)
    verify_px4_params(text, accel, gyro=gyro)
    for name in ("TC_A0_X1_0", "TC_G0_TMAX", "TC_G0_ID"):
        bad = tamper(text, name)
        with pytest.raises(FirmwareVerifyError, match=name) as info:
            verify_px4_params(bad, accel, gyro=gyro)
        one_line(info)
    # a digit beyond float32 precision loads as the same float32: not a difference on the vehicle
    row = next(ln for ln in text.splitlines() if "\tTC_A0_X1_0\t" in ln)
    value = row.split("\t")[3]
    verify_px4_params(text.replace(row, row.replace(value, value[:-1] + str((int(value[-1]) + 1) % 10))),
                      accel, gyro=gyro)
    with pytest.raises(FirmwareVerifyError, match=r"TC_G.*unexpected"):  # a gyro row the caller did not intend
        verify_px4_params(text, accel)

    ap_accel, ap_gyro, _ = ap_cals
    parm = checked_ardupilot_parm_text(ap_accel, gyro=ap_gyro)
    for name in ("INS_TCAL1_ACC2_Y", "INS_TCAL1_GYR1_Z", "INS_TCAL1_TMIN"):
        bad = tamper(parm, name)
        with pytest.raises(FirmwareVerifyError, match=name) as info:
            verify_ardupilot_parm(bad, ap_accel, gyro=ap_gyro)
        one_line(info)
    with pytest.raises(FirmwareVerifyError, match="GYR.*unexpected"):
        verify_ardupilot_parm(parm, ap_accel)


# ---------------------------------------------------------------- what the vehicle applies (PX4 republish rule)

SLOPE = 1e-3  # m/s²/°C: a linear offset, so the error is exactly SLOPE × the temperature lag


@pytest.fixture(scope="module")
def linear_values():
    cal = Px4AccelCal(0, 42, -40.0, 85.0, 20.0, ((0.0, SLOPE, 0.0, 0.0),) * 3)
    return cal, parse_px4_params(checked_px4_params_text(cal)).values


def steps(applied):
    return np.flatnonzero(np.any(np.diff(applied, axis=0) != 0, axis=1)) + 1


def test_slow_ramp_gives_a_staircase_that_moves_only_after_1c_and_once_a_second(linear_values):
    cal, values = linear_values
    time_s = np.arange(0.0, 600.0, 0.01)  # 100 Hz
    temp = -30.0 + 0.05 * time_s  # 0.05 °C/s
    applied = px4_vehicle_offsets(values, time_s, temp).astype(float)
    assert np.all(applied[0] == 0)  # before the first publication the sensor has no thermal offset
    change = steps(applied)
    assert change.size > 20 and np.all(np.diff(time_s[change]) >= 1.0 - 1e-9)
    # the temperature each step was computed at (to float32 of the offset: < 1e-4 °C)
    published_t = applied[change, 0] / SLOPE + cal.tref_c
    moved = np.diff(published_t)
    assert abs(published_t[0] - temp[0]) < 1e-4  # the first run publishes (last temperature starts at −100 °C)
    assert np.all(moved > 1.0) and np.all(moved < 1.0 + 0.05 * 1.0 + 1e-4)  # > 1 °C, by at most one run
    after = time_s > time_s[0]
    lag = px4_republish_lag_c(time_s, temp)  # 1 °C + 0.05 °C/s × (1 s + 0.01 s)
    table = applied_vs_ideal(applied, cal.offset(temp), after)
    assert lag == pytest.approx(1.0505)
    assert all(SLOPE * 1.0 < row["max_abs"] <= SLOPE * lag + 1e-9 for row in table.values())
    # the rule itself: compensation starts only for the calibrated device id
    assert np.all(px4_vehicle_offsets(values, time_s, temp, device_id=43) == 0)
    np.testing.assert_array_equal(px4_vehicle_offsets(values, time_s, temp, device_id=42), applied)


def test_fast_ramp_lags_by_one_check_period(linear_values):
    cal, values = linear_values
    time_s = np.arange(0.0, 30.0, 0.01)
    rate = 5.0  # °C/s: every run republishes, and each offset is held for the whole second after it
    temp = -30.0 + rate * time_s
    applied = px4_vehicle_offsets(values, time_s, temp).astype(float)
    assert np.allclose(np.diff(time_s[steps(applied)]), 1.0)
    err = np.max(np.abs(applied - cal.offset(temp))[time_s > 0])
    # derived: run k reads the latest sample (taken within one sample interval dt before t_k) and its
    # offset is held until the run at t_k + 1 s, so T has moved rate × (1 s ± dt) by then; float32 of
    # T ≈ 100 °C adds < 1e-5 °C
    dt = 0.01
    print(f"fast ramp: max lag error {err:.3e} m/s² = {err / SLOPE:.4f} °C × slope")
    assert SLOPE * (rate * (1.0 - dt) - 1e-4) <= err <= SLOPE * (rate * (1.0 + dt) + 1e-4)
    assert err <= SLOPE * px4_republish_lag_c(time_s, temp)
    t32 = temp.astype(np.float32).astype(float)  # the firmware's temperature is a float32
    ideal_table = applied_vs_ideal(firmware_offset_px4(values, t32).astype(float), cal.offset(t32))
    # without the republish rule the formula is exact to float32: a few ulp of the largest offset
    assert all(row["max_abs"] <= 4 * EPS32 * SLOPE * 100 for row in ideal_table.values())


def test_gyro_vehicle_offsets_use_tc_g(px4_cals):
    accel, gyro = px4_cals
    values = parse_px4_params(checked_px4_params_text(accel, gyro=gyro)).values
    time_s = np.arange(0.0, 100.0, 0.1)
    temp = 10.0 + 0.3 * time_s
    applied = px4_vehicle_offsets(values, time_s, temp, sensor="gyro", device_id=2753037).astype(float)
    later = time_s > 0
    bound = px4_republish_lag_c(time_s, temp) * np.max(np.abs(cubic(TRUE_G[:, 1:] * [1, 2, 3], temp - TREF_C)))
    assert np.max(np.abs(applied - gyro.offset_rad_s(temp))[later]) <= bound
    assert np.all(px4_vehicle_offsets({**values, "TC_G_ENABLE": 0}, time_s, temp, sensor="gyro") == 0)
