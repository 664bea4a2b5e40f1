"""``units.jsonl``: one JSON line per finished unit, appended and fsynced before the next.

A kill loses at most the unit in flight. A kill during an append leaves a last line without its
newline: it is detected, cut off (so that unit runs again) and said so. A complete line that is not
a unit record of a fleet means the folder holds something else: refused in one line. A killed run
also leaves the temporary files of its atomic writes (``.NAME.XXXX.tmp``): the next run removes them.
"""

from __future__ import annotations

import fcntl
import json
import os
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path

from twin.fleet.result import KIND, FleetRow
from twin.fleet.spec import FleetError

LEDGER = "units.jsonl"
#: what a fleet writes atomically, in its folder and in each unit's folder
FOLDER_OUTPUTS = ("table.csv", "table.parquet", "population.json", "summary.html", "truth.json", "fleet.yaml")
UNIT_OUTPUTS = ("compare.json", "cal.json", "report.html")


@dataclass
class LedgerState:
    """What a run found in the ledger: the finished units, and what it repaired.

    Attributes
    ----------
    records : dict of str to FleetRow
        Finished units by id (:func:`read_ledger`).
    torn_dropped : bool
        A torn last line was cut off (that unit runs again).
    temporaries_removed : int
        Temporary files of a killed run's atomic writes that were removed.
    """

    records: dict[str, FleetRow]
    torn_dropped: bool = False
    temporaries_removed: int = 0


def append_record(path: Path, record: FleetRow) -> None:
    """Append one unit's row as a JSON line, durably (written, flushed and fsynced before returning).

    Parameters
    ----------
    path : Path
        ``units.jsonl``.
    record : FleetRow
        Written by :func:`twin.results.to_json` (its ``kind`` first).
    """
    from twin.results import to_json

    line = json.dumps(to_json(record), allow_nan=False) + "\n"
    with open(path, "a", encoding="utf-8") as f:
        f.write(line)
        f.flush()
        os.fsync(f.fileno())


def drop_torn_line(path: Path) -> bool:
    """Cut a last line that has no newline (a kill during its append); True if one was cut.

    Parameters
    ----------
    path : Path
        ``units.jsonl`` (missing or empty: nothing to cut).

    Returns
    -------
    bool
        True if a torn line was cut off (the file is fsynced).
    """
    if not path.is_file() or path.stat().st_size == 0:
        return False
    data = path.read_bytes()
    if data.endswith(b"\n"):
        return False
    with open(path, "rb+") as f:
        f.truncate(data.rfind(b"\n") + 1)
        f.flush()
        os.fsync(f.fileno())
    return True


def read_ledger(path: Path) -> dict[str, FleetRow]:
    """Finished units by id (the last record of a unit wins); a torn last line is ignored.

    Parameters
    ----------
    path : Path
        ``units.jsonl`` (missing: no unit finished).

    Returns
    -------
    dict of str to FleetRow
        Lines of any earlier run read back, those written before rows were typed included.

    Raises
    ------
    FleetError
        A complete line that is not a fleet's unit record, naming the file and line.
    """
    records: dict[str, FleetRow] = {}
    if not path.is_file():
        return records
    text = path.read_bytes().decode("utf-8", errors="replace")
    lines = text.split("\n")
    complete = lines[:-1]  # the part after the last newline is empty, or torn
    for n, line in enumerate(complete, 1):
        if not line.strip():
            continue
        try:
            r = json.loads(line)
        except json.JSONDecodeError:
            r = None
        row = None
        if isinstance(r, dict) and r.get("kind") == KIND and isinstance(r.get("unit"), str) and "status" in r:
            try:
                row = FleetRow.from_json(r)
            except (KeyError, TypeError, ValueError, AttributeError, IndexError):
                row = None
        if row is None:
            raise FleetError(f"{path}:{n}: not a unit record of a fleet (expected a JSON object with kind "
                             f"'{KIND}'); give the fleet an output folder of its own")
        records[row.unit] = row
    return records


def remove_temporaries(folder: Path) -> int:
    """Remove the temporary files (``.NAME.*.tmp``) a killed run's atomic writes left in ``folder``,
    its unit folders (``units/*``) and its logs (``logs/``, a simulated fleet's).

    Parameters
    ----------
    folder : Path
        The fleet's output folder.

    Returns
    -------
    int
        Files removed.
    """
    from twin.io import remove_stale_temporaries

    n = len(remove_stale_temporaries(folder, FOLDER_OUTPUTS))
    for sub in sorted((folder / "units").glob("*")) if (folder / "units").is_dir() else []:
        n += len(remove_stale_temporaries(sub, UNIT_OUTPUTS))
    logs = folder / "logs"
    if logs.is_dir():
        n += len(remove_stale_temporaries(logs, sorted({p.name.split(".")[1] + ".csv" for p in logs.glob(".*.csv.*.tmp")})))
    return n


def make_output_folder(out_dir: Path) -> None:
    """Create ``out_dir``; a file in its place is one line, not the OS's "File exists".

    Parameters
    ----------
    out_dir : Path
        The output folder (parents created too).

    Raises
    ------
    FleetError
        ``out_dir`` is a file.
    """
    if out_dir.exists() and not out_dir.is_dir():
        raise FleetError(f"{out_dir}: the output must be a folder, and this is a file")
    out_dir.mkdir(parents=True, exist_ok=True)


def open_ledger(out_dir: Path) -> LedgerState:
    """Prepare ``out_dir`` for a run: stale temporaries removed, a torn last line cut, records read.

    Parameters
    ----------
    out_dir : Path
        The output folder (created when missing).

    Returns
    -------
    LedgerState
        The finished units and what was repaired.

    Raises
    ------
    FleetError
        A folder that holds something else than a fleet's ledger (refused before anything in it
        is touched).
    """
    make_output_folder(out_dir)
    path = out_dir / LEDGER
    records = read_ledger(path)  # refuse a foreign folder before touching anything in it
    removed = remove_temporaries(out_dir)
    torn = drop_torn_line(path)
    return LedgerState(records, torn, removed)


@contextmanager
def exclusive(out_dir: Path):
    """Hold ``out_dir/.lock`` for the run: two fleets writing one ledger would interleave units.

    Parameters
    ----------
    out_dir : Path
        The output folder (created when missing).

    Yields
    ------
    None
        While the lock is held (an exclusive ``flock``, released on exit).

    Raises
    ------
    FleetError
        Another ``twin fleet`` holds the lock.
    """
    make_output_folder(out_dir)
    with open(out_dir / ".lock", "w") as f:
        try:
            fcntl.flock(f.fileno(), fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            raise FleetError(f"{out_dir}: another twin fleet is running on this folder") from None
        try:
            yield
        finally:
            fcntl.flock(f.fileno(), fcntl.LOCK_UN)
