"""The reader registry: one module per format registers itself; loading dispatches by suffix.

In the style of meshio's ``register_format``: :func:`register_reader` adds a format, and
:func:`load_measurements` / :func:`read_imu_logs` pick the reader by the file's suffix, sniffing
the content where several readers claim the suffix or none does. A user's reader is one file
loaded by :func:`load_reader_plugin`.

A reader is ``read(path, options) -> Measurement | ImuLog | list[ImuLog]``, with ``options`` a
:class:`ReadOptions`.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Callable, Union

import numpy as np

from twin.measurement.columns import ColumnMap
from twin.measurement.core import Measurement, MeasurementError, concatenate
from twin.measurement.imu import ImuLog

ReadResult = Union[Measurement, ImuLog, list]


@dataclass(frozen=True)
class ReadOptions:
    """What a reader may need beyond the path.

    Attributes
    ----------
    columns : ColumnMap or None
        Column map for delimited logs (``None``: the canonical CSV).
    skip_bad_rows : bool
        Skip and count corrupted rows instead of failing.
    applied_g : float or None
        Acceleration along the axis [g] for files that do not log it; ``None`` means unknown.
    """

    columns: ColumnMap | None = None
    skip_bad_rows: bool = False
    applied_g: float | None = None


@dataclass(frozen=True)
class Reader:
    """A registered format: its name, the suffixes it claims, its read function and sniffer.

    Attributes
    ----------
    name : str
        Format name.
    suffixes : tuple of str
        File suffixes claimed, lower case with the dot.
    read : callable
        ``read(path, options)`` → Measurement, ImuLog or list of ImuLog.
    sniff : callable or None
        ``sniff(path)`` → whether the content is this format.
    description : str
        One line for ``twin formats``.
    priority : int
        Sniffing order, highest first.
    """

    name: str
    suffixes: tuple[str, ...]
    read: Callable[[Path, ReadOptions], ReadResult]
    sniff: Callable[[Path], bool] | None = None
    description: str = ""
    priority: int = 0


_READERS: dict[str, Reader] = {}


def register_reader(name: str, suffixes, read_fn: Callable[[Path, ReadOptions], ReadResult],
                    sniff: Callable[[Path], bool] | None = None, *, description: str = "",
                    priority: int = 0) -> Reader:
    """Register (or replace) the reader ``name`` for ``suffixes`` (e.g. ``[".ulg"]``).

    ``sniff(path) -> bool`` says from the content whether the file is this format; it decides
    when several readers claim a suffix, or when no reader claims it. Sniffers run by descending
    ``priority``, then in registration order (a catch-all such as plain text takes a negative one).

    Parameters
    ----------
    name : str
        Format name.
    suffixes : str or sequence of str
        Suffixes claimed, each starting with ``.``.
    read_fn : callable
        ``read_fn(path, options)`` → Measurement, ImuLog or list of ImuLog.
    sniff : callable, optional
        ``sniff(path)`` → bool.
    description : str
        One line for ``twin formats``.
    priority : int
        Sniffing order, highest first.

    Returns
    -------
    Reader
        The registered reader.
    """
    if not callable(read_fn) or (sniff is not None and not callable(sniff)):
        raise MeasurementError(f"reader {name!r}: read_fn and sniff must be callables")
    suffixes = (suffixes,) if isinstance(suffixes, str) else tuple(suffixes)
    bad = [s for s in suffixes if not (isinstance(s, str) and s.startswith("."))]
    if not name or bad:
        raise MeasurementError(f"reader {name!r}: suffixes must start with '.', got {bad}")
    reader = Reader(name, tuple(s.lower() for s in suffixes), read_fn, sniff, description, priority)
    _READERS[name] = reader
    return reader


def unregister_reader(name: str) -> None:
    """Remove the reader ``name`` (a no-op if it is not registered).

    Parameters
    ----------
    name : str
        Format name.
    """
    _READERS.pop(name, None)


def readers() -> dict[str, Reader]:
    """The registered readers by name, in registration order (a copy).

    Returns
    -------
    dict of str to Reader
        The readers.
    """
    return dict(_READERS)


def known_formats() -> str:
    """``"name (.a, .b), ..."`` for error messages.

    Returns
    -------
    str
        Every format with its suffixes.
    """
    return ", ".join(f"{r.name} ({', '.join(r.suffixes)})" for r in _READERS.values())


def _sniffs(reader: Reader, path: Path) -> bool:
    try:
        return bool(reader.sniff(path)) if reader.sniff is not None else False
    except OSError:
        return False


def find_reader(path: str | Path) -> Reader:
    """The reader for ``path``: by suffix, sniffing among several claimants or when none claims it.

    Parameters
    ----------
    path : str or Path
        The file.

    Returns
    -------
    Reader
        The reader chosen.

    Raises
    ------
    MeasurementError
        The file is missing (when sniffing is needed) or no registered reader recognises it.
    """
    path = Path(path)
    ordered = sorted(_READERS.values(), key=lambda r: -r.priority)  # stable: registration order within a priority
    claim = [r for r in ordered if path.suffix.lower() in r.suffixes]
    if len(claim) == 1:
        return claim[0]
    if claim:
        return next((r for r in claim if _sniffs(r, path)), claim[0])
    if not path.is_file():
        raise MeasurementError(f"{path}: measurement file not found")
    found = next((r for r in ordered if _sniffs(r, path)), None)
    if found is None:
        raise MeasurementError(f"{path}: unknown measurement format (suffix {path.suffix or 'none'!r}); "
                               f"known formats: {known_formats()}")
    return found


def load_reader_plugin(path_or_module: str | Path, base_dir: str | Path = ".") -> list[Reader]:
    """Import a user's reader module (a ``.py`` path or a module name); the readers it registered.

    Parameters
    ----------
    path_or_module : str or Path
        A ``.py`` path (relative to ``base_dir``) or a module name.
    base_dir : str or Path
        Directory a relative path is resolved against.

    Returns
    -------
    list of Reader
        The readers whose read function the module defines.

    Raises
    ------
    MeasurementError
        The module cannot be imported, or registers no reader.
    """
    from twin.plugins import import_plugin

    module = import_plugin(str(path_or_module), base_dir, error=MeasurementError)
    mine = [r for r in _READERS.values() if getattr(r.read, "__module__", None) == module.__name__]
    if not mine:
        raise MeasurementError(f"reader plugin {path_or_module}: registered no reader; "
                               "call twin.measurement.register_reader(name, suffixes, read_fn) in it")
    return mine


def read_any(path: str | Path, options: ReadOptions | None = None) -> ReadResult:
    """Whatever the registered reader for ``path`` returns.

    Parameters
    ----------
    path : str or Path
        The file.
    options : ReadOptions, optional
        Column map, bad-row handling, applied acceleration [g].

    Returns
    -------
    Measurement or ImuLog or list of ImuLog
        The reader's result.
    """
    path = Path(path)
    return find_reader(path).read(path, options or ReadOptions())


def as_imu_logs(result: ReadResult, path: Path) -> list[ImuLog]:
    """A reader's result as IMU logs (a single-axis Measurement cannot be one).

    Parameters
    ----------
    result : Measurement or ImuLog or list of ImuLog
        What a reader returned.
    path : Path
        The file, for messages.

    Returns
    -------
    list of ImuLog
        The logs.
    """
    if isinstance(result, ImuLog):
        return [result]
    if isinstance(result, list) and all(isinstance(r, ImuLog) for r in result):
        return result
    raise MeasurementError(f"{path}: holds a single-axis measurement, not 3-axis IMU data; "
                           "for a delimited log name the x, y, z columns in the column map")


def as_measurement(result: ReadResult, path: Path, axis: str, instance: int | None,
                   applied_g: float | None) -> Measurement:
    """A reader's result as one single-axis Measurement: ``axis`` of IMU ``instance`` (default: the first).

    Parameters
    ----------
    result : Measurement or ImuLog or list of ImuLog
        What a reader returned.
    path : Path
        The file, for messages.
    axis : str
        ``"x"``, ``"y"`` or ``"z"``.
    instance : int or None
        IMU instance.
    applied_g : float or None
        Acceleration applied along the axis [g]; ``None``: unknown.

    Returns
    -------
    Measurement
        Time [s], temperature [°C], output [g].
    """
    if isinstance(result, Measurement):
        return result
    logs = as_imu_logs(result, path)
    if not logs:
        raise MeasurementError(f"{path}: holds no IMU data")
    chosen = logs[0] if instance is None else next((g for g in logs if g.instance == instance), None)
    if chosen is None:
        raise MeasurementError(f"{path}: no IMU instance {instance}; instances are "
                               f"{', '.join(str(g.instance) for g in logs)}")
    m = chosen.axis(axis, applied_g)
    if len(logs) > 1:
        m.notes.append(f"{path}: {len(logs)} IMU instances; compared instance {chosen.instance}, axis {axis}")
    return m


def load_measurements(paths: list[str | Path], cmap: ColumnMap | None = None, *, skip_bad_rows: bool = False,
                      applied_g: float | None | str = 1.0, axis: str | None = None,
                      instance: int | None = None) -> Measurement:
    """Read one or more files (any registered format) as runs of one device.

    Parameters
    ----------
    paths : list of path
        Several files are several runs.
    cmap : ColumnMap, optional
        For delimited logs.
    skip_bad_rows : bool
        Skip and count corrupted rows instead of failing.
    applied_g : float or "unknown"
        Value for files without an applied column [g]; ``"unknown"`` when the orientation was not logged.
    axis, instance : optional
        For multi-axis logs: the axis (default ``cmap.axis``, else ``"z"``) and IMU instance
        (default: the first) compared.

    Returns
    -------
    Measurement
        Time [s], temperature [°C], output and applied acceleration [g], runs concatenated.
    """
    if not paths:
        raise MeasurementError("no measurement files given")
    unknown = isinstance(applied_g, str) and applied_g == "unknown"
    value = None
    if not unknown and applied_g is not None:
        try:
            value = float(applied_g)
        except (TypeError, ValueError):
            value = np.nan
        if not np.isfinite(value):
            raise MeasurementError(f"--applied-g / applied_g: got {applied_g!r}, expected a finite acceleration "
                                   "in g or 'unknown'")
    options = ReadOptions(cmap, skip_bad_rows, value)
    axis = axis or (cmap.axis if cmap is not None else "z")
    parts = [as_measurement(read_any(p, options), Path(p), axis, instance, options.applied_g) for p in paths]
    m = concatenate(parts) if len(parts) > 1 else parts[0]
    if unknown:
        m.applied_g = np.full(m.time_s.size, np.nan)
        m.applied_known = False
    return m


def read_imu_logs(path: str | Path, cmap: ColumnMap | None = None, *, skip_bad_rows: bool = False) -> list[ImuLog]:
    """Every IMU instance of a flight log or 3-axis table, one :class:`ImuLog` each.

    Parameters
    ----------
    path : str or Path
        The log.
    cmap : ColumnMap, optional
        For a 3-axis delimited or Parquet table.
    skip_bad_rows : bool
        Skip and count corrupted rows instead of failing.

    Returns
    -------
    list of ImuLog
        One per instance: time [s], temperature [°C], acceleration [g].
    """
    path = Path(path)
    return as_imu_logs(read_any(path, ReadOptions(cmap, skip_bad_rows, None)), path)


def imu_logs_by_instance(paths, cmap: ColumnMap | None = None, imu: str | int | None = "all", *,
                         skip_bad_rows: bool = False) -> dict[int, list[ImuLog]]:
    """IMU instance → its logs over ``paths`` (several files = several runs of one IMU), all
    instances or the one ``imu`` names; an instance the logs lack is an error naming those they hold.

    Parameters
    ----------
    paths : sequence of str or Path
        The logs.
    cmap : ColumnMap, optional
        For 3-axis tables.
    imu : str or int or None
        An instance number, or ``"all"`` / ``None``.
    skip_bad_rows : bool
        Skip and count corrupted rows instead of failing.

    Returns
    -------
    dict of int to list of ImuLog
        Logs per instance, in the order of ``paths``.
    """
    per: dict[int, list[ImuLog]] = {}
    for path in paths:
        for log in read_imu_logs(path, cmap, skip_bad_rows=skip_bad_rows):
            per.setdefault(log.instance, []).append(log)
    if imu in (None, "all"):
        return per
    try:
        n = int(imu)
    except ValueError:
        raise MeasurementError(f"--imu expects an instance number or 'all', got {imu!r}") from None
    if n not in per:
        raise MeasurementError(f"{', '.join(map(str, paths))}: no IMU instance {n}; the log holds instances "
                               f"{sorted(per)}")
    return {n: per[n]}


def require_signature(path: Path, signature: bytes, what: str) -> None:
    """Fail in one line unless ``path`` exists, is not empty and starts with ``signature``.

    Parameters
    ----------
    path : Path
        The file.
    signature : bytes
        The format's magic bytes.
    what : str
        The format, for messages.
    """
    if not path.is_file():
        raise MeasurementError(f"{path}: measurement file not found")
    with path.open("rb") as f:
        head = f.read(len(signature))
    if not head:
        raise MeasurementError(f"{path}: empty file; expected a {what}")
    if len(head) < len(signature) and signature.startswith(head):
        raise MeasurementError(f"{path}: truncated: {len(head)} byte(s), shorter than a {what}'s signature")
    if head != signature:
        raise MeasurementError(f"{path}: not a {what} (starts with {head.hex()}, expected {signature.hex()})")
