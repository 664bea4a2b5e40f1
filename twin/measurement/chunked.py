"""Large delimited logs read in chunks straight into the arrays of a :class:`Measurement`.

A week at 100 Hz is 60 M rows (2 GB of CSV). Read whole, the parser's six float64 columns
(2.9 GB), its buffers and the copies made from them peaked at 7.9 GB. Here the same parser with
the same options (pandas' C parser, every field float64) hands over :data:`CHUNK_ROWS` rows at a
time, and each chunk is converted (time origin and unit, temperature and output units, run as
int16, power as bool) into preallocated arrays of the final dtypes. The arithmetic is the same
element by element, so the arrays are bit for bit those of the in-memory path
(tests/test_readers.py); the parser is not changed, so no value can round differently.

Only clean files are read here. Anything else — a parse error, a ragged row, a missing or
non-finite value, a missing column, a run or power flag that is not a whole number in range, fewer
than ten rows — returns ``None``, and the caller reads the file as before, naming file, line and
column. Not chosen: Arrow's streaming reader (as fast on one thread; it parsed all 51.8 M values of
the 24-h benchmark log to the same bits as pandas, but it is another float parser, and the
in-memory path's values are the contract).
"""

from __future__ import annotations

import os
from collections.abc import Callable, Iterable
from pathlib import Path

import numpy as np

from twin.measurement.columns import (
    RUN_MAX,
    ColumnMap,
    convert_output,
    convert_temperature_c,
    not_whole_in_range,
    time_factor_s,
)
from twin.measurement.core import MIN_ROWS, Measurement, MeasurementError, check

LARGE_FILE_BYTES = 256 * 2**20  # smaller logs (every test, the 0.5 M-row benchmark) keep the in-memory path
LARGE_FILE_ENV = "TDE_TWIN_CHUNKED_MIN_BYTES"  # overrides LARGE_FILE_BYTES (a test forces small files here)
CHUNK_ROWS = 1 << 18  # ≈ 12 MB of float64 per chunk of six columns: the frame is no longer a peak


def large_file_bytes() -> int:
    """Size [bytes] from which a delimited log is read in chunks (``TDE_TWIN_CHUNKED_MIN_BYTES``
    overrides :data:`LARGE_FILE_BYTES`; an unusable value is ignored).

    Returns
    -------
    int
        Threshold [bytes].
    """
    try:
        return max(0, int(os.environ[LARGE_FILE_ENV]))
    except (KeyError, ValueError):
        return LARGE_FILE_BYTES


def is_large(path: Path) -> bool:
    """Whether ``path`` is read in chunks.

    Parameters
    ----------
    path : Path
        The delimited log.

    Returns
    -------
    bool
        True when its size reaches :func:`large_file_bytes` (False when it cannot be stat'ed).
    """
    try:
        return path.stat().st_size >= large_file_bytes()
    except OSError:
        return False


def estimated_rows(path: Path, first_line: int) -> int:
    """Rows from the file size and the line length of its first megabyte (after the banner and
    header); later lines hold longer times, so this errs high, and untouched pages cost no memory.

    Parameters
    ----------
    path : Path
        The delimited log.
    first_line : int
        File line (1-based) of the first data row.

    Returns
    -------
    int
        Estimated rows, plus one chunk of margin.
    """
    with path.open("rb") as f:
        for _ in range(first_line - 1):
            f.readline()
        start = f.tell()
        sample = f.read(1 << 20)
    lines = max(1, sample.count(b"\n"))
    return int((path.stat().st_size - start) / max(1.0, len(sample) / lines) * 1.1) + CHUNK_ROWS


class _Columns:
    """The measurement's arrays, preallocated and grown in place (``ndarray.resize``: no second copy)."""

    def __init__(self, capacity: int, roles: set[str]):
        self.arrays = {"time": np.empty(capacity), "temperature": np.empty(capacity), "output": np.empty(capacity)}
        if "applied" in roles:
            self.arrays["applied"] = np.empty(capacity)
        self.arrays["run"] = np.empty(capacity, np.int16)
        self.arrays["power_on"] = np.empty(capacity, bool)

    def ensure(self, rows: int) -> None:
        capacity = self.arrays["time"].size
        if rows > capacity:
            for a in self.arrays.values():
                a.resize(max(rows, capacity + capacity // 2), refcheck=False)

    def trim(self, rows: int) -> dict[str, np.ndarray]:
        for a in self.arrays.values():
            a.resize(rows, refcheck=False)
        return self.arrays


def measurement_from_chunks(path: Path, cmap: ColumnMap, open_frames: Callable[[], Iterable], roles,
                            position: Callable, first_line: int, run: int = 0,
                            applied_g: float | None = None) -> Measurement | None:
    """A checked :class:`Measurement` from a clean file's float64 chunks, or ``None`` (module docstring).

    Parameters
    ----------
    path : Path
        The delimited log.
    cmap : ColumnMap
        Column names and units.
    open_frames : callable
        Returns the parser's chunks (DataFrames of float64 columns), as the in-memory path reads them.
    roles : tuple
        ``(role, key, required)`` triples (:func:`~twin.measurement.from_columns.single_axis_roles`).
    position : callable
        ``position(columns, key)``: the index of the column ``key`` names, ``None`` if absent.
    first_line : int
        The file line of the first data row.
    run, applied_g
        Run number and applied acceleration [g] when the file has no such column.

    Returns
    -------
    Measurement or None
        Time [s], temperature [°C], output [g] …; ``None`` when the file is not clean.
    """
    import pandas as pd

    factor = time_factor_s(cmap.time_unit)
    store, wanted, t0, n = None, None, None, 0
    try:
        with open_frames() as frames:
            for frame in frames:
                if not len(frame):
                    continue
                if wanted is None:
                    names = [str(c).strip() for c in frame.columns]
                    wanted = {role: position(names, key) for role, key, _ in roles if key is not None}
                    if any(wanted[role] is None for role, key, required in roles if key is not None and required):
                        return None
                    wanted = {role: idx for role, idx in wanted.items() if idx is not None}
                    store = _Columns(estimated_rows(path, first_line), set(wanted))
                values = {role: frame.iloc[:, idx].to_numpy(np.float64) for role, idx in wanted.items()}
                if not all(np.isfinite(v).all() for v in values.values()):
                    return None
                if "run" in values and not_whole_in_range(values["run"], 0, RUN_MAX).any():
                    return None
                if "power_on" in values and not_whole_in_range(values["power_on"], 0, 1).any():
                    return None
                a, b = n, n + len(frame)
                store.ensure(b)
                out = store.arrays
                if "time" in values:
                    t = values["time"] * factor if factor != 1.0 else values["time"]  # x·1 == x: no copy
                    t0 = t[0] if t0 is None else t0
                    np.subtract(t, t0, out=out["time"][a:b])
                out["temperature"][a:b] = convert_temperature_c(values["temperature"], cmap)
                out["output"][a:b] = convert_output(values["output"], cmap)
                if "applied" in values:
                    out["applied"][a:b] = values["applied"]
                out["run"][a:b] = values["run"] if "run" in values else run
                if "power_on" in values:
                    np.not_equal(values["power_on"], 0.0, out=out["power_on"][a:b])
                else:
                    out["power_on"][a:b] = False
                n = b
                del frame, values
    except (ValueError, TypeError, OverflowError, UnicodeDecodeError, OSError, pd.errors.ParserError,
            MeasurementError):  # e.g. output_unit digits without digit_mg: named where the old path names it
        return None  # the in-memory and careful paths read it again and name what is wrong
    if store is None or n < MIN_ROWS:
        return None
    arrays = store.trim(n)
    if "time" not in wanted:
        arrays["time"][:] = np.arange(n) / cmap.sample_rate_hz
    if "applied" in arrays:
        applied, known = arrays["applied"], True
    else:
        applied, known = np.full(n, np.nan if applied_g is None else float(applied_g)), applied_g is not None
    m = Measurement(arrays["time"], arrays["temperature"], arrays["output"], applied, arrays["run"],
                    arrays["power_on"], known, [str(path)], 0, [])
    check(m, str(path))
    return m

