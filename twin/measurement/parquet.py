"""Parquet logs: the columns a :class:`~twin.measurement.columns.ColumnMap` names, read row group
by row group into preallocated float64 arrays (no table or DataFrame kept).

The map works as for delimited logs (names, or 0-based indices into the schema; units; ``x``,
``y``, ``z`` for a 3-axis log); its text options (``skip_lines``, ``delimiter``, ``header``) do
not apply. A null or non-finite value is an error naming its row, or a skipped row with
``--skip-bad-rows``.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from twin.measurement.columns import ColumnMap
from twin.measurement.core import Measurement, MeasurementError
from twin.measurement.from_columns import (
    imu_from_columns,
    measurement_from_columns,
    single_axis_roles,
    three_axis_roles,
)
from twin.measurement.imu import ImuLog
from twin.measurement.registry import ReadOptions, register_reader, require_signature
from twin.text import did_you_mean

PARQUET_SIGNATURE = b"PAR1"  # at the start and the end of every Parquet file (format spec)


def _open(path: Path):
    import pyarrow as pa
    import pyarrow.parquet as pq

    require_signature(path, PARQUET_SIGNATURE, "Parquet file")
    try:
        return pq.ParquetFile(path)
    except (pa.ArrowException, OSError, ValueError) as exc:
        raise MeasurementError(f"{path}: not a readable Parquet file ({' '.join(str(exc).split())})") from None


def _resolve(names: list[str], key, path: Path, role: str, required: bool) -> str | None:
    """The schema column ``key`` names (a name, or a 0-based index as int or digits)."""
    if key is None:
        return None
    if isinstance(key, int) or (isinstance(key, str) and key.isdigit() and key not in names):
        idx = int(key)
        if idx >= len(names):
            raise MeasurementError(f"{path}: {role} column index {idx} out of range (the file has {len(names)} columns)")
        return names[idx]
    if key in names:
        return key
    if required:
        raise MeasurementError(f"{path}: no {role} column {key!r}{did_you_mean(key, names, label='columns are', sort=False)}")
    return None


def read_columns(path: Path, cmap: ColumnMap, roles, skip_bad_rows: bool):
    """``{role: float64 values}``, the rows to keep (``None``: all) and how many were bad.

    Parameters
    ----------
    path : Path
        The Parquet file.
    cmap : ColumnMap
        Columns and units.
    roles : tuple
        ``(role, key, required)`` triples (:func:`~twin.measurement.from_columns.single_axis_roles`).
    skip_bad_rows : bool
        Drop (and count) rows with a null or non-finite value instead of failing.

    Returns
    -------
    values : dict of str to ndarray
        Columns by role, float64, in the file's units.
    keep : ndarray of bool or None
        Rows kept.
    n_bad : int
        Rows dropped.
    """
    import pyarrow as pa

    cmap.validate(f"{path}: column map")
    f = _open(path)
    names = list(f.schema_arrow.names)
    chosen = {role: _resolve(names, key, path, role, required) for role, key, required in roles}
    chosen = {role: name for role, name in chosen.items() if name is not None}
    for role, name in chosen.items():
        if names.count(name) > 1:  # pyarrow looks a name up only when it is unique
            raise MeasurementError(f"{path}: {role} column {name!r} appears {names.count(name)} times in the "
                                   "schema; expected unique column names (rename the duplicates)")
        kind = f.schema_arrow.field(name).type
        if not (pa.types.is_integer(kind) or pa.types.is_floating(kind) or pa.types.is_boolean(kind)):
            raise MeasurementError(f"{path}: {role} column {name!r} has type {kind}; expected numbers")
    n = f.metadata.num_rows
    if n == 0:
        raise MeasurementError(f"{path}: no data rows")
    columns = sorted(set(chosen.values()))
    out = {name: np.empty(n) for name in columns}
    start = 0
    try:
        for batch in f.iter_batches(columns=columns, batch_size=1 << 20):
            stop = start + batch.num_rows
            for name in columns:
                col = batch.column(batch.schema.get_field_index(name)).cast(pa.float64())
                out[name][start:stop] = col.to_numpy(zero_copy_only=False)  # nulls → NaN
            start = stop
    except (pa.ArrowException, OSError, ValueError) as exc:
        raise MeasurementError(f"{path}: cannot read row {start + 1} onwards ({' '.join(str(exc).split())})") from None
    values = {role: out[name] for role, name in chosen.items()}
    bad = np.zeros(n, bool)
    for v in out.values():
        bad |= ~np.isfinite(v)
    n_bad = int(bad.sum())
    if n_bad and not skip_bad_rows:
        rows = (np.flatnonzero(bad)[:5] + 1).tolist()
        raise MeasurementError(f"{path}: {n_bad} row(s) with null or non-finite values, first at row(s) "
                               f"{', '.join(map(str, rows))} (use --skip-bad-rows to skip them)")
    if n - n_bad < 10:
        raise MeasurementError(f"{path}: fewer than 10 usable rows")
    return values, (~bad if n_bad else None), n_bad


def read_parquet(path: str | Path, cmap: ColumnMap | None = None, *, skip_bad_rows: bool = False,
                 applied_g: float | None = None) -> Measurement | ImuLog:
    """A Parquet log as a :class:`Measurement` (or an :class:`ImuLog` when the map names x, y, z).

    Parameters
    ----------
    path : str or Path
        The Parquet file.
    cmap : ColumnMap, optional
        Columns and units; default the canonical names.
    skip_bad_rows : bool
        Drop (and count) rows with a null or non-finite value instead of failing.
    applied_g : float, optional
        Acceleration along the axis when the file has no such column [g] (``None``: unknown).

    Returns
    -------
    Measurement or ImuLog
        Time [s], temperature [°C], output or acceleration [g].
    """
    path, cmap = Path(path), cmap or ColumnMap()
    axis_cols = cmap.axis_columns()
    if axis_cols is not None:
        values, keep, n_bad = read_columns(path, cmap, three_axis_roles(cmap, axis_cols), skip_bad_rows)
        return imu_from_columns(path, cmap, values, keep, n_bad, 1)
    if applied_g is not None and not np.isfinite(applied_g):
        raise MeasurementError(f"applied acceleration must be a finite number of g, got {applied_g}")
    values, keep, n_bad = read_columns(path, cmap, single_axis_roles(cmap), skip_bad_rows)
    return measurement_from_columns(path, cmap, values, keep, n_bad, 1, 0, applied_g)


def sniff_parquet(path: Path) -> bool:
    """Whether ``path`` starts with the Parquet signature (``PAR1``).

    Parameters
    ----------
    path : Path
        The file.

    Returns
    -------
    bool
        True for a file of this format.
    """
    with path.open("rb") as f:
        return f.read(4) == PARQUET_SIGNATURE


def _read(path: Path, options: ReadOptions) -> Measurement | ImuLog:
    return read_parquet(path, options.columns, skip_bad_rows=options.skip_bad_rows, applied_g=options.applied_g)


register_reader("parquet", (".parquet", ".pq"), _read, sniff=sniff_parquet,
                description="Parquet table: columns through a column map (canonical names by default)")
