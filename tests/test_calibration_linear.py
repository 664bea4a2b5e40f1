"""``twin calibrate`` in linear time and bounded memory (issue 28 item 1): each change that made it
faster gives the table it gave before, and the bounds hold by construction (checked here by what
the code does, never by timing it: speed is measured in benchmarks/bench_calibrate_scale.py).
"""

import numpy as np
import pytest

from test_calibration_scale import simulated_tester_log
from twin.calibration.branches import protocol_as_used
from twin.calibration.lagaware import LagAwareCompensator
from twin.calibration.methods import ArduPilotMethod, AsTheVehicleApplies, Px4Method
from twin.calibration.models import TemperaturePolynomial
from twin.calibration.validate import validate
from twin.firmware import fit_ardupilot
from twin.firmware.lstsq import polyfit_rows

# held-out RMS [mg] x / y / z pooled over the 4 folds of simulated_tester_log(hours=3, rate_hz=1,
# thermometer_noise_c=0.01),
# computed by the calibration code before this change (one thread pool, three polyfits, every row
# of a lag-aware model predicted): they agreed to all 10 digits printed
TESTER_BEFORE_MG = {"px4": [2.1784103028, 1.7414842097, 2.204430022],
                    "ardupilot": [2.1839127148, 1.7443653546, 2.2094535026],
                    "polynomial": [2.1770441524, 1.7390005892, 2.2064117695],
                    "twin": [0.9810143157, 0.9979124039, 1.0022440392],
                    "px4_as_applied": [2.2942638515, 1.8004178167, 2.4439232271],
                    "ardupilot_as_applied": [2.1839130871, 1.7443653734, 2.2094528094]}


def test_the_simulated_tester_table_is_the_one_before():
    X, y = simulated_tester_log(hours=3.0, rate_hz=1.0, thermometer_noise_c=0.01)
    protocol = protocol_as_used(X[:, 0], X[:, 1])
    assert len(protocol.folds) == 4
    models = {"px4": Px4Method(), "ardupilot": ArduPilotMethod(), "polynomial": TemperaturePolynomial(),
              "twin": LagAwareCompensator()}
    models.update(px4_as_applied=AsTheVehicleApplies(models["px4"]),
                  ardupilot_as_applied=AsTheVehicleApplies(models["ardupilot"]))
    res = validate(models, X[:, 0], X[:, 1], y, protocol)
    # 1e-8: the QR of ArduPilot's rows in place of polyfit's SVD differs by rounding (≤ 1e-14 measured)
    for method, rms in TESTER_BEFORE_MG.items():
        np.testing.assert_allclose(res.rms_mg(method), rms, rtol=1e-8)


# ------------------------------------------------------------------------------------------
# one least squares of the rows a chunk at a time
# ------------------------------------------------------------------------------------------

@pytest.mark.parametrize("n, chunk", [(7, 4), (1000, 1000), (10_000, 999), (50_000, 1 << 16)])
def test_polyfit_rows_is_np_polyfit(n, chunk):
    rng = np.random.default_rng(n)
    x = rng.uniform(-55.0, 15.0, n)
    Y = np.column_stack([c * (1e-5 * x**3 + 2e-4 * x**2 - 0.02 * x + 0.3) + rng.normal(0, 0.01, n)
                         for c in (1.0, -2.0, 0.5)])
    grid = np.linspace(x.min(), x.max(), 50)
    ours, ref = polyfit_rows(x, Y, 3, chunk=chunk), np.polyfit(x, Y, 3)
    assert ours.shape == ref.shape == (4, 3)
    for k in range(3):  # the curves: a coefficient near zero has no relative precision to compare
        curve = np.polyval(ref[:, k], grid)
        assert np.max(np.abs(np.polyval(ours[:, k], grid) - curve)) <= 1e-11 * np.max(np.abs(curve))
    np.testing.assert_allclose(polyfit_rows(x, Y[:, 1], 3, chunk=chunk), np.polyfit(x, Y[:, 1], 3),
                               rtol=1e-9, atol=1e-12)


def test_polyfit_rows_holds_one_chunk_at_a_time(monkeypatch):
    sizes, qr = [], np.linalg.qr

    def recording(a, mode="reduced"):
        sizes.append(a.shape)
        return qr(a, mode=mode)

    monkeypatch.setattr(np.linalg, "qr", recording)
    x = np.linspace(-20, 50, 100_000)
    polyfit_rows(x, np.column_stack([x, x**2, np.sin(x)]), 3, chunk=4096)
    blocks, last = sizes[:-1], sizes[-1]
    assert len(blocks) == -(-x.size // 4096) and all(r <= 4096 and c == 7 for r, c in blocks)
    assert last == (7 * len(blocks), 7)  # the stacked triangles: 7 rows per chunk, not the log


def test_ardupilot_fits_its_three_axes_in_one_least_squares(monkeypatch):
    rng = np.random.default_rng(5)
    t = np.linspace(-10, 60, 20_000)
    a = np.column_stack([1e-4 * (t - 35) ** 3, -2e-3 * (t - 35), 0.01 * (t - 35) ** 2]) + rng.normal(0, 1e-3, (t.size, 3))
    calls = []
    real = polyfit_rows

    def once(x, y, degree, **kw):
        calls.append(np.shape(y))
        return real(x, y, degree, **kw)

    monkeypatch.setattr("twin.firmware.ardupilot.polyfit_rows", once)
    cal = fit_ardupilot(t, a, time_s=np.arange(t.size) * 0.01)
    assert calls == [(t.size - 199, 3)]  # the 2 s moving average at 100 Hz, then one solve
    # each axis as the script's own np.polyfit on the same filtered rows
    k = np.ones(200) / 200
    tf = np.convolve(t, k, "valid")
    for axis in range(3):
        p = np.polyfit(tf - 35.0, np.convolve(a[:, axis], k, "valid"), 3)
        np.testing.assert_allclose(cal.acc[axis], [p[2], p[1], p[0]], rtol=1e-8, atol=1e-14)


# ------------------------------------------------------------------------------------------
# validation: a model with a thermal state predicts the held-out rows only
# ------------------------------------------------------------------------------------------

def test_predict_rows_is_predict_of_those_rows():
    X, y = simulated_tester_log(hours=1.5, rate_hz=1.0)
    est = LagAwareCompensator().fit(X, y, np.arange(len(y)) < 3000)
    rows = np.r_[5:400, 3000:4100]
    np.testing.assert_array_equal(est.predict_rows(X, rows), est.predict(X)[rows])
    np.testing.assert_array_equal(est.predict_rows(X, slice(None)), est.predict(X))


def test_the_validation_never_predicts_a_lag_model_on_every_row(monkeypatch):
    X, y = simulated_tester_log(hours=3.0, rate_hz=0.5)
    protocol = protocol_as_used(X[:, 0], X[:, 1])
    asked = []
    monkeypatch.setattr(LagAwareCompensator, "predict", lambda self, X: asked.append("all") or 1 / 0)
    real = LagAwareCompensator.predict_rows
    monkeypatch.setattr(LagAwareCompensator, "predict_rows",
                        lambda self, X, rows: asked.append(len(np.arange(len(X))[rows])) or real(self, X, rows))
    validate({"twin": LagAwareCompensator()}, X[:, 0], X[:, 1], y, protocol)
    held = [sum(t.index.size for t in f.tests) for f in protocol.folds]
    assert asked == held  # per fold its held-out rows: the rows predicted sum to the log once, not once per fold


# ------------------------------------------------------------------------------------------
# BLAS on one thread while calibrating
# ------------------------------------------------------------------------------------------

def test_calibrating_runs_blas_on_one_thread(monkeypatch):
    from threadpoolctl import threadpool_info

    import twin.calibration.workflow as wf

    seen = []
    monkeypatch.setattr(wf, "calibrate_imu", lambda logs, **kw: seen.append(
        [p["num_threads"] for p in threadpool_info() if p["user_api"] == "blas"]) or "done")
    done, skipped = wf.calibrate_imus({0: ["log"]})
    assert done == ["done"] and not skipped
    assert seen and all(n == 1 for n in seen[0])


# ------------------------------------------------------------------------------------------
# PX4's median filter: once per log, each fold's read from it
# ------------------------------------------------------------------------------------------

def test_the_median_filter_of_selected_rows_is_read_from_the_whole_logs():
    from twin.firmware import median_filter, median_filter_rows

    rng = np.random.default_rng(3)
    for n in (31, 40, 1000, 20_000):
        v = np.round(rng.normal(size=(n, 3)), 3)  # rounded: ties, as a logger's readings have
        whole = np.column_stack([median_filter(v[:, k] * 9.8) for k in range(3)])
        for trial in range(12):
            keep = np.ones(n, bool)
            for _ in range(int(rng.integers(0, 5))):  # held-out branches and dwells: gaps of any length
                a = int(rng.integers(0, n))
                keep[a:a + int(rng.integers(1, 200))] = False
            if trial % 4 == 0:
                keep = rng.random(n) < 0.9  # scattered rows
            idx = np.flatnonzero(keep)
            if idx.size < 31:
                continue
            ref = np.column_stack([median_filter(v[idx, k] * 9.8) for k in range(3)])
            assert np.array_equal(median_filter_rows(whole, v, idx, scale=9.8), ref)  # a selection: exact


def test_a_shared_median_filter_gives_the_same_px4_fit():
    X, y = simulated_tester_log(hours=3.0, rate_hz=1.0)
    shared = Px4Method().share_folds(X, y)
    for fold in protocol_as_used(X[:, 0], X[:, 1]).folds:
        mask = np.zeros(len(y), bool)
        mask[fold.train] = True
        a, b = Px4Method().fit(X, y, mask), Px4Method().fit(X, y, mask, shared=shared)
        assert a.cal_ == b.cal_ and np.array_equal(a.level_g_, b.level_g_)


def test_share_folds_is_computed_once_per_validation(monkeypatch):
    X, y = simulated_tester_log(hours=3.0, rate_hz=0.5)
    protocol = protocol_as_used(X[:, 0], X[:, 1])
    calls, real = [], Px4Method.share_folds
    monkeypatch.setattr(Px4Method, "share_folds", lambda self, X, y: calls.append(1) or real(self, X, y))
    validate({"px4": Px4Method(), "px4_as_applied": AsTheVehicleApplies(Px4Method())}, X[:, 0], X[:, 1], y, protocol)
    assert len(protocol.folds) > 1 and calls == [1]


# ------------------------------------------------------------------------------------------
# lags across gaps, and the orientation stage's pieces
# ------------------------------------------------------------------------------------------

@pytest.mark.parametrize("tau", [1e-9, 0.05, 3.0, 40.0, 600.0])
def test_a_lag_across_a_few_gaps_is_the_per_step_recursion(tau):
    from sim.drift import lowpass_at
    from twin.calibration.lag import clock_of, lag_on_clock

    rng = np.random.default_rng(0)
    t = np.arange(20_000) * 0.1
    t = np.delete(t, np.sort(rng.choice(np.arange(1, t.size - 1), 30, replace=False)))
    t[9000:] += 37.3  # and a long gap
    u = np.cumsum(rng.normal(size=t.size)) * 0.01 + 20.0
    clock = clock_of(t)
    assert clock.irregular is not None and 0 < clock.irregular.size <= 31  # filter runs, no compiled loop
    # measured ≤ 3e-13 °C: the same discretisation, rounded in another order
    np.testing.assert_allclose(lag_on_clock(t, u, tau, clock), lowpass_at(t, u, tau), rtol=0, atol=1e-11)


def test_a_jittered_clock_keeps_the_per_step_recursion():
    from twin.calibration.lag import clock_of

    t = np.cumsum(np.random.default_rng(1).uniform(0.09, 0.11, 5000))
    assert clock_of(t).irregular is None


def test_cutting_a_stretch_by_temperature_reads_each_piece_once():
    from twin.calibration.orientation import cut_by_temperature

    def quadratic(T, s0, s1, span_c):  # the definition, as it was written: the rest of the stretch per piece
        pieces, start = [], s0
        while start < s1:
            drift = np.abs(T[start:s1] - T[start])
            end = start + int(np.argmax(drift > span_c)) if np.any(drift > span_c) else s1
            pieces.append((start, max(end, start + 1)))
            start = max(end, start + 1)
        return pieces

    rng = np.random.default_rng(2)
    T = np.cumsum(rng.normal(0, 0.01, 200_000)) + np.linspace(-20, 50, 200_000)
    for s0, s1, span in [(0, 200_000, 2.0), (5, 100_003, 0.05), (0, 10, 2.0), (100, 101, 2.0), (7, 5000, 1e3)]:
        assert cut_by_temperature(T, s0, s1, span) == quadratic(T, s0, s1, span)


def test_a_lag_model_fitted_on_the_whole_logs_blocks_is_the_one_fitted_alone():
    X, y = simulated_tester_log(hours=3.0, rate_hz=4.0, thermometer_noise_c=0.01)  # searched on 1-s means
    shared = LagAwareCompensator().share_folds(X, y)
    assert shared.factor == 4
    for fold in protocol_as_used(X[:, 0], X[:, 1]).folds:
        mask = np.zeros(len(y), bool)
        mask[fold.train] = True
        alone, reused = LagAwareCompensator().fit(X, y, mask), LagAwareCompensator().fit(X, y, mask, shared=shared)
        assert alone.selected_.name == reused.selected_.name
        # the block sums about another level move the search's rounding: measured ≤ 1e-8 relative in
        # τ, 8e-10 mg in the coefficients and 4e-12 g in the prediction
        np.testing.assert_allclose(reused.tau_die_s_, alone.tau_die_s_, rtol=1e-7)
        np.testing.assert_allclose(reused.tau_rate_s_, alone.tau_rate_s_, rtol=1e-7)
        np.testing.assert_allclose(reused.coef_mg_, alone.coef_mg_, rtol=1e-7, atol=1e-9)
        held = np.concatenate([t.index for t in fold.tests])
        np.testing.assert_allclose(reused.predict(X)[held], alone.predict(X)[held], rtol=0, atol=1e-10)
