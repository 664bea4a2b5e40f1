"""PX4 ULog flight logs (``.ulg``) via pyulog: every ``sensor_accel`` instance as an :class:`ImuLog`.

``sensor_accel`` fields used: ``timestamp`` [µs], ``x``, ``y``, ``z`` [m/s², FRD board frame],
``temperature`` [°C], ``device_id``; one instance per ``multi_id``. The ``sensor_gyro`` instance
of the same ``multi_id`` (``timestamp``, ``x``, ``y``, ``z`` [rad/s], ``device_id``) gives
:attr:`ImuLog.gyro_rad_s`, interpolated linearly onto the accelerometer's times: PX4 publishes
the two topics on their own clocks.
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
GYRO_TOPIC = "sensor_gyro"
GYRO_FIELDS = ("timestamp", "x", "y", "z")
# below this share of accelerometer rows inside the gyro's time span the gyro is left out: the
# rest would be mostly missing, not an IMU's rate
MIN_GYRO_OVERLAP = 0.9
TOPICS_SHOWN = 8


# the message types pyulog reads in the definitions section (ULog spec: flag bits, format, info,
# info multiple, parameter, parameter default) and those that end it (subscription, logging)
DEFINITION_TYPES, SECTION_END = set(b"BFIMPQ"), set(b"ALC")
CRAWL_SIZE = 10_000  # pyulog treats a larger unknown message as corrupt too


def _check_definitions(path: Path) -> None:
    """Walk the definitions section as pyulog will. An unknown message type of size 0 (or > 10 kB)
    makes pyulog resynchronise one byte at a time, rereading up to 64 kB per byte: 10,000 such
    messages kept it busy for minutes. Refuse that section at once, naming the byte."""
    with open(path, "rb") as f:
        if len(f.read(16)) < 16:
            return  # too short for a header: pyulog says so
        offset = 16
        while True:
            raw = f.read(3)
            if len(raw) < 3:
                return
            size, kind = int.from_bytes(raw[:2], "little"), raw[2]
            if kind in SECTION_END:
                return
            if kind not in DEFINITION_TYPES and (kind == 0 or size == 0 or size > CRAWL_SIZE):
                raise MeasurementError(f"{path}: not a readable ULog file: its definitions section is corrupt at byte "
                                       f"{offset} (message type {chr(kind)!r} of {size} bytes, expected a "
                                       "definition or the first subscription)")
            f.seek(size, 1)
            offset += 3 + size


def _parse(path: Path, topics: list[str] | None):
    """pyulog's parse of ``path`` (only ``topics`` when given), its failures as one line."""
    import struct

    from pyulog import ULog
    from pyulog.exceptions import ULogException

    _check_definitions(path)
    try:
        with contextlib.redirect_stdout(io.StringIO()):  # pyulog prints its warnings on corrupt data
            return ULog(str(path), topics)
    # OSError: a corrupt offset makes pyulog seek before the start (EINVAL)
    except (ULogException, ValueError, KeyError, IndexError, struct.error, UnicodeDecodeError, OSError,
            OverflowError) as exc:
        raise MeasurementError(f"{path}: not a readable ULog file ({type(exc).__name__}: {exc})") from None
    except Exception as exc:  # noqa: BLE001  whatever else a malformed file makes the parser raise (a format
        # that refers to itself recurses without end): still the file's fault, said in one line
        detail = " ".join(str(exc).split())[:160]
        raise MeasurementError(f"{path}: not a readable ULog file ({type(exc).__name__}: {detail})") from None


def _missing_topic_error(path: Path) -> MeasurementError:
    topics = sorted({d.name for d in _parse(path, None).data_list})
    if not topics:
        return MeasurementError(f"{path}: no logged data (truncated before the data section?); "
                                f"expected topic {TOPIC!r}")
    shown = ", ".join(topics[:TOPICS_SHOWN]) + (f", ... ({len(topics)} in all)" if len(topics) > TOPICS_SHOWN else "")
    return MeasurementError(f"{path}: no {TOPIC!r} topic (accelerometer data); the log has {shown}")


def _device_id(data, where: str) -> tuple[int | None, tuple[str, ...]]:
    """A topic instance's ``device_id`` (the first logged), with a note when it changes."""
    ids = data.data.get("device_id")
    device_id = int(ids[0]) if ids is not None and ids.size else None
    if ids is not None and np.unique(ids).size > 1:
        return device_id, (f"{where}: device_id changes within the log ({', '.join(map(str, np.unique(ids)))}); "
                           "kept the first",)
    return device_id, ()


def _gyro_samples(data, where: str) -> tuple[np.ndarray, np.ndarray] | str:
    """``(time_s, rate_rad_s)`` of a ``sensor_gyro`` instance, sorted, finite and without repeated
    times; a note (str) instead when it has no usable sample."""
    missing = [f for f in GYRO_FIELDS if f not in data.data]
    if missing:
        return f"{where}: no field(s) {', '.join(missing)}; expected {', '.join(GYRO_FIELDS)}; gyro left out"
    t = data.data["timestamp"].astype(np.float64) * 1e-6
    rate = np.column_stack([data.data[a] for a in "xyz"]).astype(np.float64)
    order = np.argsort(t, kind="stable")
    t, rate = t[order], rate[order]
    keep = np.isfinite(t) & np.isfinite(rate).all(axis=1)
    keep[1:] &= np.diff(t) > 0
    if keep.sum() < 2:
        return f"{where}: fewer than 2 usable samples; gyro left out"
    return t[keep], rate[keep]


def gyro_on_rows(time_s: np.ndarray, gyro_time_s: np.ndarray, gyro_rad_s: np.ndarray,
                 where: str) -> tuple[np.ndarray | None, tuple[str, ...]]:
    """The gyro interpolated linearly onto the accelerometer times ``time_s``, within its own span.

    Parameters
    ----------
    time_s : numpy.ndarray
        Accelerometer times [s], increasing.
    gyro_time_s, gyro_rad_s : numpy.ndarray
        Gyro times [s] (increasing) and rates, shape (m, 3) [rad/s].
    where : str
        For the notes.

    Returns
    -------
    (numpy.ndarray or None, tuple of str)
        Rates, shape (n, 3) [rad/s]; NaN on rows more than half a gyro period outside the gyro's
        span (with a note). ``None`` with a note when under :data:`MIN_GYRO_OVERLAP` of the rows
        are inside it.
    """
    # half a gyro period of slack: the two topics sample on their own clocks, so the first and
    # last accelerometer rows routinely fall just outside the gyro's span
    slack_s = 0.5 * float(np.median(np.diff(gyro_time_s)))
    inside = (time_s >= gyro_time_s[0] - slack_s) & (time_s <= gyro_time_s[-1] + slack_s)
    share = float(inside.mean()) if inside.size else 0.0
    if share < MIN_GYRO_OVERLAP:
        return None, (f"{where}: covers {100 * share:.1f} % of the accelerometer rows "
                      f"({gyro_time_s[0]:.3f}-{gyro_time_s[-1]:.3f} s), under {100 * MIN_GYRO_OVERLAP:.0f} %; "
                      "gyro left out",)
    rate = np.column_stack([np.interp(time_s, gyro_time_s, gyro_rad_s[:, k]) for k in range(3)])
    outside = int((~inside).sum())
    if not outside:
        return rate, ()
    rate[~inside] = np.nan  # not extrapolated: a rate invented past the data is worse than none
    return rate, (f"{where}: {outside} accelerometer row(s) outside the gyro's time span; their gyro is NaN",)


def _gyro(gyro_data, time_s: np.ndarray, path: Path) -> tuple[np.ndarray | None, int | None, tuple[str, ...]]:
    """Rates on the accelerometer rows, the gyro's device id and notes (all empty without a gyro)."""
    if gyro_data is None:
        return None, None, ()
    where = f"{path} {GYRO_TOPIC} instance {gyro_data.multi_id}"
    device_id, notes = _device_id(gyro_data, where)
    samples = _gyro_samples(gyro_data, where)
    if isinstance(samples, str):
        return None, device_id, notes + (samples,)
    rate, more = gyro_on_rows(time_s, *samples, where)
    return rate, device_id, notes + more


def _imu_log(data, gyro_data, path: Path, corrupt: bool) -> ImuLog:
    """One ``sensor_accel`` instance (a pyulog ``ULog.Data``) and its ``sensor_gyro`` instance
    (``None`` when not logged) as an :class:`ImuLog`."""
    where = f"{path} {TOPIC} instance {data.multi_id}"
    missing = [f for f in FIELDS if f not in data.data]
    if missing:
        raise MeasurementError(f"{where}: no field(s) {', '.join(missing)}; expected {', '.join(FIELDS)}")
    time_s = data.data["timestamp"].astype(np.float64) * 1e-6
    accel_g = np.column_stack([data.data[a] for a in "xyz"]).astype(np.float64) / STANDARD_GRAVITY
    t, temp, acc, notes = drop_unusable_rows(time_s, data.data["temperature"].astype(np.float64), accel_g, where)
    device_id, id_notes = _device_id(data, where)
    gyro, gyro_id, gyro_notes = _gyro(gyro_data, t, path)
    notes += id_notes + gyro_notes
    if corrupt:
        notes += (f"{path}: pyulog found corrupt data and skipped it",)
    return ImuLog(t, temp, acc, int(data.multi_id), device_id, str(path), notes, gyro_rad_s=gyro,
                  gyro_device_id=gyro_id)


def read_ulog(path: str | Path) -> list[ImuLog]:
    """Every ``sensor_accel`` instance of a PX4 ULog, in ``multi_id`` order, each with the gyro of
    its ``multi_id`` when ``sensor_gyro`` is logged.

    Parameters
    ----------
    path : str or Path
        The ``.ulg`` log.

    Returns
    -------
    list of ImuLog
        One per instance: time [s], temperature [°C], acceleration [g], gyro [rad/s].

    Raises
    ------
    MeasurementError
        Missing, empty, not a ULog, unreadable, or without ``sensor_accel`` (the message lists
        the topics the log does have).
    """
    path = Path(path)
    require_signature(path, ULOG_SIGNATURE, "PX4 ULog file")
    ulog = _parse(path, [TOPIC, GYRO_TOPIC])
    data = sorted((d for d in ulog.data_list if d.name == TOPIC), key=lambda d: d.multi_id)
    if not data:
        raise _missing_topic_error(path)
    gyros = {d.multi_id: d for d in ulog.data_list if d.name == GYRO_TOPIC}
    return [_imu_log(d, gyros.get(d.multi_id), path, ulog.file_corruption) for d in data]


def sniff_ulog(path: Path) -> bool:
    """Whether ``path`` starts with the ULog signature (its file magic).

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
        return f.read(len(ULOG_SIGNATURE)) == ULOG_SIGNATURE


def _read(path: Path, options: ReadOptions) -> list[ImuLog]:
    return read_ulog(path)


register_reader("ulog", (".ulg", ".ulog"), _read, sniff=sniff_ulog,
                description="PX4 ULog: sensor_accel (and sensor_gyro), every instance")
