"""Calibration at the scale of real logs (issue 28): each reduction that makes ``twin calibrate``
linear in the log's length gives what the full-rate computation it replaces gave.

The tolerances are the measured differences (this machine, numpy/OpenBLAS of the venv) with a
margin stated beside each; the logs are simulated here, seeded.
"""

import numpy as np
import pytest
from scipy.signal import lfilter
from sklearn.base import clone

from logfixtures import chamber_run, write_dataflash
from sim.drift import lowpass
from twin.calibration.branches import protocol_as_used
from twin.calibration.lag import as_log, lagged_c, make_X, uniform_lag
from twin.calibration.lagaware import LagAwareCompensator
from twin.calibration.lagprofile import Profile
from twin.calibration.methods import ArduPilotMethod, AsTheVehicleApplies, Px4Method
from twin.calibration.models import TemperaturePolynomial, poly_columns
from twin.calibration.progress import FitProgress
from twin.calibration.validate import validate
from twin.measurement.rowstats import runs

# a tester's chamber program, repeated every 1.5 h: dwell, 2 °C/min up, dwell, 2 °C/min down
PROGRAM = np.array([(0.0, -20.0), (600.0, -20.0), (2700.0, 50.0), (3300.0, 50.0), (5400.0, -20.0)])


def _lag(u, dt, tau):
    a = np.exp(-dt / tau)
    return lfilter([1 - a], [1, -a], u, zi=[a * u[0]])[0]


def simulated_tester_log(hours=1.5, rate_hz=4.0, thermometer_noise_c=0.0, seed=3):
    """X, y of a board through PROGRAM: die 120 s behind the board, thermometer 2 s, a cubic in the
    die temperature and a rate term through 60 s per axis, 1 mg of white noise."""
    rng = np.random.default_rng(seed)
    dt = 1 / rate_hz
    t = np.arange(int(hours * 3600 * rate_hz)) * dt
    board = _lag(np.interp(np.mod(t, PROGRAM[-1, 0]), *PROGRAM.T), dt, 300.0)
    probe, die = _lag(board, dt, 2.0), _lag(board, dt, 120.0)
    temp = probe + (rng.normal(0, thermometer_noise_c, t.size) if thermometer_noise_c else 0.0)
    d = die[:, None] - 25.0
    y = (np.array([0.4, -0.25, 0.6]) * d + np.array([4e-3, -3e-3, 2e-3]) * d**2
         + np.array([1.5, -1.0, 2.0]) * (probe - _lag(probe, dt, 60.0))[:, None]) * 1e-3
    y += rng.normal(0, 1e-3, y.shape) + [0.0, 0.0, 1.0]
    return make_X(t, temp), y


# ------------------------------------------------------------------------------------------
# lags
# ------------------------------------------------------------------------------------------

@pytest.mark.parametrize("tau", [1e-8, 0.03, 2.0, 59.3, 600.0])
def test_uniform_lag_is_lowpass_bit_for_bit(tau):
    u = np.cumsum(np.random.default_rng(0).normal(size=5000)) * 0.01
    assert np.array_equal(uniform_lag(u, 0.01, tau), lowpass(u, 0.01, tau))


def test_the_profiles_lags_are_lagged_c_bit_for_bit():
    rng = np.random.default_rng(0)  # a uniform run, a jittered one, a one-row run, another uniform one
    t = np.r_[np.arange(1000) * 0.5, np.cumsum(rng.uniform(0.4, 0.6, 800)), [0.0], np.arange(500) * 1.0]
    run = np.r_[np.zeros(1000), np.ones(800), [2], np.full(500, 3)]
    log = as_log(make_X(t, rng.normal(size=t.size).cumsum(), run))
    profile = Profile(log, np.zeros((t.size, 3)), np.ones(t.size, bool), 3, 35.0)
    for tau in (0.0, 0.3, 5.0, 120.0):
        assert np.array_equal(profile.lag(tau), lagged_c(log, tau))


# ------------------------------------------------------------------------------------------
# the lag-aware search on block means
# ------------------------------------------------------------------------------------------

def _fit_both(monkeypatch, X, y):
    means = LagAwareCompensator().fit(X, y)
    monkeypatch.setenv("TDE_TWIN_FULL_RATE", "1")  # the search on every row, as before issue 28
    full = LagAwareCompensator().fit(X, y)
    return means, full


def test_block_mean_search_finds_the_full_rate_fit(monkeypatch):
    """A noise-free thermometer: the 1-s means hold everything the 4 Hz rows do."""
    X, y = simulated_tester_log()
    assert Profile(as_log(X), y, np.ones(len(y), bool), 3, 35.0).factor == 4
    means, full = _fit_both(monkeypatch, X, y)
    assert means.selected_.name == full.selected_.name
    # measured (1.5 h at 4 Hz): τ_die 1.2e-5, τ_rate 7.1e-5, b 6.5e-5 relative; every amplitude
    # within 0.0012 of its standard error; the standard errors 1e-5..9.5e-5 relative, the training
    # RMS 2e-8. The bounds are 5-10× those (another BLAS sums in another order).
    np.testing.assert_allclose(means.tau_die_s_, full.tau_die_s_, rtol=1e-4)
    np.testing.assert_allclose(means.tau_rate_s_, full.tau_rate_s_, rtol=5e-4)
    np.testing.assert_allclose(means.rate_mg_per_c_, full.rate_mg_per_c_, rtol=5e-4)
    assert np.all(np.abs(means.coef_mg_ - full.coef_mg_) <= 0.01 * full.coef_se_mg_)
    assert np.all(np.abs(means.rate_mg_per_c_ - full.rate_mg_per_c_) <= 0.01 * full.rate_se_mg_per_c_)
    for attr in ("tau_die_se_s_", "tau_rate_se_s_", "rate_se_mg_per_c_", "coef_se_mg_"):
        np.testing.assert_allclose(getattr(means, attr), getattr(full, attr), rtol=5e-4)
    np.testing.assert_allclose(means.train_rms_mg_, full.train_rms_mg_, rtol=1e-6)


def test_thermometer_noise_biases_the_full_rate_search_not_the_means(monkeypatch):
    """0.01 °C of thermometer noise enters T − lag(T, τ_rate) unfiltered at full rate; its share of the
    SSE, n·b²·σ², shrinks with b, so the full-rate optimum slides along the valley b·τ_rate = const
    to a longer τ_rate and a smaller b (truth: 60 s, b = 1.5 / −1.0 / 2.0 mg/°C)."""
    X, y = simulated_tester_log(thermometer_noise_c=0.01)
    means, full = _fit_both(monkeypatch, X, y)
    assert full.tau_rate_s_[0] > means.tau_rate_s_[0]
    assert np.all(np.abs(full.rate_mg_per_c_) < np.abs(means.rate_mg_per_c_))
    # what the data fix, b·τ_rate, agrees: measured 0.06 % here, 0.12 % on 1.5 h at 100 Hz
    np.testing.assert_allclose(means.rate_mg_per_c_ * means.tau_rate_s_, full.rate_mg_per_c_ * full.tau_rate_s_,
                               rtol=5e-3)


# ------------------------------------------------------------------------------------------
# the polynomial from Gram matrices
# ------------------------------------------------------------------------------------------

def test_polynomial_from_block_grams_is_the_least_squares_on_the_rows():
    X, y = simulated_tester_log(hours=1.0, rate_hz=2.0)
    mask = np.zeros(len(y), bool)
    mask[: 2 * len(y) // 3] = True
    est = TemperaturePolynomial(max_degree=5).fit(X, y, mask)
    dT, Y = X[mask, 1] - 35.0, y[mask]
    blocks = np.array_split(np.arange(dT.size), 5)
    for d in range(1, 6):  # the held-out RMS per degree, as lstsq on the rows gives it
        sse = np.zeros(3)
        for b in blocks:
            train = np.ones(dT.size, bool)
            train[b] = False
            c = np.linalg.lstsq(poly_columns(dT[train], d), Y[train], rcond=None)[0]
            sse += ((Y[b] - poly_columns(dT[b], d) @ c) ** 2).sum(axis=0)
        # measured ≤ 6e-10 relative (degree 5 extrapolated into a held-out block is ill-conditioned)
        np.testing.assert_allclose(est.cv_rms_mg_[:, d - 1], np.sqrt(sse / dT.size) * 1e3, rtol=1e-8)
    for a, d in enumerate(est.degree_):
        c = np.linalg.lstsq(poly_columns(dT, d), Y[:, a], rcond=None)[0]
        # measured ≤ 5e-12 relative
        np.testing.assert_allclose(est.coef_mg_[a, : d + 1], c * 1e3 / 10.0 ** np.arange(d + 1), rtol=1e-9)


def test_a_noise_free_polynomial_is_found_exactly():
    """yᵀy − 2cᵀb + cᵀGc cancels to nothing on an exact fit: those blocks are scored on their rows."""
    t = np.arange(2000.0)
    T = 20 + 30 * np.sin(t / 300)
    y = np.column_stack([1e-3 * (T - 35) + 1e-5 * (T - 35) ** 2, -2e-3 * (T - 35), np.full(t.size, 1.0)])
    est = TemperaturePolynomial(max_degree=4).fit(make_X(t, T), y)
    assert np.all(est.cv_rms_mg_[:, 1:] < 1e-9) and est.cv_rms_mg_[0, 0] > 1e-3
    np.testing.assert_allclose(est.coef_mg_[0, 1:3], [1.0, 1e-2], rtol=1e-9)


# ------------------------------------------------------------------------------------------
# validation: each fit once, row-by-row models predicted on the held-out rows only
# ------------------------------------------------------------------------------------------

@pytest.mark.parametrize("method", [Px4Method(instance=0, device_id=7), ArduPilotMethod(instance=1)])
def test_as_the_vehicle_applies_from_a_fitted_method_is_its_own_fit(method):
    X, y = simulated_tester_log(hours=1.5, rate_hz=1.0)
    mask = np.arange(len(y)) < 4000
    inner = method.fit(X, y, mask)
    a = AsTheVehicleApplies(clone(method)).fit(X, y, mask)
    b = AsTheVehicleApplies(clone(method)).fit_from(inner, X, y, mask)
    assert a.values_ == b.values_
    np.testing.assert_array_equal(a.predict(X), b.predict(X))
    with pytest.raises(TypeError):
        AsTheVehicleApplies(TemperaturePolynomial()).fit_from(inner, X, y, mask)


def test_validation_scores_as_if_every_row_were_predicted():
    X, y = simulated_tester_log(hours=3.0, rate_hz=1.0)
    protocol = protocol_as_used(X[:, 0], X[:, 1])
    models = {"px4": Px4Method(), "ardupilot": ArduPilotMethod(), "polynomial": TemperaturePolynomial()}
    wrapped = {"px4_as_applied": AsTheVehicleApplies(models["px4"]),
               "ardupilot_as_applied": AsTheVehicleApplies(models["ardupilot"])}
    res = validate({**models, **wrapped}, X[:, 0], X[:, 1], y, protocol)
    for fold in protocol.folds:  # the same fold, every row predicted and the wrappers fitted anew
        mask = np.zeros(len(y), bool)
        mask[fold.train] = True
        for name, est in {**models, **wrapped}.items():
            r = y - clone(est).fit(X, y, mask).predict(X)
            for t in fold.tests:
                # measured ≤ 3e-15 relative (a product of another shape sums in another order)
                np.testing.assert_allclose(res.rms_mg(name, t.name, fold.name),
                                           np.sqrt(np.mean(r[t.index] ** 2, axis=0)) * 1e3, rtol=1e-12)


# ------------------------------------------------------------------------------------------
# readers and log quality on long logs
# ------------------------------------------------------------------------------------------

def test_runs_cut_at_breaks_as_the_loop_did():
    def loop(mask, breaks):  # the definition: every run of True, cut at each break inside it
        edge, out = np.diff(np.r_[0, mask.astype(np.int8), 0]), []
        for i, j in zip(np.flatnonzero(edge == 1), np.flatnonzero(edge == -1)):
            bounds = np.r_[i, breaks[(breaks > i) & (breaks < j)], j]
            out += [(int(p), int(q)) for p, q in zip(bounds[:-1], bounds[1:])]
        return out

    rng = np.random.default_rng(1)
    for _ in range(300):
        n = int(rng.integers(0, 60))
        mask = rng.random(n) < rng.random()
        breaks = np.unique(rng.integers(-3, n + 3, int(rng.integers(0, 6))))
        assert runs(mask, breaks) == loop(mask, breaks)


def test_dataflash_rows_read_in_blocks_are_the_rows(tmp_path, monkeypatch):
    import twin.measurement.dataflash as df

    path = write_dataflash(tmp_path / "chamber.bin", chamber_run(n=300, gyro=True))
    whole = df.read_dataflash(path)
    monkeypatch.setattr(df, "CHUNK_ROWS", 7)  # 300 rows per instance: 42 blocks and a remainder
    blocks = df.read_dataflash(path)
    for a, b in zip(whole, blocks, strict=True):
        for name in ("time_s", "temperature_c", "accel_g", "gyro_rad_s"):
            np.testing.assert_array_equal(getattr(a, name), getattr(b, name))
        assert (a.instance, a.device_id, a.notes) == (b.instance, b.device_id, b.notes)


# ------------------------------------------------------------------------------------------
# progress
# ------------------------------------------------------------------------------------------

def test_a_progress_bar_only_on_a_terminal(capsys):
    with FitProgress("IMU 0", enabled=True) as bar:
        bar.expect(3)
        for what in ("log quality", "protocol", "twin on fold 1"):
            bar.step(what)
    err = capsys.readouterr().err
    assert "IMU 0" in err and "3/3" in err
    with FitProgress("IMU 1") as bar:  # stderr is captured here: not a terminal, nothing drawn
        bar.expect(2)
        bar.step("x")
    assert capsys.readouterr().err == ""


def test_a_large_three_axis_table_read_in_chunks_is_the_table(tmp_path, monkeypatch):
    from twin.measurement import ColumnMap, chunked, read_imu_logs

    X, y = simulated_tester_log(hours=0.5, rate_hz=4.0)
    path = tmp_path / "tester.csv"
    np.savetxt(path, np.column_stack([X, y]), delimiter=",", header="time_s,temp_c,ax_g,ay_g,az_g", comments="",
               fmt=["%.3f", "%.4f", "%.7f", "%.7f", "%.7f"])
    cmap = ColumnMap(time="time_s", temperature="temp_c", x="ax_g", y="ay_g", z="az_g", output_unit="g")
    whole = read_imu_logs(path, cmap)[0]
    monkeypatch.setenv("TDE_TWIN_CHUNKED_MIN_BYTES", "0")
    monkeypatch.setattr(chunked, "CHUNK_ROWS", 1000)  # 7200 rows: eight chunks, the last one short
    assert chunked.is_large(path)
    parts = read_imu_logs(path, cmap)[0]
    for name in ("time_s", "temperature_c", "accel_g"):
        np.testing.assert_array_equal(getattr(whole, name), getattr(parts, name))
    assert whole.notes == parts.notes


# ------------------------------------------------------------------------------------------
# the real log: the TofuPilot table as it was before issue 28
# ------------------------------------------------------------------------------------------

# `twin calibrate` of the TofuPilot log (2 Hz: the τ search runs on every row, as before) with the
# code before issue 28: pooled held-out RMS [mg] x / y / z per method, and the twin's time constants
TOFU_BEFORE_MG = {"px4": [0.9973252796, 3.1323279235, 7.1458461741],
                  "ardupilot": [0.9770011077, 3.1029059443, 7.0251405908],
                  "polynomial": [1.0140153979, 3.0723249282, 7.1278614402],
                  "twin": [0.5628881251, 1.1357287277, 3.4987018964],
                  "px4_as_applied": [0.9147102393, 3.0537299143, 7.0206551638],
                  "ardupilot_as_applied": [0.9770017781, 3.1029062831, 7.0251438464]}
TOFU_BEFORE_TAU_S = {"die": [34.287886903923095, 42.44087768998972, 0.0],
                     "rate": [335.71369666909186, 363.3184041463546, 600.0]}


def test_the_tofupilot_table_is_the_one_before():
    from conftest import SHARED
    from twin.calibration.workflow import calibrate_imus
    from twin.measurement import ColumnMap, imu_logs_by_instance

    path = SHARED / "data" / "real" / "tofupilot_imu_thermal" / "imu_raw_data.tsv"
    if not path.exists():
        pytest.skip(f"{path} not present")
    cmap = ColumnMap(time="timestamp", time_unit="us", temperature="imu.temperature", x="imu.acc.x", y="imu.acc.y",
                     z="imu.acc.z", output_unit="m/s^2")
    [cal], _ = calibrate_imus(imu_logs_by_instance([path], cmap))
    assert cal.protocol == "held-out branches, both directions in training"
    assert cal.recommended() == {"px4": "px4", "ardupilot": "ardupilot", "c": "twin"}
    # measured: the held-out RMS within 3e-9 relative, τ within 8e-9 (normal equations and QR in
    # place of SVD least squares: rounding only); 1e-7 leaves room for another BLAS
    for method, rms in TOFU_BEFORE_MG.items():
        np.testing.assert_allclose(cal.heldout_rms_mg(method), rms, rtol=1e-7)
    twin = cal.fitted["twin"]
    np.testing.assert_allclose(twin.tau_die_s_, TOFU_BEFORE_TAU_S["die"], rtol=1e-7, atol=1e-9)
    np.testing.assert_allclose(twin.tau_rate_s_, TOFU_BEFORE_TAU_S["rate"], rtol=1e-7)


def test_a_long_log_holds_out_four_branches_spread_over_it_the_last_one_included():
    """Eight ramps (four cycles): four leave-one-branch-out folds, not eight — the forward fold on the
    last branch, the first branch, both directions held out, the others' training rows unchanged;
    a two-cycle log keeps every branch it can leave out."""
    t = np.arange(0.0, 4 * 5400.0, 1.0)
    phase = t % 5400.0  # 10 min dwell at -20 °C, 35 min up to 50 °C, 10 min dwell, 35 min down
    T = np.interp(phase, [0, 600, 2700, 3300, 5400], [-20, -20, 50, 50, -20])
    p = protocol_as_used(t, T)
    names = [f.name for f in p.folds]
    assert len(p.folds) == 4 and names[-1].startswith("forward: cooling 4"), names
    assert names[0].startswith("leave out: heating 1")
    assert {n.split(": ")[1].split(" ")[0] for n in names} == {"heating", "cooling"}
    assert "4 of the 8 branches" in p.note
    two = protocol_as_used(t[t < 2 * 5400], T[t < 2 * 5400])
    assert len(two.folds) == 4 and two.note == ""
    assert all(f.both_directions for f in p.folds)
