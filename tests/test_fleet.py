"""twin fleet: many units' logs analysed durably (local pool or Dask), the population view, and
simulated fleets whose truth is kept apart. Units are tiny (3-h programs at 0.5 Hz); the 200-unit
figures are benchmarks/bench_fleet.py's."""

import dataclasses
import json
import os
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
import yaml

from conftest import run_cli
from schemas import check_schema
from twin.fleet.ledger import LEDGER, append_record, exclusive, open_ledger, read_ledger
from twin.fleet.population import population, robust_z, table_rows
from twin.fleet.result import FleetRow, ParameterValue
from twin.fleet.runner import dask_client, run_units
from twin.fleet.scenario import draw_unit, load_fleet_scenario
from twin.fleet.simulate import score_against_truth, simulate_fleet
from twin.fleet.spec import FleetError, load_fleet_spec

BASE = {  # two ramp rates and dwells: a lag (rate-dependent) and a play loop (rate-independent) separate
    "seed": 0,
    "program": {"start_c": 25.0, "steps": [
        {"type": "hold", "dwell_s": 1200}, {"type": "ramp", "target_c": 70.0, "ramp_c_per_h": 90},
        {"type": "hold", "dwell_s": 1800}, {"type": "ramp", "target_c": -10.0, "ramp_c_per_h": 160},
        {"type": "hold", "dwell_s": 1800}, {"type": "ramp", "target_c": 25.0, "ramp_c_per_h": 90},
        {"type": "hold", "dwell_s": 1200}]},
    "chamber": {"thermometer": {"attached_to": "die", "tau_s": 0.0}},
    "device": {"effects": {"static_bias_tc": {"tc1_mg_per_c": 0.5}, "scale_factor_tc": {"tc1_ppm_per_c": 80.0}}},
    "test_plan": {"logger_rate_hz": 0.5},
    "twin": {"effects": ["static_bias_tc", "scale_factor_tc"]},
}
# clear effects (many times the noise of 10-s means), so every unit's truth must be found
FLEET = {
    "name": "tiny", "base": "base.yaml", "units": 6, "seed": 11,
    "vary": {"device.effects.static_bias_tc.tc1_mg_per_c": {"normal": [0.5, 0.1]}},
    "effects": {
        "thermal_lag": {"prevalence": 0.34, "set": {"chamber.thermometer.attached_to": "board"},
                        "draw": {"chamber.lumped.die_tau_s": {"uniform": [200.0, 300.0]}}},
        "thermal_hysteresis": {"prevalence": 0.33,
                               "draw": {"device.effects.thermal_hysteresis.k_mg_per_c": {"uniform": [0.4, 0.5]},
                                        "device.effects.thermal_hysteresis.half_width_c": {"uniform": [3.0, 4.0]}}},
    },
}


def _write_fleet(folder, **changes):
    folder.mkdir(parents=True, exist_ok=True)
    (folder / "base.yaml").write_text(yaml.safe_dump(BASE, sort_keys=False))
    (folder / "fleet.yaml").write_text(yaml.safe_dump({**FLEET, **changes}, sort_keys=False))
    return folder / "fleet.yaml"


@pytest.fixture(scope="module")
def fleet(tmp_path_factory):
    """Six simulated units, analysed once on one local worker."""
    root = tmp_path_factory.mktemp("fleet")
    sim = simulate_fleet(_write_fleet(root / "scn"), root / "sim")
    spec = load_fleet_spec(sim.spec)
    run = run_units(spec, root / "out", workers=1)
    return {"root": root, "sim": sim, "spec": spec, "run": run, "truth": json.loads((root / "sim/truth.json").read_text())}


def test_unit_draws_depend_on_seed_and_index_only(tmp_path):
    small = load_fleet_scenario(_write_fleet(tmp_path / "a"))
    large = load_fleet_scenario(_write_fleet(tmp_path / "b", units=40))
    for i in range(6):
        assert draw_unit(small, i) == draw_unit(large, i)  # unit i does not move when the fleet grows
    other = dataclasses.replace(small, seed=12)
    assert draw_unit(other, 0)[1]["parameters"] != draw_unit(small, 0)[1]["parameters"]
    # exclusive draws: prevalences are shares of one uniform draw, so no unit carries two effects
    kinds = [tuple(draw_unit(large, i)[1]["effects"]) for i in range(40)]
    assert all(len(k) <= 1 for k in kinds) and {("thermal_lag",), ("thermal_hysteresis",), ()} <= set(kinds)


def test_simulated_fleet_keeps_the_truth_apart_and_the_analysis_finds_it(fleet):
    truth, run = fleet["truth"], fleet["run"]
    header = (fleet["root"] / "sim/logs/unit0000.csv").read_text().splitlines()[0]
    assert header == "time_s,temperature_c,output_g,applied_g,run,power_on"  # logged columns only
    assert "truth" not in (fleet["root"] / "sim/fleet.yaml").read_text().split("\n", 1)[1]
    assert [r.unit for r in run.records] == [t["unit"] for t in truth["units"]]
    assert all(r.status == "ok" for r in run.records)
    for r, t in zip(run.records, truth["units"]):  # clear effects: every unit's family named, nothing else
        assert set(r.families) == set(t["families"]), (r.unit, r.named, t)
        if "thermal_lag" in r.named:  # the die's time constant recovered (board node shifts it a little)
            assert abs(r.parameters["thermal_lag.tau_s"].value / t["parameters"]["chamber.lumped.die_tau_s"] - 1) < 0.25
    pop = population(run.records)
    score = score_against_truth(pop, truth)
    assert all(abs(v["family_error_pp"]) < 1e-9 for v in score.values())
    assert pop.none_named.units == sum(not t["effects"] for t in truth["units"])


def test_rerun_skips_finished_units_and_redoes_a_torn_line(fleet, tmp_path):
    out = tmp_path / "out"
    shutil.copytree(fleet["root"] / "out", out)
    log = out / LEDGER
    lines = log.read_text().splitlines(keepends=True)
    log.write_text("".join(lines[:-1]) + lines[-1][:40])  # a kill during the last append
    (out / "units/unit0000/.compare.json.abc123xy.tmp").write_text("{")  # a killed atomic write
    run = run_units(fleet["spec"], out, workers=1)
    assert run.ran == 1 and run.skipped == 5 and run.torn_dropped and run.temporaries_removed == 1
    assert len(log.read_text().splitlines()) == 6 and len(read_ledger(log)) == 6
    assert table_rows(run.records) == table_rows(fleet["run"].records)
    again = run_units(fleet["spec"], out, workers=1)
    assert again.ran == 0 and again.skipped == 6


# lines as fleets wrote them before rows were typed (json.dumps of a dict, default=float): a NaN
# token, a calibrate row's nulls, an error row without the ok fields
LEGACY_LINES = [
    '{"kind": "twin-fleet-unit", "unit": "a", "files": ["a.csv"], "command": "compare", "named": ["thermal_lag"], '
    '"families": ["thermal_lag"], "confidence": "confident", "detected": true, "withheld": [{"effect": "e", '
    '"family": "f", "outranked_by": "g", "outranked_by_family": "h", "delta_bic": [12.5, 3.0]}], "finding": "lag", '
    '"parameters": {"thermal_lag.tau_s": {"value": 250.0, "unit": "s", "ci95": [240.0, 260.0]}, '
    '"thermal_lag.k_mg": {"value": NaN, "unit": "mg", "ci95": null}}, "rms_residual_mg": 0.02, '
    '"noise_floor_mg": 0.02, "residual_over_floor": 1.01, "heldout_rms_mg": 0.01, "samples": 5400, '
    '"reports": {"json": "units/a/compare.json", "html": "units/a/report.html"}, "status": "ok", "seconds": 1.5}',
    '{"kind": "twin-fleet-unit", "unit": "b", "files": ["b.ulg"], "command": "calibrate", "named": [], '
    '"families": [], "confidence": null, "detected": null, "withheld": [], "finding": "IMU 0: px4 px4", '
    '"recommended": {"0": {"px4": "px4", "ardupilot": null}}, "parameters": {"imu0.noise_floor_mg.z": '
    '{"value": 0.3, "unit": "mg", "ci95": null}}, "rms_residual_mg": 0.5, "noise_floor_mg": null, '
    '"residual_over_floor": null, "heldout_rms_mg": 0.5, "samples": 400, "reports": {"json": "units/b/cal.json"}, '
    '"status": "ok", "seconds": 0.5}',
    '{"kind": "twin-fleet-unit", "unit": "c", "files": ["c.csv"], "command": "compare", "status": "error", '
    '"error": "c.csv: empty", "seconds": 0.01}',
]


def test_a_ledger_written_before_rows_were_typed_is_read_back(tmp_path):
    """A fleet killed under the previous version resumes: its lines are read as typed rows, and the
    same rows written now read back to the same table."""
    old = tmp_path / "old.jsonl"
    old.write_text("\n".join(LEGACY_LINES) + "\n")
    rows = read_ledger(old)
    a, b, c = rows["a"], rows["b"], rows["c"]
    assert a.parameters["thermal_lag.tau_s"] == ParameterValue(250.0, "s", (240.0, 260.0))
    assert np.isnan(a.parameters["thermal_lag.k_mg"].value) and a.withheld[0].delta_bic == (12.5, 3.0)
    assert a.report == "units/a/report.html" and b.report == "units/b/cal.json" and c.report == ""
    assert b.recommended == {"0": {"px4": "px4", "ardupilot": None}} and b.noise_floor_mg is None
    assert not c.ok and c.error == "c.csv: empty" and c.named is None
    new = tmp_path / LEDGER
    for row in rows.values():
        append_record(new, row)
    again = read_ledger(new)
    assert "NaN" not in new.read_text()  # strict JSON: a NaN is written as null, and read back as NaN
    assert np.isnan(again["a"].parameters["thermal_lag.k_mg"].value)
    drop_nan = lambda rs: [{k: v for k, v in r.items() if v == v} for r in table_rows(rs)[1]]  # noqa: E731
    assert table_rows(list(again.values()))[0] == table_rows(list(rows.values()))[0]
    assert drop_nan(list(again.values())) == drop_nan(list(rows.values()))
    lines = new.read_text().splitlines()
    assert lines[0] == LEGACY_LINES[0].replace("NaN", "null") and lines[2] == LEGACY_LINES[2]  # the same line
    # a calibrate row leaves out the keys it has no value for (they were written as null)
    assert json.loads(lines[1]) == {k: v for k, v in json.loads(LEGACY_LINES[1]).items() if v is not None}


def test_a_foreign_ledger_line_is_refused_in_one_line(fleet, tmp_path):
    out = tmp_path / "out"
    out.mkdir()
    (out / LEDGER).write_text('{"key": "abc", "status": "ok"}\n')
    with pytest.raises(FleetError, match=r"units.jsonl:1: not a unit record of a fleet"):
        run_units(fleet["spec"], out)


def test_bad_unit_logs_are_rows_with_an_error(fleet, tmp_path):
    logs = tmp_path / "logs"
    logs.mkdir()
    good = fleet["spec"].units[0].files[0]
    shutil.copy(good, logs / "good.csv")
    (logs / "empty.csv").write_text("")
    (logs / "corrupt.csv").write_bytes(Path(good).read_bytes()[:3000] + b"\x00\xff,garbage,,\n1,2\n")
    (logs / "columns.csv").write_text("t,temp,acc\n0,25,1\n1,25,1\n")
    spec = load_fleet_spec(str(logs / "*.csv"), scenario=fleet["spec"].scenario)
    run = run_units(spec, tmp_path / "out", workers=2)
    by = {r.unit: r for r in run.records}
    assert by["good"].status == "ok"
    for unit in ("empty", "corrupt", "columns"):
        assert by[unit].status == "error" and f"{unit}.csv" in by[unit].error and "\n" not in by[unit].error
    assert population(run.records).errors == 3


def test_local_pool_and_dask_give_identical_tables(fleet, tmp_path):
    spec = load_fleet_spec(fleet["sim"].spec)
    spec.units = spec.units[:3]
    # a LocalCluster of threads: worker processes take tens of seconds to start on a loaded machine
    # (benchmarks/bench_fleet.py compares 200 units on a LocalCluster of processes)
    run = run_units(spec, tmp_path / "dask", workers=2, executor="dask", dask_processes=False)
    assert table_rows(run.records) == table_rows(fleet["run"].records[:3])


def test_a_dead_scheduler_is_one_line_after_a_short_timeout(monkeypatch):
    with pytest.raises(FleetError) as exc:
        dask_client("tcp://127.0.0.1:9", 1, connect_timeout_s=2.0)  # port 9 (discard): nothing listens
    assert "\n" not in str(exc.value) and "dask scheduler" in str(exc.value)
    # the short timeout is the one Dask waits for: what the client is asked for, not how long this
    # machine took (a fake client that records its arguments and fails as a dead scheduler does)
    import dask.distributed

    asked = []

    def unreachable(address, timeout=None, **kwargs):
        asked.append((address, timeout))
        raise OSError(f"Timed out trying to connect to {address} after {timeout} s")

    monkeypatch.setattr(dask.distributed, "Client", unreachable)
    with pytest.raises(FleetError) as exc:
        dask_client("tcp://127.0.0.1:9", 1, connect_timeout_s=2.0)
    assert asked == [("tcp://127.0.0.1:9", 2.0)]
    assert "\n" not in str(exc.value) and "within 2 s" in str(exc.value)


def test_killing_the_parent_ends_its_pool_workers(tmp_path):
    code = ("import time\nfrom concurrent.futures import ProcessPoolExecutor\nfrom twin.fleet.runner import die_with_parent\n"
            "ex = ProcessPoolExecutor(2, initializer=die_with_parent)\nfs = [ex.submit(time.sleep, 60) for _ in range(2)]\n"
            "time.sleep(60)\n")
    parent = subprocess.Popen([sys.executable, "-c", code])
    try:
        for _ in range(100):
            kids = subprocess.run(["pgrep", "-P", str(parent.pid)], capture_output=True, text=True).stdout.split()
            if len(kids) >= 2:
                break
            time.sleep(0.1)
        assert len(kids) >= 2
        os.kill(parent.pid, signal.SIGKILL)
        parent.wait()
        time.sleep(1.0)
        alive = [k for k in kids if os.path.exists(f"/proc/{k}") and open(f"/proc/{k}/stat").read().split()[2] != "Z"]
        assert not alive
    finally:
        parent.kill()


def test_robust_outliers_and_prevalence_on_known_records():
    rng = np.random.default_rng(0)
    values = 0.5 + 0.01 * rng.standard_normal(20)
    values[7] = 0.9  # 40 σ off
    recs = [FleetRow(unit=f"u{i:02d}", files=(), command="compare", status="ok", seconds=1.0,
                     named=("thermal_lag",) if i < 5 else (), families=("thermal_lag",) if i < 5 else (),
                     confidence="confident",
                     parameters={"static_bias_tc.tc1_mg_per_c": ParameterValue(float(values[i]), "mg/degC", None)})
            for i in range(20)]
    recs.append(FleetRow(unit="u99", files=(), command="compare", status="error", error="x.csv: empty", seconds=0.1))
    pop = population(recs)
    assert pop.prevalence["thermal_lag"].units == 5 and pop.prevalence["thermal_lag"].share == 0.25
    assert [o.unit for o in pop.outliers] == ["u07"] and pop.errors == 1
    z = robust_z(np.array([1.0, 2.0, 3.0, 4.0, 100.0]))
    assert z[2] == 0 and z[4] > 3.5  # the median is 0; one wild value does not drag the scale


def test_fleet_spec_errors_name_the_file_line_and_key(tmp_path):
    (tmp_path / "f.yaml").write_text("scenario: x.yaml\nunit: '*.csv'\n")
    with pytest.raises(FleetError, match=r"f.yaml:2: unknown key 'unit'; did you mean 'units'\?"):
        load_fleet_spec(tmp_path / "f.yaml")
    with pytest.raises(FleetError, match="compare needs the twin's scenario"):
        (tmp_path / "a.csv").write_text("x")
        load_fleet_spec(str(tmp_path / "*.csv"))
    with pytest.raises(FleetError, match="prevalences must sum to at most 1"):
        load_fleet_scenario(_write_fleet(tmp_path / "p", effects={k: {**v, "prevalence": 0.6}
                                                                   for k, v in FLEET["effects"].items()}))


def test_cli_fleet_resumes_and_writes_table_population_summary_and_json(fleet, tmp_path):
    out = tmp_path / "cli"
    shutil.copytree(fleet["root"] / "out", out)  # every unit finished: the rerun only rewrites the views
    r = run_cli("fleet", fleet["sim"].spec, "-o", str(out), "--workers", "2", "--json", "-")
    assert r.returncode == 0, r.stderr
    result = json.loads(r.stdout)
    check_schema(result, "fleet")  # the JSON is what `twin schema --result fleet` describes
    assert result["ok"] == 6 and result["ran"] == 0 and result["skipped"] == 6
    assert (out / "table.csv").read_text() == _table_csv(fleet, tmp_path)
    assert "<img src='data:image/png;base64," in (out / "summary.html").read_text()
    assert json.loads((out / "population.json").read_text())["prevalence"] == result["prevalence"]
    bad = run_cli("fleet", fleet["sim"].spec, "-o", str(out), "--executor", "ray")
    assert bad.returncode == 2 and bad.stderr.count("\n") == 1 and "--executor" in bad.stderr


def _table_csv(fleet, tmp_path):
    from twin.fleet.population import write_table

    write_table(tmp_path, fleet["run"].records)
    return (tmp_path / "table.csv").read_text()


def test_fleet_calibrate_command_per_unit(tmp_path):
    from logfixtures import chamber_run, write_ulog

    (tmp_path / "logs").mkdir()
    write_ulog(tmp_path / "logs" / "vehicle0.ulg", chamber_run(n=400))
    (tmp_path / "logs" / "vehicle1.ulg").write_bytes(b"ULog\x01")  # truncated: its row says why
    (tmp_path / "f.yaml").write_text("command: calibrate\nunits: logs\n")
    run = run_units(load_fleet_spec(tmp_path / "f.yaml"), tmp_path / "out", workers=1)
    assert [r.status for r in run.records] == ["ok", "error"], run.records
    assert "vehicle1.ulg" in run.records[1].error
    doc = json.loads((tmp_path / "out" / run.records[0].reports.json).read_text())
    check_schema(doc, "calibration")  # the same document twin calibrate writes
    assert doc["imus"] and run.records[0].recommended
    assert any(k.endswith("heldout_rms_mg.z") for k in run.records[0].parameters)


def test_an_output_that_is_a_file_is_one_line_and_the_file_is_kept(tmp_path):
    spec = tmp_path / "fleet.yaml"
    spec.write_text("scenario: x.yaml\n")
    for step in (open_ledger, lambda p: exclusive(p).__enter__()):  # the lock used to raise "File exists"
        with pytest.raises(FleetError, match="the output must be a folder, and this is a file"):
            step(spec)
    assert spec.read_text() == "scenario: x.yaml\n"
