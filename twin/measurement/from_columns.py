"""A checked :class:`~twin.measurement.core.Measurement` or :class:`~twin.measurement.imu.ImuLog`
from the float64 columns a reader found, by role.

A reader (delimited text, Parquet) looks up the columns a
:class:`~twin.measurement.columns.ColumnMap` names, as ``(role, key, required)`` triples
(:func:`single_axis_roles`, :func:`three_axis_roles`), and hands their values here, with the rows
it kept and the file line of the first row. The builders convert units, check the run and power
flags, time order and plausible units, and name the file and line of the first bad value.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

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

MAX_MEDIAN_NORM_G = 4.0  # a median |a| above this is a unit mistake, not an accelerometer (as the 1-axis check)


def single_axis_roles(cmap: ColumnMap) -> tuple:
    """``(role, key, required)`` for a single-axis log, in the order a missing column is named.

    Parameters
    ----------
    cmap : ColumnMap
        The columns of the log.

    Returns
    -------
    tuple of tuple
        ``(role, key, required)``: temperature, output, time (required without a sample rate),
        applied, run, power_on.
    """
    return (("temperature", cmap.temperature, True), ("output", cmap.output, True),
            ("time", cmap.time, cmap.sample_rate_hz is None), ("applied", cmap.applied, False),
            ("run", cmap.run, False), ("power_on", cmap.power_on, False))


def three_axis_roles(cmap: ColumnMap, axis_cols) -> tuple:
    """``(role, key, required)`` for a 3-axis log (with ``x gyro`` ... when the map names a gyro).

    Parameters
    ----------
    cmap : ColumnMap
        The columns of the log.
    axis_cols : sequence
        The keys of the x, y, z output columns (``cmap.axis_columns()``).

    Returns
    -------
    tuple of tuple
        ``(role, key, required)``: temperature, ``x output`` … ``z output``, time, and ``x gyro``
        … ``z gyro`` when the map names a gyro.
    """
    gyro_cols = cmap.gyro_columns() or ()
    return (("temperature", cmap.temperature, True), *((f"{a} output", k, True) for a, k in zip("xyz", axis_cols)),
            ("time", cmap.time, cmap.sample_rate_hz is None),
            *((f"{a} gyro", k, True) for a, k in zip("xyz", gyro_cols)))


def measurement_from_columns(path: Path, cmap: ColumnMap, values: dict, keep: np.ndarray | None, n_bad: int,
                             first_line: int, run: int = 0, applied_g: float | None = None) -> Measurement:
    """A checked :class:`Measurement` from a reader's float64 columns by role.

    Parameters
    ----------
    path : Path
        The log, for messages and the measurement's sources.
    cmap : ColumnMap
        Units of the columns.
    values : dict of str to ndarray
        Float64 column values by role (:func:`single_axis_roles`) [the file's units].
    keep : ndarray of bool or None
        Rows kept; ``None`` for all.
    n_bad : int
        Rows the reader skipped (recorded in the measurement).
    first_line : int
        File line of the first row, for messages.
    run : int
        Run number when there is no run column.
    applied_g : float, optional
        Acceleration along the axis when there is no such column [g]; ``None``: unknown.

    Returns
    -------
    Measurement
        Time from the first row [s], temperature [°C], output and applied acceleration [g], run,
        power-on flag.
    """
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


def imu_from_columns(path: Path, cmap: ColumnMap, values: dict, keep: np.ndarray | None, n_bad: int,
                     first_line: int) -> ImuLog:
    """A checked :class:`ImuLog` from a reader's float64 columns by role (as :func:`measurement_from_columns`).

    Parameters
    ----------
    path : Path
        The log, for messages and the log's source.
    cmap : ColumnMap
        Units of the columns.
    values : dict of str to ndarray
        Float64 column values by role (:func:`three_axis_roles`) [the file's units].
    keep : ndarray of bool or None
        Rows kept; ``None`` for all.
    n_bad : int
        Rows the reader skipped (noted in the log).
    first_line : int
        File line of the first row, for messages.

    Returns
    -------
    ImuLog
        Time from the first row [s], temperature [°C], acceleration (n, 3) [g], gyro (n, 3)
        [rad/s] when the map names one.
    """
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
    """Fail naming the file line where time stops increasing strictly.

    Parameters
    ----------
    t : ndarray
        Time of the kept rows [s].
    path : Path
        The log, for the message.
    first_line : int
        File line of the first row.
    keep : ndarray of bool or None
        Rows kept (to find a row's file line); ``None`` for all.

    Raises
    ------
    MeasurementError
        Two rows at one instant, or time going back.
    """
    d = np.diff(t)
    if d.size and not (d > 0).all():
        k = int(np.flatnonzero(~(d > 0))[0]) + 1
        row = int(np.flatnonzero(keep)[k]) if keep is not None else k
        raise MeasurementError(f"{path}:{row + first_line}: time {t[k] + 0.0:g} s does not follow {t[k - 1] + 0.0:g} s; expected "
                               "strictly increasing time (one orientation per instant; check time_unit or sort the file)")


def check_values(temperature_c: np.ndarray, accel_g: np.ndarray, where: str) -> None:
    """Plausible units for a 3-axis log: temperature in °C, acceleration in g.

    Parameters
    ----------
    temperature_c : ndarray
        Temperature [°C].
    accel_g : ndarray
        Acceleration, (n, 3) or (n,) [g].
    where : str
        The log, for the message.

    Raises
    ------
    MeasurementError
        A temperature median above 150 (kelvin), or a median |a| above :data:`MAX_MEDIAN_NORM_G`.
    """
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
