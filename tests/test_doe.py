"""Design-of-experiment studies: table and plots, resume after SIGKILL, dask = local, bad files."""

import json
import os
import signal
import subprocess
import sys
import time

import pytest

from conftest import ROOT, run_cli
from twin.studies.doe import load_study, plan, read_runs
from twin.errors import ScenarioError

STUDY = """\
name: tiny
base: {base}
seed: 3
logger_rate_hz: 0.2
factors:
  device.effects.aging_drift.rate_mg_per_h: {{levels: [0.05, 0.3]}}
  program.cycles: {{levels: [1, 2]}}
design: {{type: full_factorial}}
replicates: 2
responses: [drift_pp_mg, chamber_hours, residual_rms_mg]
"""


def _study(tmp_path, text=None, name="s.yaml"):
    f = tmp_path / name
    f.write_text(text or STUDY.format(base=ROOT / "scenarios" / "hidden_aging.yaml"))
    return f


def test_doe_writes_table_and_plots(tmp_path):
    out = tmp_path / "doe"
    r = run_cli("doe", str(_study(tmp_path)), "-o", str(out), "--json", "-")
    assert r.returncode == 0, r.stderr
    res = json.loads(r.stdout)
    assert res["runs"] == res["planned"] == 8 and res["failed"] == 0
    lines = (out / "table.csv").read_text().splitlines()
    assert len(lines) == 9 and lines[0].startswith("index,replicate,status")
    for f in ("table.h5", "analysis.json", "main_effects.png", "response_surface.png"):
        assert (out / f).is_file(), f
    me = res["main_effects"]["program.cycles"]["chamber_hours"]["means"]
    assert me["2"] == pytest.approx(2 * me["1"])  # two cycles cost twice the chamber time
    assert "device.effects.aging_drift.rate_mg_per_h × program.cycles" in res["interactions"]


def test_killed_study_resumes_without_loss_or_duplicates(tmp_path):
    study = _study(tmp_path)
    out = tmp_path / "doe"
    env = {**os.environ, "PYTHONWARNINGS": "ignore"}
    proc = subprocess.Popen([sys.executable, "-m", "twin.cli", "doe", str(study), "-o", str(out)], cwd=ROOT, env=env,
                            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    log = out / "runs.jsonl"
    deadline = time.time() + 120
    while time.time() < deadline and len(read_runs(log)) < 3:
        time.sleep(0.2)
    proc.send_signal(signal.SIGKILL)
    proc.wait()
    before = len(read_runs(log))
    assert 0 < before < 8, before  # killed part-way
    r = run_cli("doe", str(study), "-o", str(out), "--json", "-")
    assert r.returncode == 0, r.stderr
    rows = (out / "table.csv").read_text().splitlines()[1:]
    keys = [tuple(line.split(",")[:2]) for line in rows]
    assert len(keys) == 8 and len(set(keys)) == 8  # one row per design point and replicate
    lines = [json.loads(x) for x in log.read_text().splitlines() if x.strip()]
    assert len({x["key"] for x in lines}) == len(lines) == 8  # nothing run twice


def test_dask_executor_gives_the_same_table(tmp_path):
    pytest.importorskip("distributed")
    study = _study(tmp_path)
    local = run_cli("doe", str(study), "-o", str(tmp_path / "local"), "--workers", "2")
    dask = run_cli("doe", str(study), "-o", str(tmp_path / "dask"), "--executor", "dask", "--workers", "2")
    assert local.returncode == 0 and dask.returncode == 0, local.stderr + dask.stderr
    assert (tmp_path / "local" / "table.csv").read_text() == (tmp_path / "dask" / "table.csv").read_text()


@pytest.mark.parametrize("change,fragment", [
    (("program.cycles", "program.cylces"), "did you mean 'program.cycles'"),
    (("aging_drift.rate_mg_per_h", "aging_drift.rate_mg_per_hr"), "did you mean 'rate_mg_per_h'"),
    (("{levels: [1, 2]}", "{range: [3, 3]}"), "empty range"),
    (("type: full_factorial", "type: latin_hypercube, points: 400"), "more than max_runs"),
    (("[drift_pp_mg,", "[drift_pp,"), "did you mean 'drift_pp_mg'"),
    (("replicates: 2", "replicate: 2"), "did you mean 'replicates'"),
])
def test_bad_study_files(tmp_path, change, fragment):
    text = STUDY.format(base=ROOT / "scenarios" / "hidden_aging.yaml").replace(*change)
    with pytest.raises(ScenarioError) as exc:
        load_study(_study(tmp_path, text))
    assert fragment in str(exc.value)
    r = run_cli("doe", str(tmp_path / "s.yaml"), "-o", str(tmp_path / "o"))
    assert r.returncode == 2 and fragment in r.stderr


def test_runs_are_seeded_from_study_seed_and_index(tmp_path):
    study, base, _ = load_study(_study(tmp_path))
    a, b = plan(study, base), plan(study, base)
    assert [j["key"] for j in a] == [j["key"] for j in b]
    assert len({j["seed"] for j in a}) == len(a)


@pytest.mark.parametrize("path", sorted((ROOT / "scenarios").glob("study_*.yaml")), ids=lambda p: p.stem)
def test_example_studies_validate(path):
    study, base, _ = load_study(path)
    assert len(plan(study, base)) <= study.max_runs


def test_multi_run_compensated_ratio_tests_the_last_cycle_of_every_run(tmp_path):
    """The DOE splits train/test as ``twin benchmark`` does: a sample's cycle is read from its time
    within its run, so a study of two runs tests on the last cycle of each (not on all of run 2)."""
    import numpy as np

    from fitting import FeatureSet, PolynomialCompensator
    from twin.model.scenario import parse_scenario
    from twin.model.simulate import simulate
    from twin.studies.doe import evaluate_run

    text = STUDY.format(base=ROOT / "scenarios" / "hidden_aging.yaml").replace(
        "program.cycles: {levels: [1, 2]}", "program.cycles: {levels: [2]}\n  test_plan.runs: {levels: [2]}").replace(
        "[drift_pp_mg, chamber_hours, residual_rms_mg]", "[compensated_mse_ratio]").replace("replicates: 2", "")
    study, base, _ = load_study(_study(tmp_path, text))
    job = plan(study, base)[0]
    rec = evaluate_run(job, study.responses)
    assert rec["status"] == "ok", rec.get("error")
    loaded = parse_scenario(job["yaml"], "<run>")
    ds = simulate(loaded)
    t, run = ds["time_s"], ds["test/run_index"].astype(int)
    within = t - np.array([t[run == k].min() for k in range(2)])[run]
    cycle = np.array([s.cycle for s in loaded.program.segments])[loaded.program.segment_index(within)]
    test = cycle == 1
    assert test[run == 0].any() and test[run == 1].any() and (~test[run == 1]).any()
    X = FeatureSet(("T",)).transform(ds["temperature/thermometer_c"], t)
    y = ds["output/output_g"] - ds["test/applied_g"]
    err = y[test] - PolynomialCompensator(max_order=4).fit(X[~test], y[~test]).predict(X[test])
    noise = ds["truth/noise_white_g"] + ds["truth/noise_bias_instability_g"] + ds["truth/quantisation_g"]
    assert rec["responses"]["compensated_mse_ratio"] == float(np.var(err) / np.mean(noise[test] ** 2))


def test_run_time_errors_exit_2_with_one_line(tmp_path):
    """A folder whose runs.jsonl holds something else: the study stops at run time with one line."""
    out = tmp_path / "doe"
    out.mkdir()
    (out / "runs.jsonl").write_text('{"note": "not a run"}\n')
    r = run_cli("doe", str(_study(tmp_path)), "-o", str(out))
    assert r.returncode == 2, r.stderr
    assert r.stderr.startswith("twin: error: ") and "runs.jsonl:1: not a run record" in r.stderr
    assert len(r.stderr.strip().splitlines()) == 1
    target = tmp_path / "a_file"
    target.write_text("")
    r = run_cli("doe", str(_study(tmp_path)), "-o", str(target))
    assert r.returncode == 2 and "must be a folder" in r.stderr and "Traceback" not in r.stderr


SMALL = STUDY.replace("  program.cycles: {{levels: [1, 2]}}\n", "").replace("replicates: 2", "replicates: 1")


def test_resume_after_a_torn_line_and_with_a_new_response(tmp_path):
    """A record torn by a kill does not swallow the next one; a response added later is computed
    for the runs finished without it."""
    study = _study(tmp_path, SMALL.format(base=ROOT / "scenarios" / "hidden_aging.yaml").replace(
        "[drift_pp_mg, chamber_hours, residual_rms_mg]", "[chamber_hours]"))
    out = tmp_path / "doe"
    out.mkdir()
    (out / "runs.jsonl").write_text('{"key": "0123456789abcdef", "index": 0, "repl')  # torn, no newline
    r = run_cli("doe", str(study), "-o", str(out), "--json", "-")
    assert r.returncode == 0, r.stderr
    assert json.loads(r.stdout)["runs"] == 2 and len(read_runs(out / "runs.jsonl")) == 2
    study.write_text(study.read_text().replace("[chamber_hours]", "[chamber_hours, drift_pp_mg]"))
    r = run_cli("doe", str(study), "-o", str(out), "--json", "-")
    assert r.returncode == 0, r.stderr
    rows = (out / "table.csv").read_text().splitlines()
    assert rows[0].endswith("chamber_hours,drift_pp_mg,error") and len(rows) == 3
    assert all(line.split(",")[-2] not in ("", "nan") for line in rows[1:])
