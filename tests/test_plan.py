"""``twin plan`` (issue 29): the candidate tests, the rivals read from a finding, the expected
separation as physics (signatures that are the same cannot be separated by any test, one that is
odd in g needs a second orientation), and the command as a user runs it."""

from __future__ import annotations

import json
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
import yaml

from conftest import ROOT, run_cli
from twin.errors import TwinError
from twin.model.scenario import load_scenario
from twin.model.simulate import time_base
from twin.fleet.population import wilson_ci95
from twin.plan.check import check_plan
from twin.plan.hypotheses import NONE, WALK, Hypothesis, hypotheses_from_finding
from twin.plan.programs import ChamberLimits, PlannedTest, candidate_programs
from twin.plan.scenarios import base_scenario, load, with_hypothesis, with_program
from twin.plan.separation import separation

LAG_SCENARIO = ROOT / "scenarios" / "hidden_thermal_lag.yaml"


def test_candidates_stay_within_budget_and_chamber_limits():
    limits = ChamberLimits(min_c=-20, max_c=70, max_ramp_c_per_h=120, min_ramp_c_per_h=30,
                           orientations=["fixed", "flip"], max_power_ons=2)
    programs = candidate_programs(limits, budget_h=10.0)
    assert programs
    for p in programs:
        assert p.hours() <= 10.0 + 1e-9
        assert all(30 <= r <= 120 for r in p.ramp_c_per_h)
        assert p.orientation in ("fixed", "flip") and 1 <= p.power_ons <= 2
        temps = [p.start_c] + [s["target_c"] for s in p.steps() if "target_c" in s]
        assert min(temps) >= -20 and max(temps) <= 70
    # at its design, each candidate runs as many cycles (loops) as fit: one more would break the budget
    p = next(p for p in programs if p.shape == "cycles")
    more = PlannedTest(p.low_c, p.high_c, p.start_c, p.ramp_c_per_h, p.dwell_s, p.cycles + 1, p.orientation,
                       p.power_ons)
    assert more.hours() > 10.0
    loops = [p for p in programs if p.shape == "loops"]
    assert loops and all(p.loops >= 2 and p.cycles == 1 and p.power_ons == 1 for p in loops)
    assert all(-20 <= p.loop_low_c < p.loop_high_c <= 70 and set(p.loop_ramp_c_per_h) == {40.0, 120.0} for p in loops)
    p = loops[0]
    assert replace(p, loops=p.loops + 1).hours() > 10.0
    # a soak holds the start temperature for the whole budget, the runs of a flip sharing it
    soaks = [p for p in programs if p.shape == "soak"]
    assert {(p.orientation, p.power_ons) for p in soaks} == {(o, n) for o in ("fixed", "flip") for n in (1, 2)}
    assert all(p.hours() == pytest.approx(10.0) and len(p.steps()) == 1 for p in soaks)


def test_logger_rates_stay_within_the_logger_and_the_sensor():
    assert ChamberLimits().logger_rates() == [1.0, 2.0, 3.0, 5.0, 10.0]
    assert ChamberLimits(max_logger_rate_hz=5.0).logger_rates() == [1.0, 2.0, 3.0, 5.0]
    assert ChamberLimits().logger_rates(odr_hz=2.5) == [1.0, 2.0]
    assert ChamberLimits(logger_rate_hz=2.0, max_logger_rate_hz=2.0).logger_rates() == [2.0]
    with pytest.raises(ValueError, match="max_logger_rate_hz"):
        ChamberLimits(logger_rate_hz=2.0, max_logger_rate_hz=1.0)
    p = PlannedTest(-40, 85, 25, (60,), 3600, 1, "fixed", 1, 5.0, 3, 0.0, 60.0, (60.0, 180.0))
    assert p.test_plan()["logger_rate_hz"] == 5.0 and "then 3 loops 0/60 °C at 60, 180 °C/h" in p.label()
    turns = [s["target_c"] for s in p.steps() if s["type"] == "ramp"]
    assert turns == [85, -40, 60, 0, 60, 0, 60, 0, 25]


def test_the_race_keeps_the_design_the_diagnosis_reads_best():
    """Successive halving on a stand-in diagnosis: the design whose truths stand furthest from the
    decision rule wins, every design starts on the first round's seeds, the runs match the count a
    progress bar is told."""
    from twin.plan.trials import Outcome, TrialScore, race, race_jobs

    quality = [0.01, 0.03, 0.08, 0.02, 0.05]  # mean held-out gain over the rule's minimum
    calls = []

    def runner(fn, jobs):  # a gain margin drawn about the design's quality, on seeds common to the designs
        calls.extend(jobs)
        out = []
        for scn, h, seed in jobs:
            g = scn["q"] + 0.02 * np.random.default_rng(seed).standard_normal()
            out.append(Outcome(h.effect if g > 0 else NONE, g > 0, g, np.inf))
        return out

    hyps = [Hypothesis("warmup"), Hypothesis("aging_drift")]
    best, scores = race([{"q": q} for q in quality], hyps, 12, runner)
    assert best == 2 and scores[best].seeds == 12
    assert len(calls) == race_jobs(len(quality), len(hyps), 12)
    assert all(s.seeds >= 3 for s in scores)
    # the margins see what a handful of seeds cannot count: all named, one far nearer the threshold
    near = TrialScore(6, {"a": [Outcome("a", True, g, np.inf) for g in (0.002, 0.02, 0.005, 0.03, 0.001, 0.015)]})
    far = TrialScore(6, {"a": [Outcome("a", True, g, np.inf) for g in (0.10, 0.12, 0.11, 0.09, 0.12, 0.10)]})
    assert near.rate() == far.rate() == {"a": 1.0} and near.key() < far.key()
    # a walk that takes the evidence on some seeds (−inf) counts as it comes
    walked = TrialScore(4, {"a": [Outcome("a", True, 0.1, np.inf)] * 3 + [Outcome(NONE, False, 0.1, -np.inf)]})
    assert walked.expected_rate()["a"] < 0.75


def test_program_hours_match_the_simulated_time_base():
    """The duration the planner budgets is the duration the simulator runs."""
    p = PlannedTest(-40, 85, 25, (30, 120), 1800, 2, "flip", 3)
    base = base_scenario(load_scenario(LAG_SCENARIO), None)
    loaded = load(with_program(base, p.program(), p.test_plan()))
    t = time_base(loaded)
    assert t[-1] + 1.0 / loaded.scenario.test_plan.logger_rate_hz == pytest.approx(p.run_hours() * 3600, abs=1.0)
    assert loaded.scenario.test_plan.runs == 2 and len(loaded.scenario.test_plan.power_on_s) == 3


def test_identical_signatures_cannot_be_separated_and_orientation_separates_scale_factor():
    """Physics invariants of the criterion.

    * A die lag τ behind the board thermometer, seen through a linear bias tempco b₁ with no
      scale-factor tempco, leaves r = −b₁·τ·LP_τ(dT/dt): exactly a gradient term of the same τ. No
      chamber program separates them (expected ΔBIC ≈ 0, against ~10⁵ for the lag's own evidence).
    * A scale-factor tempco is odd in g: with one orientation the twin's bias tempco absorbs it
      (ΔBIC ≈ 0); a flip or a tumble makes it stand out.
    """
    base = base_scenario(load_scenario(LAG_SCENARIO), None)
    base["device"]["effects"] = {"static_bias_tc": {"tc1_mg_per_c": 0.8}, "scale_factor_tc": {"tc1_ppm_per_c": 0.0}}
    p = PlannedTest(-40, 85, 25, (60, 240), 1800, 2, "fixed", 1)
    hyps = [Hypothesis("thermal_lag", {"tau_s": 300.0}),
            Hypothesis("thermal_gradient", {"coef_mg_per_c_per_min": 4.0, "tau_s": 300.0}), Hypothesis(NONE)]
    s = separation(with_program(base, p.program(), p.test_plan()), hyps, draws=1)
    lag_own, lag_vs_gradient = s.expected_delta_bic[0, 2], s.expected_delta_bic[0, 1]
    assert lag_own > 1e4
    assert lag_vs_gradient < 1e-4 * lag_own

    base["twin"] = {"effects": ["static_bias_tc"]}
    base["device"]["effects"] = {"static_bias_tc": {"tc1_mg_per_c": 0.8}}
    sf = [Hypothesis("scale_factor_tc", {"tc1_ppm_per_c": 80.0}), Hypothesis(NONE)]
    dbic = {}
    for orientation in ("fixed", "flip", "tumble"):
        p = PlannedTest(-40, 85, 25, (120,), 1800, 1, orientation, 1)
        dbic[orientation] = separation(with_program(base, p.program(), p.test_plan()), sf, draws=1).expected_delta_bic[0, 1]
    assert dbic["fixed"] < 1.0
    assert dbic["flip"] > 1e3 and dbic["tumble"] > 1e3


def _finding(**over) -> dict:
    cand = lambda e, sig, **amp: {"effect": e, "significant": sig, "parameters": {},  # noqa: E731
                                  "amplitudes": {k: {"value": v, "ci95_half_width": 0.1 * abs(v)} for k, v in amp.items()}}
    f = {"effects": ["static_bias_tc", "scale_factor_tc"], "selected": ["stress_relaxation"],
         "rivals": ["thermal_gradient"], "withheld": [], "untestable": [],
         "aliases": [{"effects": ["stress_relaxation", "thermal_gradient", "thermal_hysteresis"],
                      "families": ["hysteresis", "thermal_lag"], "remedy": ""}],
         "candidates": [cand("stress_relaxation", True, k1_mg_per_c=0.4), cand("thermal_gradient", True,
                        coef_mg_per_c_per_min=0.6), cand("thermal_hysteresis", False, k_mg_per_c=0.3)]}
    f.update(over)
    return f


def test_rivals_from_a_finding():
    hyps = hypotheses_from_finding(_finding())
    assert [(h.effect, h.source) for h in hyps] == [("stress_relaxation", "named"), ("thermal_gradient", "rival")]
    assert hyps[0].values["k1_mg_per_c"] == 0.4 and hyps[0].amplitude_sd["k1_mg_per_c"] == pytest.approx(0.04 / 1.96)
    # nothing named: the untestable identifiable effects, one per family, against "none"
    f = _finding(selected=[], rivals=[], candidates=[], aliases=[], untestable=[
        {"effect": "scale_factor_tc", "family": "scale_factor", "reason": "", "remedy": ""},
        {"effect": "probe_offset", "family": "probe", "reason": "", "remedy": ""}],
        effects=["static_bias_tc"])
    assert [h.effect for h in hypotheses_from_finding(f)] == ["scale_factor_tc", NONE]
    assert [h.effect for h in hypotheses_from_finding(_finding(), ["warmup", "aging_drift"])] == ["warmup", "aging_drift"]
    with pytest.raises(TwinError, match="already in the twin"):
        hypotheses_from_finding(_finding(), ["static_bias_tc", "warmup"])
    with pytest.raises(TwinError, match="fewer than two"):
        hypotheses_from_finding(_finding(selected=[], rivals=[], candidates=[], aliases=[]))


def test_drawn_parameters_are_seeded_and_within_bounds():
    h = Hypothesis("thermal_gradient", {"coef_mg_per_c_per_min": 0.6, "tau_s": 1400.0}, {"coef_mg_per_c_per_min": 0.1})
    a = [h.draw(np.random.default_rng(3)) for _ in range(50)]
    b = [h.draw(np.random.default_rng(3)) for _ in range(50)]
    assert a == b
    assert all(5.0 <= d["tau_s"] <= 1500.0 for d in a)
    lag = with_hypothesis(base_scenario(load_scenario(LAG_SCENARIO), None), Hypothesis("thermal_lag", {"tau_s": 250.0}))
    assert lag["chamber"]["lumped"]["die_tau_s"] == 250.0 and "thermal_lag" not in lag["device"]["effects"]


def test_a_wandering_bias_is_as_large_as_what_the_named_effect_explained(tmp_path):
    """The bias random walk rival: its size is the residual the named effect removed, its time the
    effect's; it reaches the simulated sensor as a Gauss–Markov bias of that standard deviation; and
    naming nothing is the right answer when it is true."""
    f = _finding(rms_residual_g=1.5e-3, rms_after_selected_g=0.9e-3)
    f["candidates"][0]["parameters"] = {"tau_s": 7200.0}
    hyps = hypotheses_from_finding(f, ["stress_relaxation", WALK])
    walk = hyps[1]
    assert walk.values == pytest.approx({"bias_instability_mg": 1.2, "bias_instability_tau_s": 7200.0})
    assert walk.draw(np.random.default_rng(5)) == walk.draw(np.random.default_rng(5))
    # a 24-h soak at 1 Hz with a 600-s correlation time holds ~144 independent wanders: the sample
    # standard deviation is within 20 % of σ (its own spread is ~6 %)
    test = PlannedTest(-40, 85, 25, (60.0,), 86400.0, 0, "fixed", 1)
    scn = with_hypothesis(with_program(base_scenario(load_scenario(LAG_SCENARIO), None), test.program(), test.test_plan()),
                          walk, {"bias_instability_mg": 1.2, "bias_instability_tau_s": 600.0})
    from twin.model.simulate import simulate

    wander = simulate(load(scn), seed=3)["truth/noise_bias_instability_g"][...]
    assert np.std(wander) * 1e3 == pytest.approx(1.2, rel=0.2)
    rates = check_plan(scn, hyps, 4, {}, runner=lambda fn, jobs: [NONE] * len(jobs))
    assert {r.truth: r.named_first for r in rates} == {"stress_relaxation": 0, WALK: 4}


def test_wilson_interval_reference_values():
    """Wilson (1927) score interval, the one the check's rates use; reference values computed by hand
    from the closed form."""
    assert wilson_ci95(0, 10) == pytest.approx((0.0, 0.27754), abs=1e-5)
    assert wilson_ci95(5, 10) == pytest.approx((0.23659, 0.76341), abs=1e-5)
    assert wilson_ci95(50, 50)[0] == pytest.approx(0.92865, abs=1e-5)


def test_plan_command_designs_a_flip_for_a_scale_factor_tempco(tmp_path):
    """As a user runs it: a finding on one orientation, a small chamber, a plan checked by simulation."""
    scn = yaml.safe_load(LAG_SCENARIO.read_text())
    scn["twin"] = {"effects": ["static_bias_tc"]}
    (tmp_path / "s.yaml").write_text(yaml.safe_dump(scn))
    (tmp_path / "chamber.yaml").write_text("min_c: -20\nmax_c: 60\nmin_ramp_c_per_h: 120\nmax_ramp_c_per_h: 120\n"
                                           "orientations: [fixed, flip]\nmax_power_ons: 1\n")
    # the finding of one orientation: the scale-factor family and a package stress untestable
    untestable = [{"effect": e, "family": f, "reason": "", "remedy": ""} for e, f in (
        ("comb_expansion", "scale_factor"), ("package_stress", "bias_tc"), ("probe_offset", "probe"),
        ("scale_factor_tc", "scale_factor"))]
    finding = {"effects": ["static_bias_tc"], "selected": [], "rivals": [], "withheld": [], "aliases": [],
               "candidates": [], "untestable": untestable, "noise_floor_g": 1.5e-3, "sample_rate_hz": 1.0,
               "parameters": {"static_bias_tc": {"tc1_mg_per_c": {"value": 0.8}}}}
    (tmp_path / "finding.json").write_text(json.dumps(finding))
    out, js = tmp_path / "next.yaml", tmp_path / "plan.json"
    r = run_cli("plan", str(tmp_path / "finding.json"), str(tmp_path / "s.yaml"), "--budget-h", "7",
                "--chamber", str(tmp_path / "chamber.yaml"), "--draws", "1", "--finalists", "0", "--check-seeds", "1",
                "-o", str(out), "--json", str(js))
    assert r.returncode == 0, r.stderr
    result = json.loads(js.read_text())
    # one representative per family (the fitted scale-factor tempco, not the geometric comb term); the
    # package stress, which no chamber program shows against the twin's bias tempco, set aside
    assert [x["effect"] for x in result["rivals"]] == ["scale_factor_tc", NONE]
    assert result["set_aside"] == ["package_stress"]
    assert result["plan"]["orientation"] == "flip" and result["plan"]["chamber_hours"] <= 7
    assert result["plan"]["worst_expected_delta_bic"] > 100 * max(b["worst_expected_delta_bic"] for b in result["baselines"])
    assert {c["truth"] for c in result["check"]} == {"scale_factor_tc", NONE}
    text = out.read_text()
    assert text.startswith("# twin plan:") and "step  kind" in text
    loaded = load_scenario(out)  # ready for twin run
    assert loaded.scenario.test_plan.run_applied_g == [1.0, -1.0]
    assert "scale_factor_tc" in yaml.safe_load(text)["device"]["effects"]  # the leading rival, to simulate


@pytest.mark.parametrize("args, fragment", [
    (["--rivals", "warmup"], "at least two rivals"),
    (["--rivals", "warmup,no_such_effect"], "no_such_effect"),
    (["--rivals", "warmup,aging_drift", "--budget-h", "0.6"], "--budget-h"),
    (["--rivals", "warmup,aging_drift", "--chamber", "CHAMBER"], "max_ramp"),
])
def test_plan_bad_input_exits_2_with_one_line(tmp_path, args, fragment):
    (tmp_path / "c.yaml").write_text("min_c: -20\nmax_c: 60\nmax_ramp: 120\n")
    args = [str(tmp_path / "c.yaml") if a == "CHAMBER" else a for a in args]
    r = run_cli("plan", str(LAG_SCENARIO), *args, "-o", str(tmp_path / "n.yaml"), "--check-seeds", "0")
    assert r.returncode == 2, r.stderr
    assert len(r.stderr.strip().splitlines()) == 1 and fragment in r.stderr, r.stderr
    assert not (tmp_path / "n.yaml").exists()


def test_plan_refuses_to_overwrite_its_input(tmp_path):
    target = tmp_path / "s.yaml"
    target.write_text(Path(LAG_SCENARIO).read_text())
    r = run_cli("plan", str(target), "--rivals", "warmup,aging_drift", "-o", str(target))
    assert r.returncode == 2 and "overwrite an input" in r.stderr


@pytest.mark.parametrize("executor, workers", [("local", 1), ("local", 2), ("dask", 1)])
def test_jobs_come_back_in_order_on_every_executor(executor, workers):
    from twin.plan.check import job_client, run_jobs

    seen = []
    with job_client(executor, None, workers) as client:
        out = run_jobs(abs, [-3, 1, -2, 5], workers=workers, client=client, progress=lambda k, n: seen.append((k, n)))
    assert out == [3, 1, 2, 5]
    assert seen[-1] == (4, 4)
