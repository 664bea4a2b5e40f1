"""Fleet benchmark (issue 15 items 2 and 4), written as JSON: a simulated fleet analysed blind.

1. ``scenarios/fleet_mixed.yaml``: 200 units × 6 h at 10 Hz (216,001 rows each), 26 % with a die
   lag, 17 % with hysteresis (the realised draws), simulated on 2 workers; the truth stays in
   ``truth.json``, which the fleet's analysis never reads.
2. ``twin fleet`` on a local pool of 2 workers: units per minute; estimated prevalence of each
   effect (share of units whose finding names it) against the truth, in percentage points.
3. The same on a dask LocalCluster of 2 workers: units per minute, and the table compared with 2.
4. 1 → 2 worker speed-up on the first ``--speedup-units`` units (local pool).
5. ``twin fleet`` started as a process, SIGKILLed when half the units are done, its workers checked
   gone, then rerun: the ledger must hold exactly one row per unit.
Side by side: what a user otherwise writes, a shell loop of ``twin compare`` (one process per unit).

Usage: python benchmarks/bench_fleet.py [--units 200] [--json out/bench_fleet.json] [--work out/bench_fleet]
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

for _v in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):  # the pool is the parallelism
    os.environ.setdefault(_v, "1")

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "benchmarks"))

from _common import write_json  # noqa: E402


def _fleet_scenario(work: Path, units: int) -> Path:
    """scenarios/fleet_mixed.yaml with another unit count (the draws of unit i do not depend on it)."""
    import yaml

    data = yaml.safe_load((ROOT / "scenarios/fleet_mixed.yaml").read_text())
    data["units"] = units
    data["base"] = str(ROOT / "scenarios" / data["base"])
    path = work / "fleet.yaml"
    path.write_text(yaml.safe_dump(data, sort_keys=False))
    return path


def _analyse(spec, out: Path, workers: int, executor: str) -> tuple[float, list[dict]]:
    from twin.fleet.population import population, write_population, write_table
    from twin.fleet.runner import run_units

    shutil.rmtree(out, ignore_errors=True)
    t0 = time.perf_counter()
    run = run_units(spec, out, workers, executor)
    seconds = time.perf_counter() - t0
    pop = population(run.records)
    write_table(out, run.records)
    write_population(out, pop)
    return seconds, run.records


def _children(pid: int) -> list[int]:
    out = subprocess.run(["pgrep", "-P", str(pid)], capture_output=True, text=True).stdout.split()
    return [int(p) for p in out]


def _alive(pid: int) -> bool:
    try:
        with open(f"/proc/{pid}/stat") as f:
            return f.read().split()[2] != "Z"
    except OSError:
        return False


def _rows(path: Path) -> list[str]:
    return [json.loads(line)["unit"] for line in path.read_text().splitlines() if line.strip()]


def kill_and_resume(spec_path: Path, out: Path, units: int) -> dict:
    """Start twin fleet, SIGKILL it at half the units, check its workers died, rerun."""
    shutil.rmtree(out, ignore_errors=True)
    cmd = [sys.executable, "-m", "twin.cli", "fleet", str(spec_path), "-o", str(out), "--workers", "2"]
    proc = subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    ledger = out / "units.jsonl"
    while proc.poll() is None and (not ledger.is_file() or len(ledger.read_text().splitlines()) < units // 2):
        time.sleep(0.2)
    workers = _children(proc.pid)
    os.kill(proc.pid, signal.SIGKILL)
    proc.wait()
    at_kill = len(_rows(ledger))
    time.sleep(3.0)
    orphans = [p for p in workers if _alive(p)]
    t0 = time.perf_counter()
    rerun = subprocess.run(cmd + ["--json", "-"], capture_output=True, text=True)
    rows = _rows(ledger)
    return {"rows_at_kill": at_kill, "workers_at_kill": len(workers), "workers_alive_3s_after_kill": len(orphans),
            "rerun_exit_code": rerun.returncode, "rerun_seconds": time.perf_counter() - t0,
            "rows_after_rerun": len(rows), "distinct_units_after_rerun": len(set(rows)),
            "exactly_one_row_per_unit": len(rows) == units and len(set(rows)) == units}


def shell_loop(spec, out: Path, n: int) -> dict:
    """What a user otherwise writes: ``for f in logs/*.csv; do twin compare SCENARIO $f --json ...; done``."""
    out.mkdir(parents=True, exist_ok=True)
    t0 = time.perf_counter()
    for u in spec.units[:n]:
        subprocess.run([sys.executable, "-m", "twin.cli", "compare", spec.scenario, *u.files, "--json", str(out / f"{u.id}.json")],
                       check=True, capture_output=True)
    s = time.perf_counter() - t0
    return {"units": n, "seconds": s, "units_per_minute": 60 * n / s}


def prevalence_scores(records: list, truth: dict) -> dict:
    """Estimated against true prevalence, three ways (see score_against_truth), and per-unit agreement."""
    from twin.fleet.population import population
    from twin.fleet.simulate import score_against_truth

    score = score_against_truth(population(records), truth)
    truth_of = {t["unit"]: set(t["effects"]) for t in truth["units"]}
    fam_of = {t["unit"]: set(t["families"]) for t in truth["units"]}
    first = lambda r: set((r.families or ())[:1])  # noqa: E731
    return {
        "prevalence": score,
        # by name: the finding names the effect itself; by family: or another effect of its family
        # (a die lag named thermal_gradient, bias ∝ dT/dt, is the same physics to first order);
        # primary: the first-named effect's family (forward selection adds secondary effects)
        "prevalence_within_5pp_by_name": all(abs(v["error_pp"]) <= 5 for v in score.values()),
        "prevalence_within_5pp_by_family": all(abs(v["family_error_pp"]) <= 5 for v in score.values()),
        "prevalence_within_5pp_primary_family": all(abs(v["primary_error_pp"]) <= 5 for v in score.values()),
        "per_unit": {
            "units": len(records),
            "named_exactly_the_truth": sum(set(r.named or ()) == truth_of[r.unit] for r in records),
            "families_exactly_the_truth": sum(set(r.families or ()) == fam_of[r.unit] for r in records),
            "first_family_is_the_truth": sum(first(r) == fam_of[r.unit] for r in records),
            "a_second_effect_named": sum(len(r.named or ()) > 1 for r in records),
            "median_seconds": sorted(r.seconds for r in records)[len(records) // 2]},
    }


def rescore(path: Path, work: Path) -> None:
    """Recompute the prevalence figures of an existing run from its ledger (no analysis rerun)."""
    from twin.fleet.ledger import read_ledger

    res = json.loads(path.read_text())
    res.pop("machine", None)
    records = [read_ledger(work / "local2/units.jsonl")[k] for k in sorted(read_ledger(work / "local2/units.jsonl"))]
    res.update(prevalence_scores(records, json.loads((work / "sim/truth.json").read_text())))
    res["rescored_from"] = str(work / "local2/units.jsonl")
    write_json(path, res)


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--units", type=int, default=200)
    ap.add_argument("--speedup-units", type=int, default=30)
    ap.add_argument("--loop-units", type=int, default=10)
    ap.add_argument("--work", default=str(ROOT / "out/bench_fleet"))
    ap.add_argument("--json", default=str(ROOT / "out/bench_fleet.json"))
    ap.add_argument("--rescore", action="store_true", help="recompute the prevalence figures from the last run's ledger")
    a = ap.parse_args()
    if a.rescore:
        rescore(Path(a.json), Path(a.work))
        return
    from twin.fleet.population import population, table_rows
    from twin.fleet.simulate import simulate_fleet
    from twin.fleet.spec import load_fleet_spec

    work = Path(a.work)
    work.mkdir(parents=True, exist_ok=True)
    res: dict = {"units": a.units, "load_average_1_5_15_min_at_start": list(os.getloadavg())}
    t0 = time.perf_counter()
    sim = simulate_fleet(_fleet_scenario(work, a.units), work / "sim", workers=2)
    res["simulate"] = {"seconds": time.perf_counter() - t0, "written": sim.written, "rows_per_unit": None}
    first = sorted((work / "sim/logs").glob("*.csv"))[0]
    res["simulate"]["rows_per_unit"] = sum(1 for _ in first.open()) - 1
    print("simulated", res["simulate"], flush=True)
    spec = load_fleet_spec(work / "sim/fleet.yaml")
    truth = json.loads((work / "sim/truth.json").read_text())

    s_local, rec_local = _analyse(spec, work / "local2", 2, "local")
    pop = population(rec_local)
    res["local_2_workers"] = {"seconds": s_local, "units_per_minute": 60 * a.units / s_local, "ok": pop.ok,
                              "errors": pop.errors, "confidence": dict(pop.confidence)}
    res.update(prevalence_scores(rec_local, truth))
    print("local", res["local_2_workers"], res["prevalence"], flush=True)

    s_dask, rec_dask = _analyse(spec, work / "dask2", 2, "dask")
    res["dask_local_cluster_2_workers"] = {"seconds": s_dask, "units_per_minute": 60 * a.units / s_dask,
                                           "table_identical_to_local": table_rows(rec_dask) == table_rows(rec_local),
                                           "table_csv_identical": (work / "dask2/table.csv").read_bytes()
                                           == (work / "local2/table.csv").read_bytes()}
    print("dask", res["dask_local_cluster_2_workers"], flush=True)

    sub = load_fleet_spec(work / "sim/fleet.yaml")
    sub.units = sub.units[:a.speedup_units]
    s1, _ = _analyse(sub, work / "sub1", 1, "local")
    s2, _ = _analyse(sub, work / "sub2", 2, "local")
    res["speedup"] = {"units": len(sub.units), "seconds_1_worker": s1, "seconds_2_workers": s2, "speedup": s1 / s2}
    print("speedup", res["speedup"], flush=True)

    res["kill_and_rerun"] = kill_and_resume(work / "sim/fleet.yaml", work / "killed", a.units)
    print("kill", res["kill_and_rerun"], flush=True)
    res["shell_loop_twin_compare"] = shell_loop(spec, work / "loop", a.loop_units)
    write_json(a.json, res)


if __name__ == "__main__":
    main()
