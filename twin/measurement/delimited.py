"""Delimited logs (CSV, TSV, whitespace, with banners): the canonical CSV and any log via a column map.

Canonical CSV: ``time_s,temperature_c,output_g[,applied_g][,run][,power_on]`` with a header line.
A :class:`~twin.measurement.columns.ColumnMap` reads any other delimited log; three output
columns (``x``, ``y``, ``z``) give an :class:`~twin.measurement.imu.ImuLog`, with its gyro when
the map names ``gx``, ``gy``, ``gz``. Bad input raises
:class:`MeasurementError` naming the file, line and column.

pandas' C parser reads the text. Clean files take a fast path: every field typed float64 up front
(no object columns, no coercion pass; 8.64 M rows × 4 columns: about 40 % less time and 12 % less
peak memory, measured under load); anything it cannot parse goes to the careful path, which names
the file, line and column as before. Both give the same arrays (tests/test_properties_logs.py).
Single-axis files from 256 MB on are read by the same parser in chunks into the final arrays
(:mod:`twin.measurement.chunked`: a week at 100 Hz peaks at 3.4 GB, not 7.9 GB); any irregularity
there falls back to these paths. Not chosen: ``usecols`` (half the peak memory, but it silently
drops a ragged row's extra fields), Arrow's CSV reader (its own float parser).
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from twin.measurement import chunked
from twin.measurement.columns import (
    RUN_MAX,
    ColumnMap,
    convert_gyro_rad_s,
    convert_output,
    convert_temperature_c,
    not_whole_in_range,
    time_factor_s,
)
from twin.measurement.core import Measurement, MeasurementError, check
from twin.measurement.imu import ImuLog
from twin.measurement.registry import ReadOptions, register_reader
from twin.text import did_you_mean

SUFFIXES = (".csv", ".tsv", ".txt", ".log", ".dat")
MAX_MEDIAN_NORM_G = 4.0  # a median |a| above this is a unit mistake, not an accelerometer (as the 1-axis check)


def _sniff_separator(lines: list[str]) -> str:
    sample = "".join(lines[:3])
    if "\t" in sample:
        return "\t"
    return ";" if sample.count(";") > sample.count(",") else "," if "," in sample else r"\s+"


def utf8_error(path: Path) -> str | None:
    """``"FILE:LINE: not UTF-8 text ..."`` for the first line that is not UTF-8, or ``None``."""
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


def _read_csv(path: Path, cmap: ColumnMap, layout: _Layout, skip_bad_rows: bool, **kwargs):
    import pandas as pd

    return pd.read_csv(path, sep=layout.sep, skiprows=cmap.skip_lines, header=0 if cmap.header else None,
                       names=layout.names, engine="c" if layout.sep != r"\s+" else "python",
                       on_bad_lines="skip" if skip_bad_rows else "error", skipinitialspace=True,
                       encoding="utf-8", **kwargs)


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
    # not usecols: with it the parser silently drops a ragged row's extra fields (module docstring)
    try:
        df = _read_csv(path, cmap, layout, skip_bad_rows, dtype=np.float64)
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


def _kept(values: np.ndarray, keep: np.ndarray | None) -> np.ndarray:
    """The kept rows (no copy when every row is kept)."""
    return values if keep is None else values[keep]


def _time_s(values: dict, keep: np.ndarray | None, n: int, cmap: ColumnMap) -> np.ndarray:
    """Seconds from the first kept row (or from the sample rate when there is no time column)."""
    if "time" not in values:
        return np.arange(n) / cmap.sample_rate_hz
    t = _kept(values["time"], keep)
    if time_factor_s(cmap.time_unit) != 1.0:  # x·1 == x exactly: one copy of a long log fewer
        t = t * time_factor_s(cmap.time_unit)
    return t - t[0]


def _kept_count(values: dict, keep: np.ndarray | None) -> int:
    return int(keep.sum()) if keep is not None else next(iter(values.values())).size


def _whole_numbers(values: np.ndarray, path: Path, first_line: int, role: str, low: int, high: int) -> np.ndarray:
    """``values`` as integers in [low, high]; a fraction or an out-of-range value names its line."""
    wrong = not_whole_in_range(values, low, high)
    if wrong.any():
        k = int(np.flatnonzero(wrong)[0])
        raise MeasurementError(f"{path}: {role} column holds {values[k]:g} (row {k + 1} of the data, about line "
                               f"{k + first_line}); expected a whole number from {low} to {high}")
    return values.astype(np.int64)


def read_table(path: str | Path, cmap: ColumnMap | None = None, *, run: int = 0, skip_bad_rows: bool = False,
               applied_g: float | None = None) -> Measurement:
    """Read one delimited file as one run.

    ``applied_g``: the acceleration along the axis when the file has no such column (``None``
    with no column means unknown).
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
    open_frames = lambda: _read_csv(path, cmap, layout, skip_bad_rows, dtype=np.float64,  # noqa: E731
                                    chunksize=chunked.CHUNK_ROWS)
    return chunked.measurement_from_chunks(path, cmap, open_frames, roles, _position, layout.first_line, run, applied_g)


def single_axis_roles(cmap: ColumnMap) -> tuple:
    """``(role, key, required)`` for a single-axis log, in the order a missing column is named."""
    return (("temperature", cmap.temperature, True), ("output", cmap.output, True),
            ("time", cmap.time, cmap.sample_rate_hz is None), ("applied", cmap.applied, False),
            ("run", cmap.run, False), ("power_on", cmap.power_on, False))


def three_axis_roles(cmap: ColumnMap, axis_cols) -> tuple:
    """``(role, key, required)`` for a 3-axis log (with ``x gyro`` ... when the map names a gyro)."""
    gyro_cols = cmap.gyro_columns() or ()
    return (("temperature", cmap.temperature, True), *((f"{a} output", k, True) for a, k in zip("xyz", axis_cols)),
            ("time", cmap.time, cmap.sample_rate_hz is None),
            *((f"{a} gyro", k, True) for a, k in zip("xyz", gyro_cols)))


def measurement_from_columns(path: Path, cmap: ColumnMap, values: dict, keep: np.ndarray | None, n_bad: int,
                             first_line: int, run: int = 0, applied_g: float | None = None) -> Measurement:
    """A checked :class:`Measurement` from a reader's float64 columns by role (``keep``: rows kept,
    ``None`` for all; ``first_line``: the file line of the first row, for messages)."""
    n = _kept_count(values, keep)
    t = _time_s(values, keep, n, cmap)
    temp = convert_temperature_c(_kept(values["temperature"], keep), cmap)
    out = convert_output(_kept(values["output"], keep), cmap)
    if "applied" in values:
        applied, known = _kept(values["applied"], keep), True
    elif applied_g is not None:
        applied, known = np.full(n, float(applied_g)), True
    else:
        applied, known = np.full(n, np.nan), False
    first = first_line
    run_idx = (_whole_numbers(_kept(values["run"], keep), path, first, "run", 0, RUN_MAX)
               if "run" in values else np.full(n, run, np.int16))
    power = (_whole_numbers(_kept(values["power_on"], keep), path, first, "power_on", 0, 1).astype(bool)
             if "power_on" in values else np.zeros(n, bool))
    del values
    m = Measurement(t, temp, out, applied, run_idx.astype(np.int16), power, known, [str(path)], n_bad, [])
    check(m, str(path))
    return m


def read_table_imu(path: str | Path, cmap: ColumnMap, *, skip_bad_rows: bool = False) -> ImuLog:
    """Read a 3-axis delimited log (``cmap.x/y/z`` or ``cmap.output_cols``) as one :class:`ImuLog`.

    Time must increase strictly: two rows at one instant (two orientations, or a repeated row)
    are an error naming the line, as in a single-axis log.
    """
    path = Path(path)
    axis_cols = cmap.axis_columns()
    if axis_cols is None:
        raise MeasurementError(f"{path}: the column map names no x, y, z (or output_cols) columns")
    roles = three_axis_roles(cmap, axis_cols)
    values, keep, n_bad = _numeric_columns(path, cmap, roles, skip_bad_rows)
    return imu_from_columns(path, cmap, values, keep, n_bad, cmap.skip_lines + (2 if cmap.header else 1))


def imu_from_columns(path: Path, cmap: ColumnMap, values: dict, keep: np.ndarray | None, n_bad: int,
                     first_line: int) -> ImuLog:
    """A checked :class:`ImuLog` from a reader's float64 columns by role (as :func:`measurement_from_columns`)."""
    n = _kept_count(values, keep)
    t = _time_s(values, keep, n, cmap)
    check_increasing(t, path, first_line, keep)
    accel = np.column_stack([convert_output(_kept(values[f"{a} output"], keep), cmap) for a in "xyz"])
    gyro = (np.column_stack([convert_gyro_rad_s(_kept(values[f"{a} gyro"], keep), cmap) for a in "xyz"])
            if "x gyro" in values else None)
    temp = convert_temperature_c(_kept(values["temperature"], keep), cmap)
    del values
    check_values(temp, accel, str(path))
    notes = (f"{path}: {n_bad} bad row(s) skipped",) if n_bad else ()
    return ImuLog(t, temp, accel, 0, None, str(path), notes, gyro_rad_s=gyro)


def check_increasing(t: np.ndarray, path: Path, first_line: int, keep: np.ndarray | None) -> None:
    """Fail naming the file line where time stops increasing strictly."""
    d = np.diff(t)
    if d.size and not (d > 0).all():
        k = int(np.flatnonzero(~(d > 0))[0]) + 1
        row = int(np.flatnonzero(keep)[k]) if keep is not None else k
        raise MeasurementError(f"{path}:{row + first_line}: time {t[k] + 0.0:g} s does not follow {t[k - 1] + 0.0:g} s; expected "
                               "strictly increasing time (one orientation per instant; check time_unit or sort the file)")


def check_values(temperature_c: np.ndarray, accel_g: np.ndarray, where: str) -> None:
    """Plausible units for a 3-axis log: temperature in °C, acceleration in g."""
    med = float(np.median(temperature_c))
    if med > 150:
        raise MeasurementError(f"{where}: temperature median {med:.1f} looks like kelvin; "
                               "set temperature_unit: K (or F for Fahrenheit)")
    # per row, not per value: on a level board two axes read ~0, so the median over all values
    # would pass a log in mg (or m/s²) declared as g; a still or flying IMU reads |a| of about 1 g
    with np.errstate(over="ignore"):  # |a| of 1e300 is inf, refused below like any unit mistake
        norm = float(np.median(np.linalg.norm(accel_g, axis=1) if accel_g.ndim == 2 else np.abs(accel_g)))
    if norm > MAX_MEDIAN_NORM_G:
        raise MeasurementError(f"{where}: acceleration median |a| {norm:.3g} g is implausible for an IMU at rest or in "
                               f"flight (expected about 1 g, at most {MAX_MEDIAN_NORM_G:g}); set output_unit "
                               "(m/s^2, mg or digits)")


def write_canonical_csv(path: str | Path, time_s, temperature_c, output_g, applied_g, run, power_on) -> Path:
    """Write the canonical CSV form (atomically)."""
    import io

    from twin.io import atomic_write_text

    buf = io.StringIO()
    buf.write("time_s,temperature_c,output_g,applied_g,run,power_on\n")
    data = np.column_stack([time_s, temperature_c, output_g, applied_g, run, np.asarray(power_on, int)])
    np.savetxt(buf, data, delimiter=",", fmt=["%.3f", "%.4f", "%.7f", "%.4f", "%d", "%d"])
    return atomic_write_text(Path(path), buf.getvalue())


def sniff_text(path: Path) -> bool:
    """A text file: no NUL byte in its first 4 kB (every binary log format here has some)."""
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
