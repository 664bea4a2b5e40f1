"""PX4 ULog flight logs (``.ulg``) via pyulog: every ``sensor_accel`` instance as an :class:`ImuLog`.

``sensor_accel`` fields used: ``timestamp`` [µs], ``x``, ``y``, ``z`` [m/s², FRD board frame],
``temperature`` [°C], ``device_id``; one instance per ``multi_id``.
"""

from __future__ import annotations

import contextlib
import io
from pathlib import Path

import numpy as np

from twin.measurement.core import STANDARD_GRAVITY, MeasurementError
from twin.measurement.imu import ImuLog, drop_unusable_rows
from twin.measurement.registry import ReadOptions, register_reader, require_signature

ULOG_SIGNATURE = b"ULog\x01\x12\x35"
TOPIC = "sensor_accel"
FIELDS = ("timestamp", "x", "y", "z", "temperature")
TOPICS_SHOWN = 8


def _parse(path: Path, topics: list[str] | None):
    """pyulog's parse of ``path`` (only ``topics`` when given), its failures as one line."""
    import struct

    from pyulog import ULog
    from pyulog.exceptions import ULogException

    try:
        with contextlib.redirect_stdout(io.StringIO()):  # pyulog prints its warnings on corrupt data
            return ULog(str(path), topics)
    # OSError: a corrupt offset makes pyulog seek before the start (EINVAL)
    except (ULogException, ValueError, KeyError, IndexError, struct.error, UnicodeDecodeError, OSError,
            OverflowError) as exc:
        raise MeasurementError(f"{path}: not a readable ULog file ({type(exc).__name__}: {exc})") from None


def _missing_topic_error(path: Path) -> MeasurementError:
    topics = sorted({d.name for d in _parse(path, None).data_list})
    if not topics:
        return MeasurementError(f"{path}: no logged data (truncated before the data section?); "
                                f"expected topic {TOPIC!r}")
    shown = ", ".join(topics[:TOPICS_SHOWN]) + (f", ... ({len(topics)} in all)" if len(topics) > TOPICS_SHOWN else "")
    return MeasurementError(f"{path}: no {TOPIC!r} topic (accelerometer data); the log has {shown}")


def _imu_log(data, path: Path, corrupt: bool) -> ImuLog:
    """One ``sensor_accel`` instance (a pyulog ``ULog.Data``) as an :class:`ImuLog`."""
    where = f"{path} {TOPIC} instance {data.multi_id}"
    missing = [f for f in FIELDS if f not in data.data]
    if missing:
        raise MeasurementError(f"{where}: no field(s) {', '.join(missing)}; expected {', '.join(FIELDS)}")
    time_s = data.data["timestamp"].astype(np.float64) * 1e-6
    accel_g = np.column_stack([data.data[a] for a in "xyz"]).astype(np.float64) / STANDARD_GRAVITY
    t, temp, acc, notes = drop_unusable_rows(time_s, data.data["temperature"].astype(np.float64), accel_g, where)
    ids = data.data.get("device_id")
    device_id = int(ids[0]) if ids is not None and ids.size else None
    if ids is not None and np.unique(ids).size > 1:
        notes += (f"{where}: device_id changes within the log ({', '.join(map(str, np.unique(ids)))}); kept the first",)
    if corrupt:
        notes += (f"{path}: pyulog found corrupt data and skipped it",)
    return ImuLog(t, temp, acc, int(data.multi_id), device_id, str(path), notes)


def read_ulog(path: str | Path) -> list[ImuLog]:
    """Every ``sensor_accel`` instance of a PX4 ULog, in ``multi_id`` order.

    Raises
    ------
    MeasurementError
        Missing, empty, not a ULog, unreadable, or without ``sensor_accel`` (the message lists
        the topics the log does have).
    """
    path = Path(path)
    require_signature(path, ULOG_SIGNATURE, "PX4 ULog file")
    ulog = _parse(path, [TOPIC])
    data = sorted((d for d in ulog.data_list if d.name == TOPIC), key=lambda d: d.multi_id)
    if not data:
        raise _missing_topic_error(path)
    return [_imu_log(d, path, ulog.file_corruption) for d in data]


def sniff_ulog(path: Path) -> bool:
    with path.open("rb") as f:
        return f.read(len(ULOG_SIGNATURE)) == ULOG_SIGNATURE


def _read(path: Path, options: ReadOptions) -> list[ImuLog]:
    return read_ulog(path)


register_reader("ulog", (".ulg", ".ulog"), _read, sniff=sniff_ulog,
                description="PX4 ULog: sensor_accel, every instance")
