"""The lag-aware compensation as a C header: compiled, fed a temperature history, and compared with
``twin.calibration.deploy.correction_g`` (the arithmetic ``twin apply`` uses) to ≤ 1 µg."""

import shutil
import subprocess

import numpy as np
import pytest

from sim.drift import lowpass
from sim.thermal import first_order_lag
from twin.calibration.deploy import correction_g
from twin.calibration.lag import make_X
from twin.calibration.lagaware import LagAwareCompensator
from twin.calibration.workflow import method_json
from twin.firmware import G0_M_S2, FirmwareCalError, lag_aware_c_header, write_lag_aware_c_header
from twin.firmware.lag_header import lag_coefficients

UG_M_S2 = G0_M_S2 * 1e-6  # 1 µg in m/s²
RATE_HZ = 10.0
needs_cc = pytest.mark.skipif(shutil.which("cc") is None, reason="no C compiler")

# different τ per axis (one slow enough for the float32 dead band to matter), z without a rate term
HAND_PARAMS = {
    "kind": "LagAwareCompensator", "reference_c": 25.0,
    "coef_mg": [[12.0, 1.3, 4.0e-3, -2.0e-4], [-5.0, -0.8, -3.0e-3, 1.6e-5], [-980.0, 2.1, 1.4e-2, -1.8e-4]],
    "tau_die_s": [600.0, 45.0, 8.0], "tau_rate_s": [20.0, 900.0, None], "rate_mg_per_c": [2.5, -1.2, 0.0],
}

MAIN_C = r"""
#include <stdio.h>
#include "lag.h"
int main(void)
{
    double t_in;
    twin_lag_state state;
    twin_lag_init(&state);
    while (scanf("%lf", &t_in) == 1) {
        const twin_lag_real t = (twin_lag_real)t_in;
        twin_lag_real corr[TWIN_LAG_N_AXES], accel[TWIN_LAG_N_AXES] = {1, 2, 3};
        twin_lag_update(&state, t);
        twin_lag_correction_m_s2(&state, t, corr);
        twin_lag_correct_m_s2(&state, t, accel);
        for (int a = 0; a < TWIN_LAG_N_AXES; a++) printf("%.17g ", (double)corr[a]);
        for (int a = 0; a < TWIN_LAG_N_AXES; a++) printf("%.17g ", (double)accel[a]);
        printf("\n");
    }
    return 0;
}
"""


def run_c(tmp_path, header_text, temps):
    """Compile ``header_text`` with a main reading temperatures from stdin; (n, 6) corrections and
    corrected (1, 2, 3) m/s² per sample."""
    (tmp_path / "lag.h").write_text(header_text)
    (tmp_path / "main.c").write_text(MAIN_C)
    exe = tmp_path / "main"
    subprocess.run(["cc", "-std=c99", "-O2", "-Wall", "-Wextra", "-pedantic", "-Werror", "-o", str(exe), "main.c"],
                   cwd=tmp_path, check=True, capture_output=True, text=True)
    stdin = "\n".join(repr(float(v)) for v in temps) + "\n"
    out = subprocess.run([str(exe)], input=stdin, capture_output=True, text=True, check=True).stdout
    return np.loadtxt(out.splitlines(), ndmin=2)


@pytest.fixture(scope="module")
def history():
    """2 h at 10 Hz: dwells and 0.5–4 °C/min ramps from −10 to 60 °C, a thermometer with 1/128 °C
    noise; float32 values, so C and Python read the same temperatures."""
    knots = [(0, 20), (10, 20), (30, 60), (45, 60), (62.5, -10), (75, -10), (90, 35), (100, 35), (110, 30),
             (120, 30)]  # (minute, °C)
    t = np.arange(0, 7200.0, 1 / RATE_HZ)
    temp = np.interp(t, *np.array(knots, float).T * [[60], [1]])
    temp += np.random.default_rng(3).normal(0, 1 / 128, t.size)
    return t, temp.astype(np.float32).astype(float)


def python_m_s2(params, t, temp):
    return correction_g(params, t, temp) * G0_M_S2


def check_against_python(tmp_path, params, t, temp, label, real="float"):
    out = run_c(tmp_path, lag_aware_c_header(params, RATE_HZ, real=real), temp)
    ref = python_m_s2(params, t, temp)
    err = np.max(np.abs(out[:, :3] - ref))
    print(f"{label} ({real}): max |C − Python| = {err / UG_M_S2:.3g} µg over {t.size} samples")
    np.testing.assert_allclose(out[:, 3:], np.array([1.0, 2.0, 3.0]) - out[:, :3], rtol=0, atol=1e-6)
    return err


def test_lag_coefficients_reproduce_the_exact_first_order_hold_lag():
    u = 20 + np.cumsum(np.random.default_rng(0).normal(0, 0.3, 4000))
    for fs, tau in [(10.0, 600.0), (10.0, 45.0), (10.0, 0.05), (1000.0, 600.0), (1.0, 1e7), (100.0, 0.0)]:
        e, b0, b1 = lag_coefficients(fs, tau)
        assert b0 + b1 == pytest.approx(-np.expm1(-1 / (fs * tau)) if tau else 1.0, rel=1e-12)
        y = np.empty_like(u)
        y[0] = u[0]
        for n in range(1, u.size):
            y[n] = e * y[n - 1] + b0 * u[n] + b1 * u[n - 1]
        np.testing.assert_allclose(y, first_order_lag(u, 1 / fs, tau), rtol=0, atol=1e-10, err_msg=f"{fs} {tau}")
    e, b0, b1 = lag_coefficients(10.0, 600.0)
    h = 1 / 6000
    a = -np.expm1(-h)  # 1 − e
    assert (e, b0, b1) == pytest.approx((np.exp(-h), 1 - a / h, a / h - np.exp(-h)), rel=1e-9)


@needs_cc
def test_header_matches_python_to_1_ug_per_axis_taus(tmp_path, history):
    t, temp = history
    assert check_against_python(tmp_path, HAND_PARAMS, t, temp, "hand-made params") <= UG_M_S2
    assert check_against_python(tmp_path, HAND_PARAMS, t, temp, "hand-made params", real="double") <= 1e-3 * UG_M_S2


@needs_cc
def test_header_of_a_fitted_compensator_matches_python(tmp_path, history):
    dt = 5.0
    knots = [(0, 25), (15, 25), (35, 65), (50, 65), (110, -5), (125, -5), (140, 25), (150, 25)]
    tf = np.arange(0, knots[-1][0] * 60, dt)
    temp_f = lowpass(np.interp(tf, *np.array(knots, float).T * [[60], [1]]), dt, 60.0)
    cubic = np.array([[12.0, 0.13, 1e-3, 3e-5], [-5.0, -0.18, -3e-3, -1.6e-5], [-980.0, 0.09, 1.4e-2, -1.8e-4]])
    tau_die, tau_rate, rate = [30.0, 120.0, 60.0], [200.0, 40.0, 100.0], [0.5, -0.8, 0.0]
    mg = np.column_stack([np.polyval(cubic[a, ::-1], lowpass(temp_f, dt, tau_die[a]) - 35)
                          + rate[a] * (temp_f - lowpass(temp_f, dt, tau_rate[a])) for a in range(3)])
    accel_g = (mg + np.random.default_rng(0).normal(0, 0.05, mg.shape)) * 1e-3
    params = method_json("lag-aware", LagAwareCompensator(share="per_axis").fit(make_X(tf, temp_f), accel_g))
    assert len(set(params["tau_die_s"])) == 3
    t, temp = history
    assert check_against_python(tmp_path, params, t, temp, "fitted LagAwareCompensator") <= UG_M_S2


@needs_cc
def test_zero_tau_gives_the_plain_polynomial(tmp_path, history):
    t, temp = history
    params = {**HAND_PARAMS, "tau_die_s": [0.0, 0.0, 0.0], "tau_rate_s": [None, 0.0, None],
              "rate_mg_per_c": [0.0, 5.0, 0.0]}
    text = lag_aware_c_header(params, RATE_HZ)
    assert "twin_lag_die_lagged[TWIN_LAG_N_AXES] = {0, 0, 0}" in text
    out = run_c(tmp_path, text, temp)
    coef = np.array(params["coef_mg"])
    plain = np.column_stack([np.polyval(c[::-1], temp - 25.0) - c[0] for c in coef]) * 1e-3 * G0_M_S2
    assert np.max(np.abs(out[:, :3] - plain)) <= UG_M_S2
    np.testing.assert_allclose(python_m_s2(params, t, temp), plain, rtol=0, atol=1e-12)
    assert lag_coefficients(RATE_HZ, 0.0) == (0.0, 1.0, 0.0)


def test_write_is_atomic_text_and_exported(tmp_path):
    path = write_lag_aware_c_header(tmp_path / "twin_lag.h", HAND_PARAMS, 100.0, prefix="imu0_tc")
    text = path.read_text()
    assert text == lag_aware_c_header(HAND_PARAMS, 100.0, prefix="imu0_tc")
    assert "#ifndef IMU0_TC_H" in text and "imu0_tc_update(imu0_tc_state *state, imu0_tc_real t_meas_c)" in text
    assert "malloc" not in text and list(tmp_path.iterdir()) == [path]
    # the level (k = 0) is left out, coefficients are in m/s²/°C^k
    assert "{0.0f, 0.0127486447f, 3.92266011e-05f, -1.9613301e-06f},  /* x */" in text


BAD = [
    ({"reference_c": float("nan")}, "reference_c"),
    ({"coef_mg": [[1.0, 2.0]] * 2}, "coef_mg"),
    ({"coef_mg": [[1.0, 2.0], [1.0], [1.0, 2.0]]}, "differ in length"),
    ({"coef_mg": [[1.0, float("inf")]] * 3}, "coef_mg"),
    ({"tau_die_s": [10.0, -1.0, 3.0]}, ">= 0"),
    ({"tau_die_s": [10.0, 3.0]}, "tau_die_s"),
    ({"tau_die_s": [10.0, None, 3.0]}, "tau_die_s"),
    ({"tau_rate_s": [10.0, float("inf"), None]}, "tau_rate_s"),
    ({"tau_rate_s": [10.0, -5.0, None]}, ">= 0"),
    ({"rate_mg_per_c": None}, "rate_mg_per_c"),
    ({"rate_mg_per_c": [1.0, "2", 0.0]}, "rate_mg_per_c"),
]


@pytest.mark.parametrize("change,words", BAD)
def test_bad_params_raise_one_line(change, words):
    with pytest.raises(FirmwareCalError, match=words) as info:
        lag_aware_c_header({**HAND_PARAMS, **change}, RATE_HZ)
    assert "\n" not in str(info.value)


@pytest.mark.parametrize("rate", [0.0, -10.0, float("nan"), float("inf")])
def test_bad_sample_rate_and_arguments_raise(rate):
    with pytest.raises(FirmwareCalError, match="sample_rate_hz"):
        lag_aware_c_header(HAND_PARAMS, rate)
    with pytest.raises(FirmwareCalError, match="prefix"):
        lag_aware_c_header(HAND_PARAMS, RATE_HZ, prefix="Bad-Name")
    with pytest.raises(FirmwareCalError, match="real"):
        lag_aware_c_header(HAND_PARAMS, RATE_HZ, real="half")
    with pytest.raises(FirmwareCalError, match="reference_c"):
        lag_aware_c_header({"coef_mg": HAND_PARAMS["coef_mg"]}, RATE_HZ)
