"""twin.calibration: branches and protocols, lag-aware compensation, validation, six-position fits.

Simulated truths are built here (seeded); the real-data acceptance reads the TofuPilot IMU log in
place from where the real logs are kept beside the project (``conftest.SHARED``; one static orientation, one cycle 51.6 → −17.6 → 74.0 → 36.3 °C).
"""

import numpy as np
import pytest

from conftest import SHARED
from sim.drift import lowpass
from twin.calibration import (CubicCompensator, LagAwareCompensator, TemperaturePolynomial, make_X,
                              protocol_heating_vs_cooling, six_position, split_branches, validate)

TOFU = SHARED / "data" / "real" / "tofupilot_imu_thermal" / "imu_raw_data.tsv"
G0 = 9.80665


@pytest.fixture(scope="module")
def tofu():
    if not TOFU.exists():
        pytest.skip(f"{TOFU} not present")
    d = np.genfromtxt(TOFU, delimiter="\t", names=True)
    time_s = (d["timestamp"] - d["timestamp"][0]) * 1e-6
    accel_g = np.column_stack([d["imuaccx"], d["imuaccy"], d["imuaccz"]]) / G0
    return time_s, d["imutemperature"].astype(float), accel_g


# ------------------------------------------------------------------------------------------
# branches and protocols
# ------------------------------------------------------------------------------------------

def test_tofupilot_log_splits_into_three_branches(tofu):
    time_s, temp_c, _ = tofu
    branches = split_branches(time_s, temp_c)
    assert [b.kind for b in branches] == ["cooling", "heating", "cooling"]
    cool1, heat, cool2 = branches
    assert (cool1.start, heat.start, heat.stop - 1, cool2.stop) == (0, temp_c.argmin(), temp_c.argmax(), temp_c.size)
    assert heat.min_c == pytest.approx(-17.60, abs=0.01) and heat.max_c == pytest.approx(73.97, abs=0.01)
    assert cool1.start_c == pytest.approx(51.6, abs=0.05) and cool2.stop_c == pytest.approx(36.3, abs=0.05)
    assert heat.mean_rate_c_per_min == pytest.approx(3.1, abs=0.1)


def test_protocol_fallbacks_and_runs():
    t = np.arange(0, 3600.0, 1.0)
    heating = 20 + t / 60  # one direction only
    p = protocol_heating_vs_cooling(t, heating)
    assert p.name == "interleaved blocks" and "rate-dependent" in p.note
    assert not np.intersect1d(p.folds[0].train, np.concatenate([s.index for s in p.folds[0].tests])).size
    cycle = 25 + 30 * np.sin(2 * np.pi * t / 3600)
    runs = np.repeat([0, 1], t.size)
    two = protocol_heating_vs_cooling(np.r_[t, t], np.r_[cycle, cycle], run=runs)
    assert [f.name for f in two.folds] == ["leave out run 0", "leave out run 1"]
    assert all(np.all(runs[f.train] != runs[f.tests[0].index[0]]) for f in two.folds)
    hot = protocol_heating_vs_cooling(t, cycle)
    ext = [s.extrapolated_fraction for f in hot.folds for s in f.tests]
    assert all(0 <= e < 0.1 for e in ext)


# ------------------------------------------------------------------------------------------
# lag-aware compensation on a simulated truth
# ------------------------------------------------------------------------------------------

TAU_DIE_S, TAU_RATE_S = 40.0, 150.0
RATE_MG_PER_C = np.array([0.15, -0.40, 0.80])
CUBIC_MG = np.array([[12.0, 0.13, 1.0e-3, 3.0e-5], [-5.0, -0.18, -3.0e-3, -1.6e-5], [-980.0, 0.09, 1.4e-2, -1.8e-4]])


def simulated_cycle(seed=1, dt_s=2.0, noise_mg=0.3):
    """Chamber program with holds and ramps of 1, 3, 4 and 6 °C/min; a known die lag, gradient term
    and cubic per axis; white noise."""
    knots = [(0, 25), (20, 25), (35, 70), (50, 70), (140, -20), (155, -20), (162.5, 25), (172.5, 25), (178.75, 0),
             (190, 0)]  # (minute, °C)
    t = np.arange(0, knots[-1][0] * 60, dt_s)
    chamber = np.interp(t, *np.array(knots, float).T * [[60], [1]])
    temp_c = lowpass(chamber, dt_s, 60.0)  # the thermometer sees a smoothed chamber
    die_c = lowpass(temp_c, dt_s, TAU_DIE_S)
    grad_c = temp_c - lowpass(temp_c, dt_s, TAU_RATE_S)
    truth_mg = np.column_stack([np.polyval(c[::-1], die_c - 35) for c in CUBIC_MG]) + grad_c[:, None] * RATE_MG_PER_C
    rng = np.random.default_rng(seed)
    return t, temp_c, (truth_mg + rng.normal(0, noise_mg, truth_mg.shape)) * 1e-3


def test_lag_aware_recovers_simulated_time_constants_and_amplitudes():
    t, temp_c, accel_g = simulated_cycle()
    m = LagAwareCompensator().fit(make_X(t, temp_c), accel_g)
    print("\n" + m.equation())
    assert m.shared_ and m.rate_used_.all(), m.selected_
    assert m.tau_die_s_[0] == pytest.approx(TAU_DIE_S, rel=0.05)
    assert m.tau_rate_s_[0] == pytest.approx(TAU_RATE_S, rel=0.05)
    for a in range(3):
        lo, hi = m.rate_ci95_mg_per_c_[a]
        assert lo <= RATE_MG_PER_C[a] <= hi, (a, m.rate_ci95_mg_per_c_[a])
    assert m.tau_die_ci95_s_[0, 0] <= TAU_DIE_S <= m.tau_die_ci95_s_[0, 1]
    assert m.tau_rate_ci95_s_[0, 0] <= TAU_RATE_S <= m.tau_rate_ci95_s_[0, 1]
    assert np.all(np.abs(m.coef_mg_[:, 1] - CUBIC_MG[:, 1]) <= 1.96 * m.coef_se_mg_[:, 1])
    assert "τ_die" in m.equation() and "mg/°C" in m.equation()


def test_validation_on_simulated_truth_reaches_the_noise():
    t, temp_c, accel_g = simulated_cycle(seed=2)
    protocol = protocol_heating_vs_cooling(t, temp_c, reverse=False)
    res = validate({"cubic": CubicCompensator(), "lag-aware": LagAwareCompensator()}, t, temp_c, accel_g, protocol)
    print("\n" + res.table(reference="cubic"))
    # The floor is σ from first differences, / √2: the differences of white noise are MA(1) (lag-1
    # correlation −½), so σ̂ from N of them has a relative standard error of √(3/(4N)); it is the
    # median over the two held-out branches (3,120 and 565 samples) and the two methods, about the
    # mean of the two branches': 2.0 %. Measured over seeds 1–40 × 3 axes: SD 2.1 %, largest 5.5 %
    # (this seed: −2.9 % to +2.4 %). 4 standard errors: 8 %.
    assert np.allclose(res.noise_floor_mg, 0.3, rtol=0.08)
    # Reaching the noise: the held-out RMS of white noise alone, 3,687 samples, has a relative
    # standard error of 1/√(2N) = 1.2 %; the fitted model adds its own estimation error. Measured
    # over seeds 1–40 × 3 axes: mean +0.5 %, SD 1.5 %, largest +4.7 % above σ (this seed: up to
    # +1.4 %). The mean plus 4 SD: 7 % (the cubic leaves 3 to 30 times the noise here).
    assert np.all(res.rms_mg("lag-aware") < 1.07 * 0.3)
    assert np.all(res.rms_mg("cubic") > 2 * res.rms_mg("lag-aware"))
    assert res.best_method == ("lag-aware",) * 3


# ------------------------------------------------------------------------------------------
# six-position test at three temperatures
# ------------------------------------------------------------------------------------------

SCALE_TC_PPM = np.array([120.0, -85.0, 210.0])


def six_position_log(seed=3, rate_hz=10.0, noise_mg=2.0):
    """±x, ±y, ±z held 40 s each (4 s moves between) at −20, 25, 70 °C; known linear s(T), o(T)."""
    dirs = np.vstack([np.eye(3), -np.eye(3)])[[0, 3, 1, 4, 2, 5]]
    dt = 1 / rate_hz
    g, temp = [], []
    for T in (-20.0, 25.0, 70.0):
        for k, d in enumerate(dirs):
            nxt = dirs[(k + 1) % 6]
            g.append(np.repeat(d[None], int(40 * rate_hz), axis=0))
            w = np.linspace(0, 1, int(4 * rate_hz))[:, None]  # a move: direction swings to the next
            move = (1 - w) * d + w * nxt + np.sin(np.pi * w) * np.cross(d, nxt + 0.3)
            g.append(move / np.linalg.norm(move, axis=1, keepdims=True))
        temp += [np.full(int(44 * rate_hz) * 6, T)]
    g, temp = np.vstack(g), np.concatenate(temp)
    dT = temp - 25.0
    s = np.array([500e-6, -300e-6, 800e-6]) + SCALE_TC_PPM * 1e-6 * dT[:, None]
    o = np.array([10e-3, -5e-3, 20e-3]) + np.array([0.3e-3, -0.2e-3, 0.5e-3]) * dT[:, None]
    rng = np.random.default_rng(seed)
    accel = (1 + s) * g + o + rng.normal(0, noise_mg * 1e-3, g.shape)
    return np.arange(temp.size) * dt, temp, accel


def test_six_position_recovers_scale_factor_tempco():
    t, temp_c, accel_g = six_position_log()
    report, fit = six_position(t, accel_g, temp_c, degree=1, reference_c=25.0)
    assert report.kind == "six-position" and not report.missing
    assert sorted(len(o.segments) for o in report.orientations) == [3] * 6
    for a in range(3):
        lo, hi = fit.scale_ci95_ppm[a, 1]
        print(f"axis {'xyz'[a]}: TCSo {fit.scale_ppm[a, 1]:.1f} [{lo:.1f}, {hi:.1f}] ppm/°C "
              f"(truth {SCALE_TC_PPM[a]}), TCOff {fit.offset_mg[a, 1]:.4f} mg/°C")
        assert fit.scale_ppm[a, 1] == pytest.approx(SCALE_TC_PPM[a], rel=0.05)
        assert lo <= SCALE_TC_PPM[a] <= hi
        assert fit.offset_mg[a, 1] == pytest.approx([0.3, -0.2, 0.5][a], rel=0.05)


# ------------------------------------------------------------------------------------------
# real data: TofuPilot IMU, fit on heating, test on both cooling branches
# ------------------------------------------------------------------------------------------

def test_tofupilot_heating_to_cooling(tofu):
    time_s, temp_c, accel_g = tofu
    protocol = protocol_heating_vs_cooling(time_s, temp_c, reverse=False)
    models = {"cubic (PX4, 35 °C)": CubicCompensator(35.0), "polynomial (block CV)": TemperaturePolynomial(),
              "lag-aware": LagAwareCompensator()}
    res = validate(models, time_s, temp_c, accel_g, protocol)
    print("\n" + res.table(reference="cubic (PX4, 35 °C)"))
    cubic, lag = res.rms_mg("cubic (PX4, 35 °C)"), res.rms_mg("lag-aware")
    print("lag-aware below cubic: " + " / ".join(f"{100 * (1 - v / w):.0f} %" for v, w in zip(lag, cubic)))
    mask = np.zeros(time_s.size, bool)
    mask[protocol.folds[0].train] = True
    fitted = LagAwareCompensator().fit(make_X(time_s, temp_c), accel_g, mask=mask)
    print(f"three-axis lag-aware fit:\n{fitted.equation()}")
    for c in fitted.candidates_:
        print(f"  {c.name:45s} BIC {c.bic:10.1f}  k {c.n_params}  train RMS "
              + " / ".join(f"{v:.3f}" for v in c.rms_mg))
    assert cubic == pytest.approx([1.15, 3.49, 8.86], abs=0.02)  # the protocol check
    # One fixed log: only the fitted models move the floor, and first differences cancel what they
    # differ in. Measured, the three methods' floors on one branch agree within 0.4 % (largest: x
    # on cooling 1, 0.3263 to 0.3276 mg); the median over branches and methods is 0.328 / 0.337 /
    # 0.548 mg (the project's trimmed floor, as compare quotes it; the plain σ gave 0.563 for z).
    # 1 %: that spread and the rounding of the third digit (0.15 %).
    assert np.allclose(res.noise_floor_mg, [0.328, 0.337, 0.548], rtol=0.01)
    # Everything in LagAwareCompensator is chosen on the heating rows (mask) only; the cooling
    # branches are only scored. Fragile, though: x's margin is 3 %, degree 4-6 or shared τ's fail.
    assert np.all(lag <= 0.6 * cubic)  # the 40 % target, met on every axis
    assert np.all(lag <= [0.68, 1.0, 4.8])
