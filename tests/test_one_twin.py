"""One twin from the log to the vehicle, validated the way it is used (calibrate today, fly tomorrow).

The TofuPilot thermal cycle (51.6 → −17.6 → 74.0 → 36.3 °C, three axes) is cut into the branches a
user would have on the day of calibration; ``twin calibrate`` sees only those, ``twin apply``
compensates the whole log with the default method, and the error is scored on the branches
calibrate never saw, against the PX4 cubic fitted on the same rows.
"""

import json
import shutil
import subprocess

import numpy as np
import pytest

from conftest import SHARED, run_in_process
from schemas import check_schema
from twin.calibration.branches import Fold, Protocol, protocol_as_used, split_branches
from twin.calibration.branches import TestSet as HeldOut
from twin.calibration.recommend import TOLERANCE, recommend
from twin.calibration.validate import IN_RANGE, Score, ValidationResult

TOFU = SHARED / "data" / "real" / "tofupilot_imu_thermal" / "imu_raw_data.tsv"
COLUMNS = ("time: timestamp\ntemperature: imu.temperature\nx: imu.acc.x\ny: imu.acc.y\nz: imu.acc.z\n"
           "time_unit: us\noutput_unit: m/s^2\n")


def _twin(*args):
    code, out, err = run_in_process([str(a) for a in args])
    assert code == 0, err
    return out


@pytest.fixture(scope="module")
def tofu(tmp_path_factory):
    """The log's rows, its columns file, and its heating/cooling branches as row ranges."""
    if not TOFU.exists():
        pytest.skip(f"{TOFU} not present")
    d = tmp_path_factory.mktemp("tofu")
    (d / "cols.yaml").write_text(COLUMNS)
    lines = TOFU.read_text().splitlines()
    (d / "log.tsv").write_text("\n".join(lines) + "\n")
    table = np.genfromtxt(TOFU, delimiter="\t", names=True)
    branches = [b for b in split_branches((table["timestamp"] - table["timestamp"][0]) * 1e-6,
                                          table["imutemperature"]) if b.kind != "dwell"]
    assert [b.kind for b in branches] == ["cooling", "heating", "cooling"]
    return d, lines, branches


def _calibrated(d, name, lines, rows):
    """Write the rows (all when None) as a log, calibrate it; return (calibration, the whole log, columns)."""
    part = d / f"{name}.tsv"
    part.write_text("\n".join([lines[0]] + [lines[1 + i] for i in (rows if rows is not None else
                                                                    range(len(lines) - 1))]) + "\n")
    _twin("calibrate", part, "--columns", d / "cols.yaml", "-o", d / f"{name}.json")
    return d / f"{name}.json", d / "log.tsv", "--columns", d / "cols.yaml"


def _scored(d, cal, method, rows) -> np.ndarray:
    """RMS [mg] per axis on ``rows`` of the whole log compensated by ``method`` (None: the default)."""
    out = d / "applied.csv"
    _twin("apply", cal, d / "log.tsv", "--columns", d / "cols.yaml", "-o", out, *(["--method", method] if method else []))
    table = np.genfromtxt(out, delimiter=",", names=True)
    assert table.size == len((d / "log.tsv").read_text().splitlines()) - 1  # the rows of the log, in order
    entry = json.loads(cal.read_text())["imus"][0]
    m = entry["methods"][method or entry["recommended"]["c"]]
    # the method's own level (what it was fitted to read when still): the constant the
    # accelerometer's ordinary calibration owns, taken from the training rows, never the test rows
    level = np.asarray(m["level_g"]) if "level_g" in m else np.asarray(m["coef_mg"])[:, 0] * 1e-3
    comp = np.column_stack([table[f"{a}_compensated_g"] for a in "xyz"])[rows]
    return np.sqrt(np.mean((comp - level) ** 2, axis=0)) * 1e3


def test_heating_only_the_default_is_the_cubic_because_nothing_validates_a_rate_term(tofu):
    d, lines, (cool1, heat, cool2) = tofu
    cal, *_ = _calibrated(d, "heating", lines, heat.index)
    entry = json.loads(cal.read_text())["imus"][0]
    verdicts = entry["recommendation"]["verdicts"]
    assert not verdicts["twin"]["eligible"] and verdicts["twin"]["folds"] == []  # no fold can validate a rate term
    assert "heat and cool" in verdicts["twin"]["reason"]
    cooling = np.r_[cool1.index, cool2.index]
    default, cubic = _scored(d, cal, None, cooling), _scored(d, cal, "px4", cooling)
    print("heating only → both cooling branches [mg]:", entry["recommended"]["c"], default, "cubic", cubic)
    assert np.all(default <= (1 + TOLERANCE) * cubic)


def test_first_cooling_and_heating_the_default_leaves_under_0_6_of_the_cubic_on_the_last_cooling(tofu):
    d, lines, (cool1, heat, cool2) = tofu
    cal, *_ = _calibrated(d, "c1heat", lines, np.r_[cool1.index, heat.index])
    entry = json.loads(cal.read_text())["imus"][0]
    assert entry["protocol"].startswith("held-out branches")
    default, cubic = _scored(d, cal, None, cool2.index), _scored(d, cal, "px4", cool2.index)
    print("cooling 1 + heating → cooling 2 [mg]:", entry["recommended"]["c"], default, "cubic", cubic)
    assert np.all(default <= 0.6 * cubic)


def _validation(rms: dict) -> ValidationResult:
    scores = tuple(Score(fold, m, test, tuple(r), 100, 0.0) for (fold, m), r in rms.items()
                   for test in ("overall", IN_RANGE))
    return ValidationResult(scores, (0.3, 0.3, 0.3), ("px4",) * 3, {})


def _protocol(**directions) -> Protocol:
    empty = HeldOut("t", np.arange(3), np.zeros(3, bool))
    return Protocol("p", tuple(Fold(name, np.arange(3), (empty,), "", d) for name, d in directions.items()))


def _verdict(rec, method):
    return next(v for v in rec.verdicts if v.method == method)


# RMS ratios to the cubic just either side of the rule's tolerance (its own constant); 1e-4 is far
# above the round-off of the ratios (1e-16) and far below the tolerance
WORSE_BEYOND, WORSE_WITHIN = 1 + TOLERANCE + 1e-4, 1 + TOLERANCE - 1e-4
BETTER_BEYOND, BETTER_WITHIN = 1 - TOLERANCE - 1e-4, 1 - TOLERANCE + 1e-4


def test_the_rule_takes_the_best_validated_and_never_one_worse_than_the_cubic_on_a_fold():
    both = ("heating", "cooling")
    p = _protocol(a=both, b=both)
    cubic = {("a", "px4"): (1, 1, 1), ("b", "px4"): (1, 1, 1)}
    good = _validation({**cubic, ("a", "twin"): (0.5, 0.5, 0.5), ("b", "twin"): (0.5, 0.5, 0.5)})
    assert recommend(good, p, ["twin", "px4"], {"twin"}).method == "twin"
    # better pooled, but worse than the cubic on one fold and axis by more than the tolerance: not the default
    worse = _validation({**cubic, ("a", "twin"): (0.2, 0.2, 0.2), ("b", "twin"): (0.5, WORSE_BEYOND, 0.5)})
    rec = recommend(worse, p, ["twin", "px4"], {"twin"})
    twin = _verdict(rec, "twin")
    assert rec.method == "px4" and not twin.eligible and twin.folds == ("a", "b")
    assert twin.worst_ratio == pytest.approx(WORSE_BEYOND, rel=1e-9) and "fold 'b'" in twin.reason
    # worse on that fold and axis by less than the tolerance: the default
    at_margin = _validation({**cubic, ("a", "twin"): (0.2, 0.2, 0.2), ("b", "twin"): (0.5, WORSE_WITHIN, 0.5)})
    rec = recommend(at_margin, p, ["twin", "px4"], {"twin"})
    assert rec.method == "twin" and _verdict(rec, "twin").eligible
    assert _verdict(rec, "twin").worst_ratio == pytest.approx(WORSE_WITHIN, rel=1e-9)


def test_a_rate_dependent_method_is_judged_only_on_folds_that_heat_and_cool():
    p = _protocol(one=("heating",), both=("heating", "cooling"))
    v = _validation({("one", "px4"): (1, 1, 1), ("both", "px4"): (1, 1, 1),
                     ("one", "twin"): (5, 5, 5), ("both", "twin"): (0.5, 0.5, 0.5),
                     ("one", "polynomial"): (0.9, 0.9, 0.9), ("both", "polynomial"): (0.95, 0.95, 0.95)})
    rec = recommend(v, p, ["twin", "polynomial", "px4"], {"twin"})
    verdict = {x.method: x for x in rec.verdicts}
    assert verdict["twin"].folds == ("both",) and verdict["polynomial"].folds == ("one", "both")
    assert rec.method == "twin"
    only_one = _protocol(one=("heating",))
    rec = recommend(_validation({("one", "px4"): (1, 1, 1), ("one", "twin"): (0.1, 0.1, 0.1)}), only_one,
                    ["twin", "px4"], {"twin"})
    assert rec.method == "px4" and "unvalidated" in rec.reason


def test_folds_know_whether_their_training_rows_heat_and_cool():
    t = np.arange(0.0, 9000.0, 2.0)
    cycle = 25 + 30 * np.sin(2 * np.pi * t / 6000.0)  # 1.5 cycles: heat, cool, heat
    p = protocol_as_used(t, cycle)
    assert p.folds and all(f.both_directions for f in p.folds)
    assert p.folds[-1].name.startswith("forward")
    for f in p.folds:
        held = np.concatenate([s.index for s in f.tests])
        assert not np.intersect1d(held, f.train).size
    heating = protocol_as_used(t, np.linspace(0, 60, t.size))
    assert [f.both_directions for f in heating.folds] == [False]
    two = protocol_as_used(t[:2250], cycle[:2250])  # heat then cool: the forward fold cuts the last branch
    assert [f.name.split(":")[0] for f in two.folds] == ["forward", "leave out"]  # each half of the last branch


def _relaxing_log(seed: int, noise_mg: float = 0.3, step_s: float = 5.0):
    """Two chamber cycles at two ramp rates; truth per axis: a cubic plus a Maxwell relaxation term."""
    from sim.drift import maxwell_relaxation

    rng = np.random.default_rng(seed)
    t = np.arange(0.0, 9000.0 + 2 * 5400.0, step_s)
    # one cycle of 150 min, then two of 90 min: two ramp rates, the temperature continuous throughout
    T = 25 + 30 * np.where(t < 9000, np.sin(2 * np.pi * t / 9000.0), np.sin(2 * np.pi * (t - 9000) / 5400.0))
    dT = T - 35.0
    truth = {"k": np.array([0.8, -0.5, 1.2]), "tau_s": 3000.0}
    relax = maxwell_relaxation(T - 25.0, step_s, truth["tau_s"])[:, None] * truth["k"] * 1e-3
    accel = np.column_stack([0.02 * dT * 1e-3 + 0.001, -0.03 * dT * 1e-3, -1 + 2e-4 * dT ** 2 * 1e-3]) + relax
    return t, T, accel + rng.normal(0, noise_mg * 1e-3, accel.shape), truth


def test_composed_effect_recovers_a_known_relaxation_and_reaches_the_noise_held_out():
    from twin.calibration.composed import ComposedCompensator
    from twin.calibration.lag import make_X
    from twin.calibration.validate import validate
    from twin.calibration.methods import Px4Method

    t, T, accel, truth = _relaxing_log(seed=4)
    X = make_X(t, T)
    est = ComposedCompensator(("stress_relaxation",)).fit(X, accel)
    for a, entry in enumerate(est.axes_):
        relax = next(e["values"] for e in entry["effects"] if e["name"] == "stress_relaxation")
        # 0.3 mg noise over 4320 rows: τ within 10 %, amplitudes within 5 % (several σ of the fit)
        assert abs(relax["tau_s"] / truth["tau_s"] - 1) < 0.10, relax
        assert abs(relax["k1_mg_per_c"] / truth["k"][a] - 1) < 0.05, relax
    protocol = protocol_as_used(t, T)
    assert all(f.both_directions for f in protocol.folds)
    v = validate({"composed": ComposedCompensator(("stress_relaxation",)), "px4": Px4Method()}, t, T, accel, protocol)
    # the white-noise floor is 0.3 mg: what the composed twin leaves held out is noise (10 % allowance
    # for the fitted parameters' own error); the cubic leaves the relaxation
    assert np.all(v.rms_mg("composed") <= 1.1 * 0.3), v.rms_mg("composed")
    assert np.all(v.rms_mg("px4") > 2 * v.rms_mg("composed"))


def test_compare_named_effects_are_composed_per_axis_applied_and_refused_for_c(tmp_path):
    from conftest import run_in_process as run
    from twin.calibration.deploy import correction_g
    from twin.calibration.lag import make_X

    t, T, accel, _ = _relaxing_log(seed=5, step_s=15.0)
    log = tmp_path / "table.csv"
    np.savetxt(log, np.column_stack([t, T, accel]), delimiter=",", header="time_s,temp_c,ax,ay,az", comments="")
    cols = ["--time-col", "time_s", "--temperature-col", "temp_c", "--x-col", "ax", "--y-col", "ay", "--z-col", "az"]
    finding = tmp_path / "compare.json"
    finding.write_text(json.dumps({"imus": [{"instance": 0, "axes": {"x": {"selected": ["stress_relaxation"]},
                                                                      "y": {"selected": []},
                                                                      "z": {"selected": ["stress_relaxation"]}}}]}))
    cal = tmp_path / "cal.json"
    code, out, err = run(["calibrate", str(log), *cols, "--effects-from", str(finding), "--with-effect", "aging_drift",
                          "-o", str(cal)])
    assert code == 0, err
    assert "compared x: static cubic + die lag + stress_relaxation" in out and "compared y: static cubic + die lag leaves" in out
    assert "the C header cannot (aging_drift)" in out
    doc = json.loads(cal.read_text())
    check_schema(doc, "calibration")  # composed twins: per-axis effects with their values
    entry = doc["imus"][0]
    stored = entry["methods"]["compared"]
    assert [[e["name"] for e in ax["effects"]] for ax in stored["axes"]] == [
        ["thermal_lag", "stress_relaxation"], ["thermal_lag"], ["thermal_lag", "stress_relaxation"]]
    # one implementation of the prediction: the stored document gives what the fitted estimator gave
    from twin.calibration.composed import ComposedCompensator

    est = ComposedCompensator({"x": ("stress_relaxation",), "z": ("stress_relaxation",)}).fit(make_X(t, T), accel)
    level = np.asarray(stored["coef_mg"])[:, 0] * 1e-3
    np.testing.assert_allclose(correction_g(stored, t, T) + level, est.predict(make_X(t, T)), atol=1e-9)
    code, out, err = run(["apply", str(cal), str(log), *cols[:0], "--columns", str(_columns(tmp_path)), "--method",
                          "compared", "-o", str(tmp_path / "applied.csv")])
    assert code == 0, err
    code, _, err = run(["firmware", str(cal), "--format", "c", "--method", "compared", "-o", str(tmp_path / "c.h")])
    assert code == 0 and "twin_composed_update" in (tmp_path / "c.h").read_text(), err
    # an effect a flight controller cannot evaluate (a device's age) has no C form: one line, no file
    code, _, err = run(["firmware", str(cal), "--format", "c", "--method", "twin+aging_drift", "-o",
                        str(tmp_path / "aging.h")])
    assert code == 2 and "'aging_drift' has no C form" in err and err.count("\n") == 1, err
    assert not (tmp_path / "aging.h").exists()


@pytest.mark.skipif(shutil.which("cc") is None, reason="no C compiler")
@pytest.mark.parametrize("real,tolerance_ug", [
    ("double", 1e-6),  # float64 against float64: rounding only
    # float32 state: a lag's dead band is ulp(T)/(2(1 − e)), 1 mK at 55 °C for τ = 3000 s at 5-s steps,
    # times the largest amplitude here (≈ 1 mg/°C): about 1 µg, three hundred times below the noise
    ("float", 1.0),
])
def test_composed_c_header_compiled_matches_apply(tmp_path, real, tolerance_ug):
    from test_lag_header import MAIN_C
    from twin.calibration.correction import correction_g
    from twin.firmware import G0_M_S2
    from twin.firmware.composed_header import composed_c_header

    t, T, _, _ = _relaxing_log(seed=4)
    values = [{"thermal_lag": {"tau_s": 40.0, "tau2_s": 0.0, "tc_mg_per_c": 0.8},
               "stress_relaxation": {"k1_mg_per_c": 0.8, "tau_s": 3000.0, "k2_mg_per_c": 0.2, "tau2_s": 20000.0,
                                     "reference_c": 25.0},
               "thermal_gradient": {"coef_mg_per_c_per_min": -1.5, "tau_s": 300.0},
               "thermal_hysteresis": {"k_mg_per_c": 0.3, "half_width_c": 2.0},
               "warmup": {"amplitude_mg": 1.2, "tau_s": 200.0}}] * 3
    data = {"kind": "ComposedCompensator", "reference_c": 35.0,
            "axes": [{"axis": ax, "applied_g": 0.0, "coef_mg": [5.0, 0.3 * sign, -2e-3, 1e-5],
                      "effects": [{"name": n, "values": v} for n, v in values[i].items()]}
                     for i, (ax, sign) in enumerate(zip("xyz", (1, -1, 2)))]}
    (tmp_path / "lag.h").write_text(composed_c_header(data, prefix="twin_lag", real=real))
    (tmp_path / "main.c").write_text(MAIN_C.replace("TWIN_LAG_N_AXES", "3"))
    subprocess.run(["cc", "-std=c99", "-O2", "-Wall", "-Wextra", "-pedantic", "-Werror", "-o", "main", "main.c", "-lm"],
                   cwd=tmp_path, check=True, capture_output=True)
    stdin = "".join(f"{int(round(a * 1e6))} {float(b)!r}\n" for a, b in zip(t, T))
    out = np.loadtxt(subprocess.run([str(tmp_path / "main"), "us"], input=stdin, capture_output=True, text=True,
                                    check=True).stdout.splitlines())
    assert out[0, 0] == 1 and np.all(out[1:, 0] == 0)  # started once, then stepped
    applied_g = correction_g(data, t, T)  # what twin apply subtracts
    assert np.max(np.abs(out[:, 1:] / G0_M_S2 - applied_g)) * 1e6 <= tolerance_ug


def _columns(d):
    path = d / "cols.yaml"
    path.write_text("time: time_s\ntemperature: temp_c\nx: ax\ny: ay\nz: az\n")
    return path


@pytest.mark.parametrize("doc,expected", [
    ({"selected": ["stress_relaxation"]}, "no 'imus'"),
    ({"imus": [{"instance": 0, "axes": {"w": {"selected": []}}}]}, "expected an axis x|y|z"),
    ({"imus": [{"instance": 0, "axes": {"x": {"selected": ["stress_relaxaton"]}}}]}, "did you mean"),
])
def test_a_compare_result_calibrate_cannot_use_is_one_line(tmp_path, doc, expected):
    t, T, accel, _ = _relaxing_log(seed=6)
    log = tmp_path / "table.csv"
    np.savetxt(log, np.column_stack([t, T, accel])[:50], delimiter=",", header="time_s,temp_c,ax,ay,az", comments="")
    (tmp_path / "c.json").write_text(json.dumps(doc))
    code, _, err = run_in_process(["calibrate", str(log), "--columns", str(_columns(tmp_path)), "--effects-from",
                                   str(tmp_path / "c.json"), "-o", str(tmp_path / "cal.json")])
    assert code == 2 and expected in err and err.count("\n") == 1, err
    assert not (tmp_path / "cal.json").exists()


def test_when_in_doubt_the_cubic_and_a_drift_no_firmware_can_carry_sends_it_back():
    both = ("heating", "cooling")
    p = _protocol(a=both)
    # better than the cubic on every axis, but by less than the tolerance: no evidence, the cubic
    near = _validation({("a", "px4"): (1, 1, 1), ("a", "twin"): (BETTER_WITHIN,) * 3})
    rec = recommend(near, p, ["twin", "px4"], {"twin"})
    assert rec.method == "px4" and not _verdict(rec, "twin").eligible and "not better" in rec.reason
    # better by more than the tolerance: the twin
    beyond = _validation({("a", "px4"): (1, 1, 1), ("a", "twin"): (BETTER_BEYOND,) * 3})
    rec = recommend(beyond, p, ["twin", "px4"], {"twin"})
    assert rec.method == "twin" and _verdict(rec, "twin").eligible
    clear = {("a", "px4"): (1, 1, 1), ("a", "twin"): (0.5, 0.5, 0.5)}
    assert recommend(_validation(clear), p, ["twin", "px4"], {"twin"}).method == "twin"
    # a composed twin with an aging drift, which no firmware runs, beats the twin held out by more
    # than the tolerance: the twin's thermal terms absorbed part of a drift in time, which will not
    # repeat tomorrow
    aged = _validation({**clear, ("a", "composed"): (0.5 * BETTER_BEYOND,) * 3})
    rec = recommend(aged, p, ["twin", "px4"], {"twin"}, undeployable={"composed": ["aging_drift"]})
    assert rec.method == "px4" and not _verdict(rec, "twin").eligible and "aging_drift" in rec.reason
    # level with the twin, within the tolerance: the twin stays
    level = _validation({**clear, ("a", "composed"): (0.5 * BETTER_WITHIN,) * 3})
    assert recommend(level, p, ["twin", "px4"], {"twin"}, undeployable={"composed": ["aging_drift"]}).method == "twin"


def test_composed_prediction_over_a_gap_is_the_per_step_recursion_the_header_runs():
    """Rows dropped as motion leave gaps; the effects filter at one step, so the composed twin is
    evaluated on a uniform grid and read back: over a 5-h gap it equals the exact per-step lags."""
    from sim.drift import lowpass_at
    from twin.calibration.composed import composed_drift_g

    axes = [{"axis": a, "applied_g": 0.0, "coef_mg": [0.0, 0.1, 0.0, 0.0], "effects": [
        {"name": "thermal_lag", "values": {"tau_s": 30.0, "tau2_s": 0.0, "tc_mg_per_c": 0.8}},
        {"name": "stress_relaxation", "values": {"k1_mg_per_c": 1.0, "tau_s": 3600.0, "k2_mg_per_c": 0.0,
                                                 "tau2_s": 36000.0, "reference_c": 25.0}}]} for a in "xyz"]
    t = np.r_[np.arange(0.0, 3600.0), 3600.0 + 5 * 3600.0 + np.arange(0.0, 600.0)]
    T = 20 + 0.01 * t
    die = lowpass_at(t, T, 30.0)
    exact_g = (0.1 * (die - 35.0) + 1.0 * (die - lowpass_at(t, die, 3600.0))) * 1e-3
    # once the clock is uneven the prediction was 15 mg off just after the gap; now: rounding
    assert np.max(np.abs(composed_drift_g(axes, 35.0, t, T)[:, 0] - exact_g)) < 1e-9
