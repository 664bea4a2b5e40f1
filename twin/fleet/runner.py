"""Running a fleet: every pending unit on a local process pool or a Dask cluster, each finished
unit appended durably to ``units.jsonl`` (see :mod:`twin.fleet.ledger`), so a rerun of the same
command skips the finished units and a killed run resumes without losing or duplicating any.

Workers of the local pool die with their parent (Linux: ``PR_SET_PDEATHSIG``), so a killed fleet
leaves no orphan analysing units. ``--scheduler`` attaches to a running Dask scheduler; one that
does not answer within ``connect_timeout_s`` is one line, not a hang.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

from twin.fleet.ledger import LEDGER, append_record, exclusive, open_ledger, read_ledger
from twin.fleet.result import FleetRow
from twin.fleet.spec import FleetError, FleetSpec
from twin.fleet.units import evaluate_unit
from twin.processes import die_with_parent


@dataclass
class FleetRun:
    """The rows of every finished unit (sorted by unit id) and what this run did.

    Attributes
    ----------
    records : list of FleetRow
        Every finished unit of the fleet, sorted by unit id.
    ran, skipped : int
        Units analysed by this run; units found finished.
    torn_dropped : bool
        A torn last line of ``units.jsonl`` was cut off (that unit ran again).
    temporaries_removed : int
        Temporary files of a killed run that were removed.
    notes : list of str
        One line per repair, for people.
    """

    records: list[FleetRow]
    ran: int = 0
    skipped: int = 0
    torn_dropped: bool = False
    temporaries_removed: int = 0
    notes: list[str] = field(default_factory=list)


def dask_client(scheduler: str | None, workers: int, connect_timeout_s: float = 10.0, processes: bool = True):
    """A client on ``scheduler``, or on a new LocalCluster of ``workers`` single-threaded processes
    (``processes=False``: threads of this process, which start in a second rather than tens).

    Parameters
    ----------
    scheduler : str or None
        Address of a running Dask scheduler, e.g. ``tcp://host:8786``; None: a new local cluster.
    workers : int
        Workers of the local cluster.
    connect_timeout_s : float
        How long a named scheduler has to answer [s].
    processes : bool
        Local cluster of processes (True) or of threads of this process.

    Returns
    -------
    distributed.Client
        The connected client (its ``cluster`` is the local cluster, if one was started).

    Raises
    ------
    FleetError
        The scheduler does not answer within ``connect_timeout_s`` (one line, with what to do).
    """
    try:
        from dask.distributed import Client, LocalCluster
    except ImportError:
        raise FleetError("--executor dask needs dask.distributed (pip install 'dask[distributed]')") from None
    if scheduler is None:
        cluster = LocalCluster(n_workers=max(1, workers), threads_per_worker=1, processes=processes,
                               dashboard_address=None)
        return Client(cluster)
    try:
        return Client(scheduler, timeout=connect_timeout_s)
    except (OSError, TimeoutError, ValueError) as exc:
        reason = " ".join(str(exc).split())[:160]
        raise FleetError(f"--scheduler {scheduler}: no Dask scheduler answered within {connect_timeout_s:g} s "
                         f"({reason}); start one with 'dask scheduler' and 'dask worker ADDRESS', or drop "
                         "--scheduler for a local cluster") from None


def _record(log: Path, rec: FleetRow, done: dict, tick) -> None:
    append_record(log, rec)
    done[rec.unit] = rec
    tick(rec)


def run_units(spec: FleetSpec, out_dir: Path, workers: int = 1, executor: str = "local",
              scheduler: str | None = None, progress=None, connect_timeout_s: float = 10.0,
              dask_processes: bool = True) -> FleetRun:
    """Analyse every unit not yet in ``out_dir/units.jsonl``; return all finished rows by unit id.

    A unit that errs is recorded with its error (and is not retried by a rerun: delete its line to
    retry it). ``progress(row | None)`` is called once per unit, skipped ones included.

    Parameters
    ----------
    spec : FleetSpec
        The fleet (:func:`twin.fleet.spec.load_fleet_spec`).
    out_dir : Path
        The output folder (``units.jsonl``, ``units/<id>/``); created when missing.
    workers : int
        Parallel units (local processes, or a new local Dask cluster's workers).
    executor : {"local", "dask"}
        Where the units are analysed.
    scheduler : str, optional
        Address of a running Dask scheduler (default: a local cluster).
    progress : callable, optional
        ``progress(row | None)`` (``None``: a unit finished before).
    connect_timeout_s : float
        How long a named scheduler has to answer [s].
    dask_processes : bool
        A local Dask cluster of processes (True) or of threads.

    Returns
    -------
    FleetRun
        Every finished row, by unit id, and what this run did.

    Raises
    ------
    FleetError
        An unknown executor, a foreign or locked output folder, a scheduler that does not answer.
    """
    if executor not in ("local", "dask"):
        raise FleetError(f"--executor must be 'local' or 'dask', got {executor!r}")
    out_dir = Path(out_dir)
    if out_dir.is_dir():  # a foreign folder is refused before the lock file is made in it
        read_ledger(out_dir / LEDGER)
    # a named scheduler is reached first: one that does not answer leaves no folder behind
    client = dask_client(scheduler, workers, connect_timeout_s, dask_processes) \
        if executor == "dask" and scheduler is not None else None
    try:
        return _run(spec, out_dir, workers, executor, scheduler, progress, connect_timeout_s, dask_processes, client)
    finally:
        if client is not None:
            client.close()


def _run(spec, out_dir, workers, executor, scheduler, progress, connect_timeout_s, dask_processes, client) -> FleetRun:
    """:func:`run_units` once the output folder is known usable (``client``: a connected scheduler)."""
    with exclusive(out_dir):
        state = open_ledger(out_dir)
        log = out_dir / LEDGER
        done = dict(state.records)
        pending = [u for u in spec.units if u.id not in done]
        tick = progress or (lambda r: None)
        for _ in range(len(spec.units) - len(pending)):
            tick(None)
        settings, where = spec.settings(), str(out_dir.resolve())
        jobs = [{"unit": u.id, "files": u.files} for u in pending]
        if jobs and executor == "dask":
            from dask.distributed import as_completed

            own = client is None
            client = client or dask_client(scheduler, workers, connect_timeout_s, dask_processes)
            try:
                futures = [client.submit(evaluate_unit, j, settings, where, pure=False) for j in jobs]
                for fut in as_completed(futures):
                    _record(log, fut.result(), done, tick)
            finally:
                if own:  # a local cluster started here ends here; a named scheduler is closed by run_units
                    cluster = client.cluster
                    client.close()
                    if cluster is not None:
                        cluster.close()
        elif jobs and workers > 1:
            from concurrent.futures import ProcessPoolExecutor, as_completed

            with ProcessPoolExecutor(workers, initializer=die_with_parent) as ex:
                futures = [ex.submit(evaluate_unit, j, settings, where) for j in jobs]
                for fut in as_completed(futures):
                    _record(log, fut.result(), done, tick)
        else:
            for j in jobs:
                _record(log, evaluate_unit(j, settings, where), done, tick)
    ids = {u.id for u in spec.units}
    records = [done[k] for k in sorted(done) if k in ids]
    notes = []
    if state.torn_dropped:
        notes.append(f"{log}: its last line was torn by a kill; dropped, and that unit ran again")
    if state.temporaries_removed:
        notes.append(f"removed {state.temporaries_removed} temporary file(s) a killed run left in {out_dir}")
    return FleetRun(records, len(jobs), len(spec.units) - len(jobs), state.torn_dropped, state.temporaries_removed, notes)
