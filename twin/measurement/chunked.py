"""Large delimited logs read in chunks straight into the arrays of a :class:`Measurement`.

A week at 100 Hz is 60 M rows (2 GB of CSV). Read whole, the parser's six float64 columns
(2.9 GB), its buffers and the copies made from them peaked at 7.9 GB. Here the same parser with
the same options (pandas' C parser, every field float64) reads about :data:`CHUNK_ROWS` rows at a
time — pieces of whole lines parsed side by side on threads (:mod:`twin.measurement.pieces`) —
and each chunk is checked and converted (time unit, temperature and output units, power as bool)
on the thread that parsed it, then written in file order (time origin, run as int16) into
preallocated arrays of the final dtypes. The arithmetic is the same element by element, so the
arrays are bit for bit those of the in-memory path (tests/test_readers.py); the parser is not
changed, so no value can round differently.

Only clean files are read here. Anything else — a parse error, a ragged row, a missing or
non-finite value, a missing column, a run or power flag that is not a whole number in range, fewer
than ten rows — returns ``None``, and the caller reads the file as before, naming file, line and
column. Not chosen: Arrow's streaming reader (as fast on one thread; it parsed all 51.8 M values of
the 24-h benchmark log to the same bits as pandas, but it is another float parser, and the
in-memory path's values are the contract).
"""

from __future__ import annotations

import os
from collections.abc import Callable
from contextlib import AbstractContextManager
from pathlib import Path
from typing import Protocol

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
CHUNK_ROWS = 1 << 19  # ≈ 25 MB of float64 per chunk of six columns: the frame is no longer a peak;
# the parser sets up once per piece, so 2^19 reads a 24-h log in 2.1 s against 2.8 s at 2^18 (+100 MB)


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


def line_bytes(path: Path, first_line: int) -> float:
    """Mean length [bytes] of the first megabyte's lines after the banner and header.

    Parameters
    ----------
    path : Path
        The delimited log.
    first_line : int
        File line (1-based) of the first data row.

    Returns
    -------
    float
        Bytes per line (at least 1).
    """
    with path.open("rb") as f:
        for _ in range(first_line - 1):
            f.readline()
        sample = f.read(1 << 20)
    return max(1.0, len(sample) / max(1, sample.count(b"\n")))


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
    return int(path.stat().st_size / line_bytes(path, first_line) * 1.1) + CHUNK_ROWS


class _Columns:
    """Arrays preallocated per role and grown in place (``ndarray.resize``: no second copy)."""

    def __init__(self, capacity: int, dtypes: dict[str, type]):
        self.arrays = {role: np.empty(capacity, dtype) for role, dtype in dtypes.items()}

    def ensure(self, rows: int) -> None:
        capacity = next(iter(self.arrays.values())).size if self.arrays else 0
        if rows > capacity:
            for a in self.arrays.values():
                a.resize(max(rows, capacity + capacity // 2), refcheck=False)

    def trim(self, rows: int) -> dict[str, np.ndarray]:
        for a in self.arrays.values():
            a.resize(rows, refcheck=False)
        return self.arrays


#: what the chunked paths give up on (the in-memory and careful paths read the file again and name
#: the file, line and column); MeasurementError: e.g. output_unit digits without digit_mg
NOT_CLEAN = (ValueError, TypeError, OverflowError, UnicodeDecodeError, OSError, MeasurementError)


class _Sink(Protocol):
    """What :func:`gather_columns` does with each chunk's columns (role → float64 values):
    ``dtypes(found)`` the arrays to allocate, role → dtype, given the roles found in the header;
    ``prepare(values)`` one chunk's columns checked and converted, on the thread that parsed it
    (no state; ``None`` when the chunk is not clean); ``put(prepared, out, a, b)`` a prepared
    chunk written into rows ``a:b`` of the arrays, chunks in file order."""

    def dtypes(self, found: set[str]) -> dict[str, type]: ...

    def prepare(self, values: dict[str, np.ndarray]) -> dict[str, np.ndarray] | None: ...

    def put(self, prepared: dict[str, np.ndarray], out: dict[str, np.ndarray], a: int, b: int) -> None: ...


class _NotClean(ValueError):
    """A chunk the chunked path gives up on (a required column missing)."""


def gather_columns(path: Path, first_line: int, open_frames: Callable[[Callable], AbstractContextManager],
                   roles, position: Callable, sink: _Sink) -> tuple[dict[str, np.ndarray], set[str], int] | None:
    """The needed columns of a file's float64 chunks gathered into arrays grown in place: the
    parser holds one chunk per parsing thread and one waiting, never the file. The one loop of
    every chunked path.

    Parameters
    ----------
    path : Path
        The delimited log (its size sizes the arrays: :func:`estimated_rows`).
    first_line : int
        The file line of the first data row.
    open_frames : callable
        ``open_frames(prepare)``: a context manager of ``prepare(frame)`` for each of the parser's
        chunks (DataFrames of float64 columns) in file order, ``prepare`` run where the chunk was
        parsed (:mod:`twin.measurement.pieces`).
    roles : tuple
        ``(role, key, required)`` triples (:func:`~twin.measurement.from_columns.single_axis_roles`).
    position : callable
        ``position(columns, key)``: the index of the column ``key`` names, ``None`` if absent.
    sink : _Sink
        Allocates, checks and converts, and writes the chunks' columns.

    Returns
    -------
    (arrays, found, rows) or None
        The arrays trimmed to ``rows``, and the roles found; ``None`` when a required column is
        missing, a chunk is not clean, the parser fails or there are no rows.
    """
    import pandas as pd

    def prepare(frame) -> dict[str, np.ndarray] | None:
        if not len(frame):
            return {}
        names = [str(c).strip() for c in frame.columns]
        wanted = {role: position(names, key) for role, key, _ in roles if key is not None}
        if any(wanted[role] is None for role, key, required in roles if key is not None and required):
            raise _NotClean(f"{path}: a required column is missing")
        return sink.prepare({role: frame.iloc[:, idx].to_numpy(np.float64) for role, idx in wanted.items()
                             if idx is not None})

    store, found, n = None, set(), 0
    try:
        with open_frames(prepare) as chunks:
            for values in chunks:
                if values is None:
                    return None
                if not values:
                    continue
                if store is None:
                    found = set(values)
                    store = _Columns(estimated_rows(path, first_line), sink.dtypes(found))
                rows = next(iter(values.values())).size
                store.ensure(n + rows)
                sink.put(values, store.arrays, n, n + rows)
                n += rows
                del values
    except NOT_CLEAN + (pd.errors.ParserError, pd.errors.EmptyDataError):
        return None
    if store is None or not n:
        return None
    return store.trim(n), found, n


class _Converter:
    """The chunks of a :class:`Measurement`: checked and converted (time scaled to seconds,
    temperature and output units, power flags as bool) on the parsing thread, then written in file
    order from the first row's time as origin (the one state across chunks)."""

    def __init__(self, cmap: ColumnMap, run: int):
        self.cmap, self.run, self.factor, self.t0 = cmap, run, time_factor_s(cmap.time_unit), None

    @staticmethod
    def dtypes(found: set[str]) -> dict[str, type]:
        """The final arrays: run as int16, power as bool."""
        return {"time": np.float64, "temperature": np.float64, "output": np.float64,
                **({"applied": np.float64} if "applied" in found else {}), "run": np.int16, "power_on": bool}

    def prepare(self, values: dict[str, np.ndarray]) -> dict[str, np.ndarray] | None:
        if not all(np.isfinite(v).all() for v in values.values()):
            return None
        if "run" in values and not_whole_in_range(values["run"], 0, RUN_MAX).any():
            return None
        if "power_on" in values and not_whole_in_range(values["power_on"], 0, 1).any():
            return None
        out = dict(values, temperature=convert_temperature_c(values["temperature"], self.cmap),
                   output=convert_output(values["output"], self.cmap))
        if "time" in values and self.factor != 1.0:  # x·1 == x: no copy
            out["time"] = values["time"] * self.factor
        if "power_on" in values:
            out["power_on"] = values["power_on"] != 0.0
        return out

    def put(self, prepared: dict[str, np.ndarray], out: dict[str, np.ndarray], a: int, b: int) -> None:
        if "time" in prepared:
            t = prepared["time"]
            self.t0 = t[0] if self.t0 is None else self.t0
            np.subtract(t, self.t0, out=out["time"][a:b])
        for role in ("temperature", "output", "applied"):
            if role in prepared:
                out[role][a:b] = prepared[role]
        out["run"][a:b] = prepared["run"] if "run" in prepared else self.run
        out["power_on"][a:b] = prepared["power_on"] if "power_on" in prepared else False


class _Copy:
    """The chunks' columns as they are, float64 (a :class:`_Sink`; the caller checks them)."""

    @staticmethod
    def dtypes(found: set[str]) -> dict[str, type]:
        return dict.fromkeys(found, np.float64)

    @staticmethod
    def prepare(values: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
        return values

    @staticmethod
    def put(prepared: dict[str, np.ndarray], out: dict[str, np.ndarray], a: int, b: int) -> None:
        for role, v in prepared.items():
            out[role][a:b] = v


#: the sink of :func:`twin.measurement.delimited` 's 3-axis tables: the columns copied as they are
COPY = _Copy()


def measurement_from_chunks(path: Path, cmap: ColumnMap, open_frames: Callable[[Callable], AbstractContextManager], roles,
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
    gathered = gather_columns(path, first_line, open_frames, roles, position, _Converter(cmap, run))
    if gathered is None or gathered[2] < MIN_ROWS:
        return None
    arrays, found, n = gathered
    if "time" not in found:
        arrays["time"][:] = np.arange(n) / cmap.sample_rate_hz
    if "applied" in arrays:
        applied, known = arrays["applied"], True
    else:
        applied, known = np.full(n, np.nan if applied_g is None else float(applied_g)), applied_g is not None
    m = Measurement(arrays["time"], arrays["temperature"], arrays["output"], applied, arrays["run"],
                    arrays["power_on"], known, [str(path)], 0, [])
    check(m, str(path))
    return m
