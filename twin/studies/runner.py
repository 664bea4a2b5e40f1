"""Running a study: one run per worker call, finished runs appended durably to ``runs.jsonl``.

Each finished run is one JSON line, written and fsynced before the next: a killed study loses at
most the run in flight, and running the same command again skips every finished run (by the key
of its resolved scenario). A failing run is recorded with its error and the others go on.
"""

from __future__ import annotations

import json
import os
import time
from pathlib import Path

from twin.studies.design import plan
from twin.studies.responses import RunContext, get_response, load_plugin
from twin.studies.spec import Study, StudyError


def evaluate_run(job: dict, responses: list[str], plugins: list[str] | tuple = ()) -> dict:
    """Simulate one resolved scenario and compute its responses (run in a worker process, which
    loads the study's ``plugins`` first)."""
    from twin.model.scenario import parse_scenario

    t0 = time.perf_counter()
    out = {"key": job["key"], "index": job["index"], "replicate": job["replicate"], "point": job["point"],
           "seed": job["seed"]}
    try:
        for spec in plugins:
            load_plugin(spec)
        registered = [get_response(name) for name in responses]
        run = RunContext(parse_scenario(job["yaml"], f"<run {job['index']}>"), job)
        run.dataset  # every run simulates, whatever its responses read
        out["responses"] = {r.name: r.evaluate(run) for r in registered}
        out["status"] = "ok"
    except Exception as exc:  # recorded, and the study goes on
        out["status"] = "error"
        out["error"] = f"{type(exc).__name__}: {exc}"
    out["seconds"] = time.perf_counter() - t0
    return out


def _append(path: Path, record: dict) -> None:
    """Append one JSON line durably: a killed study never leaves a half record behind."""
    line = json.dumps(record) + "\n"
    with open(path, "a", encoding="utf-8") as f:
        f.write(line)
        f.flush()
        os.fsync(f.fileno())


def _end_torn_line(path: Path) -> None:
    """A kill in the middle of a write leaves a line without its newline: end it, so the next
    record starts a line of its own (the torn line is then skipped on reading)."""
    if path.is_file() and path.stat().st_size:
        with open(path, "rb+") as f:
            f.seek(-1, os.SEEK_END)
            if f.read(1) != b"\n":
                f.write(b"\n")
                f.flush()
                os.fsync(f.fileno())


def read_runs(path: Path) -> dict[str, dict]:
    """Finished runs by key (a torn line from a kill is ignored; a line that is JSON but not a run
    record means the folder holds something else, and is an error)."""
    runs = {}
    if path.is_file():
        for n, line in enumerate(path.read_text().splitlines(), 1):
            try:
                r = json.loads(line)
            except json.JSONDecodeError:
                continue
            if not (isinstance(r, dict) and isinstance(r.get("key"), str) and "status" in r):
                raise StudyError(f"{path}:{n}: not a run record of a study (expected an object with 'key' and "
                                 f"'status'); give the study an output folder of its own")
            runs[r["key"]] = r
    return runs


def _finished(record: dict | None, responses: list[str]) -> bool:
    """Done: failed (recorded as such), or ok with every response asked for (a study that asks
    for a new response runs again the runs finished without it)."""
    if record is None:
        return False
    return record["status"] != "ok" or all(r in record.get("responses", {}) for r in responses)


def run_study(study: Study, base: dict, out_dir: Path, workers: int = 1, executor: str = "local",
              scheduler: str | None = None, progress=None) -> list[dict]:
    """Run every pending job; return all finished runs in design order."""
    if out_dir.exists() and not out_dir.is_dir():
        raise StudyError(f"{out_dir}: the output must be a folder, and this is a file")
    out_dir.mkdir(parents=True, exist_ok=True)
    log = out_dir / "runs.jsonl"
    done = read_runs(log)
    jobs = plan(study, base)
    pending = [j for j in jobs if not _finished(done.get(j["key"]), study.responses)]
    tick = progress or (lambda r: None)
    for _ in range(len(jobs) - len(pending)):
        tick(None)
    args = (study.responses, list(study.plugins))
    if pending:
        _end_torn_line(log)
        if executor == "dask":
            from dask.distributed import Client, as_completed

            client = Client(scheduler) if scheduler else Client(processes=True, n_workers=max(1, workers),
                                                                threads_per_worker=1)
            try:
                futures = [client.submit(evaluate_run, j, *args, pure=False) for j in pending]
                for fut in as_completed(futures):
                    rec = fut.result()
                    _append(log, rec)
                    tick(rec)
            finally:
                client.close()
        elif workers > 1:
            from concurrent.futures import ProcessPoolExecutor, as_completed

            with ProcessPoolExecutor(workers) as ex:
                futures = [ex.submit(evaluate_run, j, *args) for j in pending]
                for fut in as_completed(futures):
                    rec = fut.result()
                    _append(log, rec)
                    tick(rec)
        else:
            for j in pending:
                rec = evaluate_run(j, *args)
                _append(log, rec)
                tick(rec)
    done = read_runs(log)
    return [done[j["key"]] for j in jobs if j["key"] in done]
