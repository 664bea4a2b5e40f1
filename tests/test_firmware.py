"""twin.firmware: fits as the PX4/ArduPilot scripts do them, exporters, parsers and round trips.

A round trip is: fit → write the file the firmware/ground station reads → parse it back → apply the
firmware's formula (float32, as the firmware source does) → compare with our float64 prediction.
Tolerance 1 µg = 9.80665e-6 m/s², over the calibrated range and 20 °C beyond it (clamping).
"""

import shutil
import subprocess

import numpy as np
import pytest

from twin.errors import TwinError
from twin.firmware import (G0_M_S2, CalibrationFileError, CalibrationRangeError, ardupilot_cal_from_parm,
                           c_header, die_temperature_lag, firmware_correct_ardupilot, firmware_offset_px4,
                           fit_ardupilot, fit_polynomial_heldout, fit_px4, interleaved_folds, lag_alpha,
                           parse_px4_params, px4_cal_from_params, px4_params_text, read_ardupilot_parm,
                           read_json_cal, read_px4_params, resample_by_temperature, write_ardupilot_parm,
                           write_c_header, write_json_cal, write_px4_params)

UG_M_S2 = 1e-6 * G0_M_S2  # 1 µg in m/s²
TREF_C = 15.0
# known offset per axis, ascending powers of (T − 15 °C), m/s²/°C^k; monotonic on −20…50 °C so a
# running median of the noise-free ramp returns the samples themselves
TRUE_PX4 = np.array([[0.02, 1.2e-3, -8e-6, 1.5e-7],
                     [-0.05, -6e-4, 4e-6, -9e-8],
                     [0.08, 2e-3, 1e-5, 2e-7]])
# known ArduPilot polynomial: coefficients of (T − 35 °C)^1..3 per axis, m/s²/°C^k
TRUE_AP = np.array([[1.1e-3, 9e-7, 1.5e-7], [-5.5e-4, -1.4e-6, -9e-8], [2.6e-3, 2.2e-5, 2e-7]])
LEVEL_M_S2 = np.array([0.1, -0.2, G0_M_S2])


def chamber_log(t_lo=-20.0, t_hi=50.0, n=30000, soak=2000, rate_hz=10.0):
    """Soak at t_lo, linear ramp, soak at t_hi (as the PX4 procedure's cold soak then warm-up)."""
    temp = np.concatenate([np.full(soak, t_lo), np.linspace(t_lo, t_hi, n - 2 * soak), np.full(soak, t_hi)])
    return np.arange(n) / rate_hz, temp


def cubic(coef, dt):
    return sum(coef[:, k][None, :] * dt[:, None] ** k for k in range(coef.shape[1]))


@pytest.fixture(scope="module")
def log():
    time_s, temp = chamber_log()
    return time_s, temp, LEVEL_M_S2 + cubic(TRUE_PX4, temp - TREF_C)


@pytest.fixture(scope="module")
def ap_log():
    time_s, temp = chamber_log(-10.0, 60.0)
    accel = LEVEL_M_S2 + cubic(np.column_stack([np.zeros(3), TRUE_AP]), temp - 35.0)
    return time_s, temp, accel


def beyond(cal_tmin, cal_tmax):
    return np.linspace(cal_tmin - 20.0, cal_tmax + 20.0, 2001)


# ---------------------------------------------------------------- PX4

def script_resample(x, y, n_bins=2000):
    """process_sensor_caldata.py resampleWithDeltaX, transcribed loop for loop."""
    x_min, x_max = np.amin(x), np.amax(x)
    interval = (x_max - x_min) / n_bins
    sy, sx, cnt = np.zeros(n_bins), np.zeros(n_bins), np.zeros(n_bins)
    for i in range(len(x)):
        b = 0 if x[i] < x_min else (int((x[i] - x_min) / interval) if x[i] < x_max else n_bins - 1)
        sy[b] += y[i]
        sx[b] += x[i]
        cnt[b] += 1
    keep = cnt != 0
    return sx[keep] / cnt[keep], sy[keep] / cnt[keep]


def test_px4_resampling_matches_the_script_loop():
    rng = np.random.default_rng(1)
    x = np.sort(rng.uniform(-30, 40, 5000)) - 5.0
    y = rng.normal(size=x.size)
    ours, theirs = resample_by_temperature(x, y), script_resample(x, y)
    assert ours[0].size == theirs[0].size < 2000
    np.testing.assert_allclose(ours[0], theirs[0], rtol=0, atol=1e-12)
    np.testing.assert_allclose(ours[1], theirs[1], rtol=0, atol=1e-12)


def test_px4_fit_recovers_the_known_cubic(log):
    _, temp, accel = log
    cal = fit_px4(temp, accel, device_id=2753036)
    assert (cal.tmin_c, cal.tmax_c, cal.tref_c) == (-20.0, 50.0, 15.0)
    x = np.array(cal.x)
    # X1..X3 are the known slopes; X0 is the known one less the median the script removes
    np.testing.assert_allclose(x[:, 1:], TRUE_PX4[:, 1:], rtol=1e-5)
    expected_x0 = TRUE_PX4[:, 0] + LEVEL_M_S2 - np.median(accel, axis=0)
    np.testing.assert_allclose(x[:, 0], expected_x0, atol=1e-8)
    truth = accel - np.median(accel, axis=0)
    assert np.max(np.abs(cal.offset_m_s2(temp) - truth)) < 0.01 * UG_M_S2


def test_px4_params_file_is_what_qgc_reads(log, tmp_path):
    _, temp, accel = log
    cal = fit_px4(temp, accel, device_id=3_000_000_000, instance=1)  # > int32: stored as its bits
    path = write_px4_params(tmp_path / "tcal.params", cal)
    lines = path.read_text().splitlines()
    header = [ln for ln in lines if ln.startswith("#")]
    rows = [ln for ln in lines if not ln.startswith("#")]
    assert header[0] == "# Onboard parameters for Vehicle 1"
    assert header[-1] == "# Vehicle-Id Component-Id Name Value Type"
    assert lines.index(header[-1]) == len(header) - 1  # header first, rows after
    fields = [r.split("\t") for r in rows]
    assert all(len(f) == 5 for f in fields)
    names = [f[2] for f in fields]
    assert names[:6] == ["TC_A_ENABLE", "TC_A1_ID", "TC_A1_TMIN", "TC_A1_TMAX", "TC_A1_TREF", "TC_A1_X0_0"]
    assert names[5:] == [f"TC_A1_X{k}_{i}" for i in range(3) for k in range(4)]
    types = {f[2]: f[4] for f in fields}
    assert types["TC_A_ENABLE"] == types["TC_A1_ID"] == "6"
    assert all(types[n] == "9" for n in names[2:])
    assert all(f[0] == "1" and f[1] == "1" for f in fields)
    back = read_px4_params(path)
    assert back.values["TC_A1_ID"] == np.int32(np.uint32(3_000_000_000).view(np.int32))
    assert px4_cal_from_params(back.values, 1).device_id == 3_000_000_000
    # every REAL32 text reads back to exactly the float32 of the fitted value
    for i in range(3):
        for k in range(4):
            assert np.float32(float(back.values[f"TC_A1_X{k}_{i}"])) == np.float32(cal.x[i][k])


def px4_offset_by_hand(values, temperature_c, n=0):
    """calc_thermal_offsets_3D transcribed with float32 scalars (independent of firmware_offset_px4)."""
    f = np.float32
    g = lambda k: f(values[f"TC_A{n}_{k}"])  # noqa: E731
    t = f(temperature_c)
    if t > g("TMAX"):
        d = g("TMAX") - g("TREF")
    elif t < g("TMIN"):
        d = g("TMIN") - g("TREF")
    else:
        d = t - g("TREF")
    d2 = d * d
    d3 = d2 * d
    return [g(f"X0_{i}") + g(f"X1_{i}") * d + g(f"X2_{i}") * d2 + g(f"X3_{i}") * d3 for i in range(3)]


def test_px4_round_trip_within_1ug(log, tmp_path):
    _, temp, accel = log
    cal = fit_px4(temp, accel, device_id=7)
    values = read_px4_params(write_px4_params(tmp_path / "a.params", cal)).values
    t = beyond(cal.tmin_c, cal.tmax_c)
    firmware = firmware_offset_px4(values, t).astype(float)
    err = np.max(np.abs(firmware - cal.offset_m_s2(t)))
    print(f"PX4 .params round trip: max |firmware − predicted| = {err / UG_M_S2:.2e} µg")
    assert err < UG_M_S2
    for tc in (-40.0, -20.0, 3.3, 15.0, 49.99, 50.0, 70.0):
        np.testing.assert_array_equal(px4_offset_by_hand(values, tc), firmware_offset_px4(values, tc)[0])
    # the correction the firmware applies to a 1 g reading: raw − offset, in float32
    raw = np.float32(G0_M_S2)
    corrected = raw - firmware_offset_px4(values, t)
    assert np.max(np.abs(corrected.astype(float) - cal.correct(np.full((t.size, 3), G0_M_S2), t))) < UG_M_S2
    assert np.all(firmware_offset_px4({**values, "TC_A_ENABLE": 0}, t) == 0)


def test_px4_text_refuses_duplicate_instances_and_parser_names_bad_lines(log):
    _, temp, accel = log
    cal = fit_px4(temp, accel, device_id=7)  # device id 0 is refused by the writer (PX4 would never apply it)
    with pytest.raises(CalibrationFileError):
        px4_params_text([cal, cal])
    bad = px4_params_text(cal).replace("\tTC_A0_TREF\t", " TC_A0_TREF\t")
    with pytest.raises(CalibrationFileError, match=r"<params>:\d+: 4 tab-separated fields"):
        parse_px4_params(bad)


# ---------------------------------------------------------------- ArduPilot

def test_ardupilot_fit_recovers_the_known_polynomial(ap_log):
    time_s, temp, accel = ap_log
    cal = fit_ardupilot(temp, accel)  # no time: no moving average, exact recovery
    np.testing.assert_allclose(np.array(cal.acc), TRUE_AP, rtol=1e-7)
    assert (cal.tmin_c, cal.tmax_c) == (-10.0, 60.0)
    filtered = fit_ardupilot(temp, accel, time_s=time_s)  # the script's 2 s moving average
    t = np.linspace(-10, 60, 301)
    assert np.max(np.abs(filtered.offset_m_s2(t) - cal.offset_m_s2(t))) < 0.01 * UG_M_S2


def test_ardupilot_needs_ten_degrees():
    temp = np.linspace(20.0, 28.0, 500)
    with pytest.raises(CalibrationRangeError) as info:
        fit_ardupilot(temp, np.zeros((500, 3)))
    assert isinstance(info.value, TwinError)
    msg = str(info.value)
    assert "\n" not in msg and "at least 10 °C" in msg and "8.0 °C" in msg


def test_ardupilot_parm_lines_are_the_scripts(ap_log, tmp_path):
    _, temp, accel = ap_log
    cal = fit_ardupilot(temp, accel)
    lines = write_ardupilot_parm(tmp_path / "tcal.parm", cal).read_text().splitlines()
    names = [ln.split(" ")[0] for ln in lines]
    assert names[:3] == ["INS_TCAL1_ENABLE", "INS_TCAL1_TMIN", "INS_TCAL1_TMAX"]
    assert names[3:12] == [f"INS_TCAL1_ACC{k}_{a}" for k in (1, 2, 3) for a in "XYZ"]
    assert len(names) == 12  # no gyro line without a gyro calibration: loading leaves the board's gyro terms alone
    assert all(len(ln.split(" ")) == 2 for ln in lines)
    assert lines[0] == "INS_TCAL1_ENABLE 1" and lines[1] == "INS_TCAL1_TMIN -10.0"
    assert lines[3] == "INS_TCAL1_ACC1_X %.9f" % (cal.acc[0][0] * 1e6)


@pytest.mark.parametrize("cal_temp_c", [25.0, None])
def test_ardupilot_round_trip_within_1ug(ap_log, tmp_path, cal_temp_c):
    _, temp, accel = ap_log
    cal = fit_ardupilot(temp, accel, cal_temp_c=cal_temp_c)
    path = write_ardupilot_parm(tmp_path / "tcal.parm", cal, write_caltemp=cal_temp_c is not None)
    values = read_ardupilot_parm(path)
    back = ardupilot_cal_from_parm(values)
    t = beyond(cal.tmin_c, cal.tmax_c)
    raw = np.tile(LEVEL_M_S2, (t.size, 1))
    firmware = firmware_correct_ardupilot(values, raw, t).astype(float)
    err = np.max(np.abs(firmware - cal.correct(raw, t)))
    print(f"ArduPilot .parm round trip (CALTEMP {cal_temp_c}): max error {err / UG_M_S2:.2e} µg")
    assert err < UG_M_S2
    # the firmware formula in float64, written out here: v − P(clip T − 35) + P(clip Tcal − 35)
    c = np.array(back.acc)
    anchor = np.clip(back.cal_temp_c, back.tmin_c, back.tmax_c)
    poly = lambda x: sum(c[:, k - 1][None, :] * (np.asarray(x)[:, None] - 35.0) ** k for k in (1, 2, 3))  # noqa: E731
    by_hand = raw - poly(np.clip(t, back.tmin_c, back.tmax_c)) + poly(np.full(t.size, anchor))
    assert np.max(np.abs(by_hand - cal.correct(raw, t))) < UG_M_S2
    # zero correction at the calibration temperature (TMIN when INS_ACCn_CALTEMP is unset)
    assert np.max(np.abs(cal.offset_m_s2([anchor]))) < 1e-12


# ---------------------------------------------------------------- held-out polynomial

def test_interleaved_folds_cover_the_record():
    fold = interleaved_folds(np.arange(200.0), folds=5, blocks_per_fold=4)
    assert np.bincount(fold).tolist() == [40] * 5
    assert fold[:10].tolist() == [0] * 10 and fold[10:20].tolist() == [1] * 10 and fold[50] == 0


def test_heldout_polynomial_picks_the_true_order():
    time_s, temp = chamber_log(rate_hz=1.0, n=6000, soak=300)
    temp = np.concatenate([temp[:3000], temp[3000:][::-1]])  # up and down: each fold sees both
    rng = np.random.default_rng(3)
    y = cubic(TRUE_PX4, temp - TREF_C) + rng.normal(0, 2e-4, (temp.size, 3))
    fit = fit_polynomial_heldout(time_s, temp, y, max_order=5)
    assert fit.order == 3 and len(fit.cv_rmse) == 6
    assert fit.cv_rmse[3] < 0.3 * fit.cv_rmse[2]
    t = np.linspace(-20, 50, 71)
    assert np.max(np.abs(fit.offset_m_s2(t) - cubic(TRUE_PX4, t - TREF_C))) < 1e-4


# ---------------------------------------------------------------- JSON

def test_json_round_trip_is_exact(log, ap_log, tmp_path):
    time_s, temp, accel = log
    cals = [fit_px4(temp, accel, device_id=5), fit_ardupilot(*ap_log[1:], cal_temp_c=30.0),
            fit_polynomial_heldout(time_s, temp, accel - LEVEL_M_S2, max_order=4)]
    provenance = {"inputs": {"log.ulg": "sha256:00ff"}, "software": "tde-twin 0.1.0",
                  "validation": {"max_residual_ug": 0.4}}
    for i, cal in enumerate(cals):
        back = read_json_cal(write_json_cal(tmp_path / f"cal{i}.json", cal, provenance))
        assert back.cal == cal and back.provenance == provenance and back.schema_version == 1
        t = beyond(cal.tmin_c, cal.tmax_c)
        np.testing.assert_array_equal(back.cal.offset_m_s2(t), cal.offset_m_s2(t))
    with pytest.raises(CalibrationFileError, match="provenance"):
        write_json_cal(tmp_path / "bad.json", cals[0], {"when": object()})
    (tmp_path / "old.json").write_text('{"schema_version": 0, "kind": "accel_temperature_calibration"}')
    with pytest.raises(CalibrationFileError, match="schema_version 1"):
        read_json_cal(tmp_path / "old.json")


# ---------------------------------------------------------------- C header

MAIN_C = r"""
#include <stdio.h>
#include "cal.h"
int main(void)
{
    float t, off[TWIN_TCAL_N_AXES];
#ifdef TWIN_TCAL_HAS_LAG
    twin_tcal_lag_state lag = {0};
#endif
    while (scanf("%f", &t) == 1) {
#ifdef TWIN_TCAL_HAS_LAG
        t = twin_tcal_lag_update(&lag, t);
#endif
        twin_tcal_offset_m_s2(t, off);
        for (int a = 0; a < TWIN_TCAL_N_AXES; a++) printf("%.9e ", (double)off[a]);
        printf("%.9e\n", (double)t);
    }
    return 0;
}
"""


def run_c(tmp_path, header_text, temps):
    (tmp_path / "cal.h").write_text(header_text)
    (tmp_path / "main.c").write_text(MAIN_C)
    exe = tmp_path / "main"
    subprocess.run(["cc", "-std=c99", "-O2", "-Wall", "-Wextra", "-Werror", "-o", str(exe), "main.c"],
                   cwd=tmp_path, check=True, capture_output=True, text=True)
    stdin = "\n".join("%.9g" % v for v in np.asarray(temps, dtype=np.float32)) + "\n"
    out = subprocess.run([str(exe)], input=stdin, capture_output=True, text=True, check=True).stdout
    return np.loadtxt(out.splitlines(), ndmin=2)


@pytest.mark.skipif(shutil.which("cc") is None, reason="no C compiler")
def test_c_header_compiles_and_matches_python(log, ap_log, tmp_path):
    time_s, temp, accel = log
    cals = {"px4": fit_px4(temp, accel), "ardupilot": fit_ardupilot(*ap_log[1:], cal_temp_c=25.0),
            "polynomial": fit_polynomial_heldout(time_s, temp, accel - LEVEL_M_S2, max_order=5)}
    for name, cal in cals.items():
        t = beyond(cal.tmin_c, cal.tmax_c).astype(np.float32).astype(float)
        out = run_c(tmp_path, c_header(cal, 100.0), t)
        err = np.max(np.abs(out[:, :3] - cal.offset_m_s2(t)))
        print(f"C header ({name}): max |C − Python| = {err / UG_M_S2:.2e} µg")
        assert err < UG_M_S2
    # with the die-temperature lag: 100 Hz, tau 60 s, a 1 °C/min ramp with soaks (420k samples)
    cal = cals["px4"]
    ramp = np.concatenate([np.full(30000, -20.0), np.linspace(-20, 50, 420000), np.full(60000, 50.0)])
    ramp = ramp.astype(np.float32).astype(float)
    path = write_c_header(tmp_path / "lag.h", cal, 100.0, tau_s=60.0)
    assert "static const float twin_tcal_lag_alpha" in path.read_text()
    out = run_c(tmp_path, path.read_text(), ramp)
    t_die = die_temperature_lag(ramp, 100.0, 60.0)
    err = np.max(np.abs(out[:, :3] - cal.offset_m_s2(t_die)))
    print(f"C header with lag: max |C − Python| = {err / UG_M_S2:.2e} µg, "
          f"max |T_die C − Python| = {np.max(np.abs(out[:, 3] - t_die)):.2e} °C")
    assert err < UG_M_S2
    assert lag_alpha(100.0, 60.0) == pytest.approx(1 - np.exp(-0.01 / 60.0), rel=1e-12)
