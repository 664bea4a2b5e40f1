"""Delimited logs (CSV, TSV, whitespace, with banners): the canonical CSV and any log via a column map.

Canonical CSV: ``time_s,temperature_c,output_g[,applied_g][,run][,power_on]`` with a header line.
A :class:`~twin.measurement.columns.ColumnMap` reads any other delimited log; three output
columns (``x``, ``y``, ``z``) give an :class:`~twin.measurement.imu.ImuLog`, with its gyro when
the map names ``gx``, ``gy``, ``gz``; the columns found become either in
:mod:`twin.measurement.from_columns`. Bad input raises :class:`MeasurementError` naming the file,
line and column.

pandas' C parser reads the text. Clean files take a fast path: every field typed float64 up front
(no object columns, no coercion pass; 8.64 M rows × 4 columns: about 40 % less time and 12 % less
peak memory, measured under load); anything it cannot parse goes to the careful path, which names
the file, line and column as before. Both give the same arrays (tests/test_properties_logs.py).
Single-axis files from 256 MB on are read by the same parser in chunks into the final arrays
(:mod:`twin.measurement.chunked`: a week at 100 Hz peaks at 3.4 GB, not 7.9 GB); any irregularity
there falls back to these paths. Large 3-axis tables are parsed in chunks too, their needed columns
gathered into arrays grown in place (the whole frame, every column float64, is never held). Not chosen: ``usecols`` (half the peak memory, but it silently
drops a ragged row's extra fields), Arrow's CSV reader (its own float parser).
"""

from __future__ import annotations

import io
import re
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from twin.measurement import chunked, pieces
from twin.measurement.columns import ColumnMap
from twin.measurement.core import Measurement, MeasurementError
from twin.measurement.from_columns import (
    imu_from_columns,
    measurement_from_columns,
    single_axis_roles,
    three_axis_roles,
)
from twin.measurement.imu import ImuLog
from twin.measurement.registry import ReadOptions, register_reader
from twin.text import did_you_mean

SUFFIXES = (".csv", ".tsv", ".txt", ".log", ".dat")


def _sniff_separator(lines: list[str]) -> str:
    sample = "".join(lines[:3])
    if "\t" in sample:
        return "\t"
    return ";" if sample.count(";") > sample.count(",") else "," if "," in sample else r"\s+"


def utf8_error(path: Path) -> str | None:
    """``"FILE:LINE: not UTF-8 text ..."`` for the first line that is not UTF-8, or ``None``.

    Parameters
    ----------
    path : Path
        The file.

    Returns
    -------
    str or None
        The message naming the line, byte and column; ``None`` when every line is UTF-8.
    """
    with path.open("rb") as f:
        for number, raw in enumerate(f, 1):
            try:
                raw.decode("utf-8")
            except UnicodeDecodeError as exc:
                return (f"{path}:{number}: not UTF-8 text (byte 0x{raw[exc.start]:02x} at column {exc.start + 1}); "
                        "expected a UTF-8 or ASCII text log")
    return None


@dataclass(frozen=True)
class _Layout:
    """How the parser reads the file: separator, column names when there is no header, first data line."""

    sep: str
    names: list[int] | None
    first_line: int


def _layout(path: Path, cmap: ColumnMap) -> _Layout:
    """Separator, header and first data line from the file's head (after ``skip_lines``)."""
    if not path.is_file():
        raise MeasurementError(f"{path}: measurement file not found" if not path.is_dir()
                               else f"{path}: is a directory; expected a measurement file")
    head, total = [], 0
    with path.open("rb") as f:
        for raw in f:
            total += 1
            if total > cmap.skip_lines:
                head.append(raw)
            if len(head) >= 50:
                break
    if total == 0:
        raise MeasurementError(f"{path}: empty file; expected a header line and data rows")
    if not head:
        raise MeasurementError(f"{path}: skip_lines {cmap.skip_lines} skips past the end of the file "
                               f"({total} line(s)); expected fewer banner lines")
    try:
        lines = [raw.decode("utf-8") for raw in head]
    except UnicodeDecodeError:
        raise MeasurementError(utf8_error(path) or f"{path}: not UTF-8 text") from None
    sep = cmap.separator() if cmap.delimiter is not None else _sniff_separator(lines)
    names = None
    if not cmap.header:
        # the most common field count, so one truncated first row does not set the width
        counts = [len(re.split(sep, ln.strip())) if sep == r"\s+" else ln.count(sep) + 1 for ln in lines if ln.strip()]
        names = list(range(max(set(counts), key=counts.count))) if counts else None
    return _Layout(sep, names, cmap.skip_lines + (2 if cmap.header else 1))


def _read_csv(path, cmap: ColumnMap, layout: _Layout, skip_bad_rows: bool, skiprows: int | None = None,
              spaces: bool = True, **kwargs):
    """pandas' C parser with the options of every path; ``path`` may be a buffer (then ``skiprows=0``).
    ``spaces=False`` leaves the spaces that open a field to the number parser (:func:`_numbers_only`)."""
    import pandas as pd

    skiprows = cmap.skip_lines if skiprows is None else skiprows
    return pd.read_csv(path, sep=layout.sep, skiprows=skiprows, header=0 if cmap.header else None,
                       names=layout.names, engine="c" if layout.sep != r"\s+" else "python",
                       on_bad_lines="skip" if skip_bad_rows else "error", skipinitialspace=spaces,
                       encoding="utf-8", **kwargs)


def _numbers_only(layout: _Layout, has_quote: Callable[[], bool]) -> bool:
    """Whether the fast path may parse without skipping the spaces that open a field (pandas' C
    parser runs about 1.6× faster without): only where that reads the same values or fails.

    The option changes how fields split only at a quote after a space, or with a space for the
    delimiter; so with no quote in the text and another one-character delimiter the rows split
    the same, and each field differs only by its opening spaces, which the number parser skips.
    A field of spaces alone fails to convert to float64 without the option, and the careful path
    reads the file (tests/test_properties_logs.py, tests/test_hardening_logs.py). ``has_quote()``
    looks at the text only when the delimiter allows it."""
    return len(layout.sep) == 1 and layout.sep != " " and not has_quote()


def _has_quote(path: Path, block: int = 1 << 23) -> bool:
    """Whether a double quote occurs anywhere in ``path`` (read 8 MB at a time)."""
    with path.open("rb") as f:
        while data := f.read(block):
            if b'"' in data:
                return True
    return False


def _load_frame(path: Path, cmap: ColumnMap, layout: _Layout, skip_bad_rows: bool):
    """The careful path: the file as a DataFrame, every error named (file, line, column)."""
    import pandas as pd

    try:
        df = _read_csv(path, cmap, layout, skip_bad_rows)
    except pd.errors.EmptyDataError:
        raise MeasurementError(f"{path}: no header line after skipping {cmap.skip_lines} line(s); "
                               "expected a header line and data rows") from None
    except pd.errors.ParserError as exc:
        raise MeasurementError(f"{path}: {' '.join(str(exc).split())} (use --skip-bad-rows to skip such lines)") from None
    except UnicodeDecodeError:
        raise MeasurementError(utf8_error(path) or f"{path}: not UTF-8 text") from None
    except OSError as exc:
        raise MeasurementError(f"{path}: cannot read: {exc.strerror or exc}") from None
    except ValueError as exc:  # the parser refusing its options (e.g. a separator in the data)
        raise MeasurementError(f"{path}: cannot parse with delimiter {layout.sep!r}: {' '.join(str(exc).split())}") from None
    if df.empty:
        raise MeasurementError(f"{path}: no data rows")
    df.columns = [str(c).strip() for c in df.columns]
    return df


def _position(columns: list[str], key) -> int | None:
    """Index of the column ``key`` names (a name, or a 0-based index as int or digits); ``None`` if absent."""
    if isinstance(key, int) or (isinstance(key, str) and key.isdigit() and key not in columns):
        idx = int(key)
        return idx if idx < len(columns) else None
    return columns.index(key) if key in columns else None


def _column(df, key, path: Path, role: str, required: bool):
    if key is None:
        return None
    idx = _position(list(df.columns), key)
    if idx is not None:
        return df.iloc[:, idx]
    if isinstance(key, int) or (isinstance(key, str) and key.isdigit() and key not in df.columns):
        raise MeasurementError(f"{path}: {role} column index {int(key)} out of range (the file has {df.shape[1]} columns)")
    if required:
        raise MeasurementError(f"{path}: no {role} column {key!r}"
                               f"{did_you_mean(key, df.columns, label='columns are', sort=False)}")
    return None


def _numeric(series) -> np.ndarray:
    """Values as floats (NaN where a field is not a number)."""
    import pandas as pd

    if series.dtype.kind in "fiub":  # parsed as numbers by the C parser: nothing to coerce
        return series.to_numpy(float)
    return pd.to_numeric(series.astype(str).str.strip(), errors="coerce").to_numpy(float)


def _fast_values(path: Path, cmap: ColumnMap, layout: _Layout, roles, skip_bad_rows: bool) -> dict | None:
    """The fast path for clean files: the careful path's parser and options with every field typed
    float64 up front (no object columns, no coercion pass), so the values are the same; the needed
    columns are kept, the frame is not. ``None`` whenever the careful path must look (a text
    field, a missing column): it names the file, line and column, exactly as before."""
    import pandas as pd

    if layout.sep == r"\s+":
        return None
    if chunked.is_large(path):  # the same parser and options, CHUNK_ROWS rows at a time
        return _chunked_values(path, cmap, layout, roles, skip_bad_rows)
    # not usecols: with it the parser silently drops a ragged row's extra fields (module docstring)
    try:
        df = _read_csv(path, cmap, layout, skip_bad_rows, dtype=np.float64,
                       spaces=not _numbers_only(layout, lambda: _has_quote(path)))
    except (ValueError, TypeError, OverflowError, UnicodeDecodeError, pd.errors.ParserError,
            pd.errors.EmptyDataError):
        return None
    if df.empty:
        return None
    columns = [str(c).strip() for c in df.columns]
    wanted = {role: _position(columns, key) for role, key, _ in roles if key is not None}
    if any(wanted[role] is None for role, key, required in roles if key is not None and required):
        return None
    return {role: df.iloc[:, idx].to_numpy(np.float64) for role, idx in wanted.items() if idx is not None}


def _chunk_opener(path: Path, cmap: ColumnMap, layout: _Layout, skip_bad_rows: bool):
    """``open_frames`` of the fast path's parser, every field float64, about
    :data:`~twin.measurement.chunked.CHUNK_ROWS` rows at a time: pieces of whole lines behind the
    header line, parsed on threads (:mod:`twin.measurement.pieces`), or one parser reading on
    where the head cannot be cut."""
    head = pieces.data_head(path, cmap.skip_lines, cmap.header)
    if head is None:
        return pieces.read_on(lambda: _read_csv(path, cmap, layout, skip_bad_rows, dtype=np.float64,
                                                chunksize=chunked.CHUNK_ROWS))
    header, start = head

    def parse(piece: bytes):
        import pandas as pd

        frame = _read_csv(io.BytesIO(piece), cmap, layout, skip_bad_rows, skiprows=0, dtype=np.float64,  # no copy
                          spaces=not _numbers_only(layout, lambda: b'"' in piece))
        if not isinstance(frame.index, pd.RangeIndex):  # a first row with one field more: read as an index
            raise ValueError("a row with more fields than the header")
        return frame

    piece_bytes = max(1, int(chunked.CHUNK_ROWS * chunked.line_bytes(path, layout.first_line)))
    return pieces.in_pieces(path, header, start, parse, piece_bytes)


def _chunked_values(path: Path, cmap: ColumnMap, layout: _Layout, roles, skip_bad_rows: bool) -> dict | None:
    """:func:`_fast_values` of a large file, its needed columns gathered chunk by chunk
    (:func:`~twin.measurement.chunked.gather_columns`; bit for bit the same values: the same
    parser, options and dtype)."""
    gathered = chunked.gather_columns(path, layout.first_line, _chunk_opener(path, cmap, layout, skip_bad_rows),
                                      roles, _position, chunked.COPY)
    return None if gathered is None else gathered[0]


def _numeric_columns(path: Path, cmap: ColumnMap, roles, skip_bad_rows: bool):
    """``{role: values}`` for the columns present, the rows to keep, and how many were bad.

    ``roles``: ``(role, key, required)`` triples, looked up in that order (the first missing
    required column is the one the error names).
    """
    cmap.validate(f"{path}: column map")
    layout = _layout(path, cmap)
    values = _fast_values(path, cmap, layout, roles, skip_bad_rows)
    if values is None:
        df = _load_frame(path, cmap, layout, skip_bad_rows)
        cols = {role: _column(df, key, path, role, required) for role, key, required in roles}
        values = {role: _numeric(series) for role, series in cols.items() if series is not None}
        del df, cols
    n = next(iter(values.values())).size
    bad = np.zeros(n, bool)
    for v in values.values():
        bad |= ~np.isfinite(v)
    if bad.any() and not skip_bad_rows:
        lines = (np.flatnonzero(bad)[:5] + layout.first_line).tolist()
        raise MeasurementError(f"{path}: {int(bad.sum())} row(s) with missing or non-numeric values, first at "
                               f"line(s) {', '.join(map(str, lines))} (use --skip-bad-rows to skip them)")
    keep = None if not bad.any() else ~bad
    if n - int(bad.sum()) < 10:
        raise MeasurementError(f"{path}: fewer than 10 usable rows")
    return values, keep, int(bad.sum())


def read_table(path: str | Path, cmap: ColumnMap | None = None, *, run: int = 0, skip_bad_rows: bool = False,
               applied_g: float | None = None) -> Measurement:
    """Read one delimited file as one run.

    Parameters
    ----------
    path : str or Path
        The log.
    cmap : ColumnMap, optional
        Columns and units; default the canonical CSV's.
    run : int
        Run number when the file has no run column.
    skip_bad_rows : bool
        Drop (and count) unreadable or non-finite rows instead of failing.
    applied_g : float, optional
        Acceleration along the axis when the file has no such column [g] (``None``: unknown).

    Returns
    -------
    Measurement
        Time [s], temperature [°C], output and applied acceleration [g].
    """
    cmap = cmap or ColumnMap()
    path = Path(path)
    if applied_g is not None and not np.isfinite(applied_g):
        raise MeasurementError(f"applied acceleration must be a finite number of g, got {applied_g}")
    roles = single_axis_roles(cmap)
    m = _large_measurement(path, cmap, roles, skip_bad_rows, run, applied_g)
    if m is not None:
        return m
    values, keep, n_bad = _numeric_columns(path, cmap, roles, skip_bad_rows)
    return measurement_from_columns(path, cmap, values, keep, n_bad, cmap.skip_lines + (2 if cmap.header else 1),
                                    run, applied_g)


def _large_measurement(path: Path, cmap: ColumnMap, roles, skip_bad_rows: bool, run: int,
                       applied_g: float | None) -> Measurement | None:
    """A large clean log read in chunks (:mod:`twin.measurement.chunked`); ``None`` for any other."""
    if not chunked.is_large(path):
        return None
    cmap.validate(f"{path}: column map")
    layout = _layout(path, cmap)
    if layout.sep == r"\s+":
        return None
    return chunked.measurement_from_chunks(path, cmap, _chunk_opener(path, cmap, layout, skip_bad_rows), roles,
                                           _position, layout.first_line, run, applied_g)


def read_table_imu(path: str | Path, cmap: ColumnMap, *, skip_bad_rows: bool = False) -> ImuLog:
    """Read a 3-axis delimited log (``cmap.x/y/z`` or ``cmap.output_cols``) as one :class:`ImuLog`.

    Time must increase strictly: two rows at one instant (two orientations, or a repeated row)
    are an error naming the line, as in a single-axis log.

    Parameters
    ----------
    path : str or Path
        The log.
    cmap : ColumnMap
        Columns and units.
    skip_bad_rows : bool
        Drop (and count) unreadable or non-finite rows instead of failing.

    Returns
    -------
    ImuLog
        Time [s], temperature [°C], acceleration (n, 3) [g], gyro [rad/s] when named.
    """
    path = Path(path)
    axis_cols = cmap.axis_columns()
    if axis_cols is None:
        raise MeasurementError(f"{path}: the column map names no x, y, z (or output_cols) columns")
    roles = three_axis_roles(cmap, axis_cols)
    values, keep, n_bad = _numeric_columns(path, cmap, roles, skip_bad_rows)
    return imu_from_columns(path, cmap, values, keep, n_bad, cmap.skip_lines + (2 if cmap.header else 1))


def write_canonical_csv(path: str | Path, time_s, temperature_c, output_g, applied_g, run, power_on) -> Path:
    """Write the canonical CSV form (atomically).

    Parameters
    ----------
    path : str or Path
        Output file.
    time_s, temperature_c, output_g, applied_g, run, power_on : array_like
        Time [s], temperature [°C], output and applied acceleration [g], run number, power-on flag.

    Returns
    -------
    Path
        The file written.
    """
    import io

    from twin.io import atomic_write_text

    buf = io.StringIO()
    buf.write("time_s,temperature_c,output_g,applied_g,run,power_on\n")
    data = np.column_stack([time_s, temperature_c, output_g, applied_g, run, np.asarray(power_on, int)])
    np.savetxt(buf, data, delimiter=",", fmt=["%.3f", "%.4f", "%.7f", "%.4f", "%d", "%d"])
    return atomic_write_text(Path(path), buf.getvalue())


def sniff_text(path: Path) -> bool:
    """A text file: no NUL byte in its first 4 kB (every binary log format here has some).

    Parameters
    ----------
    path : Path
        The file.

    Returns
    -------
    bool
        True for a non-empty file without a NUL byte in its first 4 kB.
    """
    with path.open("rb") as f:
        head = f.read(4096)
    return bool(head) and b"\0" not in head


def _read(path: Path, options: ReadOptions) -> Measurement | ImuLog:
    cmap = options.columns or ColumnMap()
    if cmap.axis_columns() is not None:
        return read_table_imu(path, cmap, skip_bad_rows=options.skip_bad_rows)
    return read_table(path, cmap, run=0, skip_bad_rows=options.skip_bad_rows, applied_g=options.applied_g)


register_reader("delimited", SUFFIXES, _read, sniff=sniff_text, priority=-1,  # any text: sniffs last
                description="CSV/TSV/whitespace text: canonical CSV or any log through a column map")
