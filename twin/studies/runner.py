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

SCHEDULER_TIMEOUT_S = 5.0  # a dead scheduler: one line after this, not a traceback after 30 s


def evaluate_run(job: dict, responses: list[str], plugins: list[str] | tuple = ()) -> dict:
    """Simulate one resolved scenario and compute its responses (run in a worker process, which
    loads the study's ``plugins`` first).

    Parameters
    ----------
    job : dict
        One run of :func:`twin.studies.design.plan` (``key``, ``yaml``, ``index``, ``replicate``,
        ``point``, ``seed``).
    responses : list of str
        The registered responses to compute.
    plugins : list of str
        Response modules to load first (``.py`` paths or module names).

    Returns
    -------
    dict
        The run record: the job's ``key``, ``index``, ``replicate``, ``point``, ``seed``; ``status``
        (``ok`` or ``error``); ``responses`` (name → value, in each response's unit) or ``error``
        (one line); ``seconds``, the wall time [s].
    """
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
    except (Exception, SystemExit) as exc:  # noqa: BLE001 - recorded (a plugin's SystemExit too), the study goes on
        out["status"] = "error"
        out["error"] = f"{type(exc).__name__}: {' '.join(str(exc).split())[:500]}"
    out["seconds"] = time.perf_counter() - t0
    return out


def _append(path: Path, record: dict) -> None:
    """Append one JSON line durably: a killed study never leaves a half record behind."""
    line = json.dumps(record) + "\n"
    with open(path, "a", encoding="utf-8") as f:
        f.write(line)
        f.flush()
        os.fsync(f.fileno())


def _drop_torn_line(path: Path) -> bool:
    """A kill in the middle of an append leaves a last line without its newline: cut it off, so
    the next record starts a line of its own and the torn run is run again. True if one was cut."""
    if not (path.is_file() and path.stat().st_size):
        return False
    with open(path, "rb+") as f:
        data = f.read()
        if data.endswith(b"\n"):
            return False
        f.truncate(data.rfind(b"\n") + 1)
        f.flush()
        os.fsync(f.fileno())
    return True


_OUTPUTS = ("table.csv", "table.h5", "analysis.json", "main_effects.png", "response_surface.png", "sobol.png")


def _remove_stale_temporaries(out_dir: Path) -> None:
    """Temporary files of a killed study's final write (``.table.h5.*.tmp`` ...) and of its plots."""
    from twin.io import remove_stale_temporaries

    remove_stale_temporaries(out_dir, _OUTPUTS)


def _die_with_parent() -> None:
    """Pool worker initialiser: end this worker when the study's process dies (a kill -9 included),
    rather than leave it computing runs nobody will record."""
    import signal
    import threading

    parent = os.getppid()
    try:  # Linux: the kernel signals us when the parent dies
        import ctypes

        ctypes.CDLL(None, use_errno=True).prctl(1, int(signal.SIGTERM))  # PR_SET_PDEATHSIG
    except (OSError, AttributeError):
        pass

    def watch() -> None:  # elsewhere (and as a backstop): poll the parent
        while os.getppid() == parent:
            time.sleep(1.0)
        os._exit(1)

    threading.Thread(target=watch, daemon=True).start()


def read_runs(path: Path) -> dict[str, dict]:
    """Finished runs by key. A torn last line (a kill during the append) is ignored, as is a torn
    record an older version left mid-file; any other line that is not a run record means the
    folder holds something else, and is an error.

    Parameters
    ----------
    path : Path
        ``runs.jsonl`` (missing: no run finished).

    Returns
    -------
    dict of str to dict
        Run key → run record (:func:`evaluate_run`); the last record of a key wins.

    Raises
    ------
    StudyError
        A file that is not UTF-8, or a line that is not a run record.
    """
    runs = {}
    if path.is_file():
        try:
            text = path.read_text(encoding="utf-8")
        except UnicodeDecodeError as exc:
            raise StudyError(f"{path}: not UTF-8 text (byte {exc.start}); expected the runs.jsonl of a study") from None
        lines = text.split("\n")
        for n, line in enumerate(lines, 1):
            try:
                r = json.loads(line) if line.strip() else None
            except json.JSONDecodeError:
                if n == len(lines) or line.startswith('{"key": '):  # torn: the run is done again
                    continue
                raise StudyError(f"{path}:{n}: not a run record of a study (expected one JSON object per line); "
                                 "give the study an output folder of its own") from None
            if r is None:
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


def run_design_points(study: Study, base: dict, out_dir: Path, workers: int = 1, executor: str = "local",
              scheduler: str | None = None, progress=None) -> list[dict]:
    """Run every pending job; return all finished runs in design order.

    Parameters
    ----------
    study : Study
    base : dict
        The base scenario's data.
    out_dir : Path
        The output folder (``runs.jsonl`` is appended there; created when missing).
    workers : int
        Parallel runs (local processes, or a new local Dask cluster's workers).
    executor : {"local", "dask"}
        Where the runs are computed.
    scheduler : str, optional
        Address of a running Dask scheduler (default: a local cluster).
    progress : callable, optional
        ``progress(record | None)``, called once per run (``None``: finished before).

    Returns
    -------
    list of dict
        The finished run records (:func:`evaluate_run`), in design order.

    Raises
    ------
    StudyError
        An output that is a file, or a scheduler that does not answer within
        ``SCHEDULER_TIMEOUT_S`` [s].
    """
    if out_dir.exists() and not out_dir.is_dir():
        raise StudyError(f"{out_dir}: the output must be a folder, and this is a file")
    out_dir.mkdir(parents=True, exist_ok=True)
    _remove_stale_temporaries(out_dir)
    log = out_dir / "runs.jsonl"
    done = read_runs(log)
    jobs = plan(study, base)
    pending = [j for j in jobs if not _finished(done.get(j["key"]), study.responses)]
    tick = progress or (lambda r: None)
    for _ in range(len(jobs) - len(pending)):
        tick(None)
    args = (study.responses, list(study.plugins))
    if pending:
        _drop_torn_line(log)
        if executor == "dask":
            from dask.distributed import Client, as_completed

            try:
                client = Client(scheduler, timeout=SCHEDULER_TIMEOUT_S) if scheduler else \
                    Client(processes=True, n_workers=max(1, workers), threads_per_worker=1)
            except (OSError, TimeoutError, ValueError, TypeError) as exc:
                raise StudyError(f"--scheduler {scheduler}: cannot reach the dask scheduler within "
                                 f"{SCHEDULER_TIMEOUT_S:g} s ({type(exc).__name__}: {' '.join(str(exc).split())[:160]}); "
                                 "expected a running scheduler, e.g. tcp://host:8786") from None
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

            with ProcessPoolExecutor(workers, initializer=_die_with_parent) as ex:
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
