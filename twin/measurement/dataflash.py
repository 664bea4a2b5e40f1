"""ArduPilot DataFlash binary logs (``.bin``) via pymavlink: ``IMU`` messages, one :class:`ImuLog` per instance.

``IMU`` fields used: ``TimeUS`` [µs], ``AccX``, ``AccY``, ``AccZ`` [m/s², FRD body frame], ``T``
[°C] and the instance: ``I`` since ArduPilot 4.1 (``Instance`` accepted too); logs from before
4.1 name the instances ``IMU``, ``IMU2``, ``IMU3`` instead. ``TCLR`` records (the firmware's own
temperature-calibration learning) are kept per instance in :attr:`ImuLog.records`; the device id
comes from the ``INS_ACC_ID``/``INS_ACC2_ID``/``INS_ACC3_ID`` parameters when logged.
"""

from __future__ import annotations

import contextlib
import io
import os
import sys
import tempfile
from collections import defaultdict
from pathlib import Path

import numpy as np

from twin.measurement.core import STANDARD_GRAVITY, MeasurementError
from twin.measurement.imu import ImuLog, drop_unusable_rows
from twin.measurement.registry import ReadOptions, register_reader, require_signature

DATAFLASH_SIGNATURE = b"\xa3\x95"
IMU_MESSAGES = {"IMU": 0, "IMU2": 1, "IMU3": 2}  # pre-4.1 logs: one message name per instance
INSTANCE_FIELDS = ("I", "Instance")
IMU_FIELDS = ("TimeUS", "AccX", "AccY", "AccZ", "T")
TCLR_FIELDS = {"TimeUS": "time_s", "SType": "sensor_type", "Temp": "temperature_c", "X": "x", "Y": "y", "Z": "z",
               "NSamp": "samples"}
DEVICE_ID_PARAMS = ("INS_ACC_ID", "INS_ACC2_ID", "INS_ACC3_ID")


@contextlib.contextmanager
def _quiet():
    """Silence pymavlink, which prints on bad bytes from Python and from its C indexer (file descriptor 2)."""
    sink = io.StringIO()
    with contextlib.redirect_stdout(sink), contextlib.redirect_stderr(sink), tempfile.TemporaryFile() as tmp:
        sys.stderr.flush()
        saved = os.dup(2)
        os.dup2(tmp.fileno(), 2)
        try:
            yield
        finally:
            os.dup2(saved, 2)
            os.close(saved)


def _messages(path: Path):
    """``(IMU rows by instance, TCLR rows by instance, parameters)`` from pymavlink's parse."""
    from pymavlink.DFReader import DFReader_binary

    imu, tclr = defaultdict(list), defaultdict(list)
    try:
        with _quiet():
            log = DFReader_binary(str(path), zero_time_base=True)
            try:
                while (m := log.recv_match(type=[*IMU_MESSAGES, "TCLR"])) is not None:
                    _collect(m.to_dict(), imu, tclr, path)
                params = dict(log.params)
            finally:
                log.close()
    except MeasurementError:
        raise
    except Exception as exc:  # pymavlink raises bare Exception for unsupported format characters
        raise MeasurementError(f"{path}: not a readable DataFlash log ({type(exc).__name__}: {exc})") from None
    return imu, tclr, params


def _collect(msg: dict, imu: dict, tclr: dict, path: Path) -> None:
    name = msg["mavpackettype"]
    inst_field = next((f for f in INSTANCE_FIELDS if f in msg), None)
    instance = int(msg[inst_field]) if inst_field else IMU_MESSAGES.get(name, 0)
    if name == "TCLR":
        tclr[instance].append([msg.get(f, np.nan) for f in TCLR_FIELDS])
        return
    missing = [f for f in IMU_FIELDS if f not in msg]
    if missing:
        raise MeasurementError(f"{path}: {name} messages have no field(s) {', '.join(missing)}; "
                               f"expected {', '.join(IMU_FIELDS)}")
    imu[instance].append([msg[f] for f in IMU_FIELDS])


def _tclr_records(rows: list) -> dict[str, dict[str, np.ndarray]]:
    if not rows:
        return {}
    table = np.asarray(rows, dtype=float)
    record = {key: table[:, k] for k, key in enumerate(TCLR_FIELDS.values())}
    record["time_s"] = record["time_s"] * 1e-6
    return {"TCLR": record}


def _imu_log(instance: int, rows: list, tclr_rows: list, params: dict, path: Path) -> ImuLog:
    where = f"{path} IMU instance {instance}"
    table = np.asarray(rows, dtype=np.float64)
    t, temp, acc, notes = drop_unusable_rows(table[:, 0] * 1e-6, table[:, 4], table[:, 1:4] / STANDARD_GRAVITY, where)
    records = _tclr_records(tclr_rows)
    if records:
        notes += (f"{where}: {len(tclr_rows)} TCLR record(s) (ArduPilot temperature-calibration learning)",)
    key = DEVICE_ID_PARAMS[instance] if instance < len(DEVICE_ID_PARAMS) else None
    device_id = int(round(params[key])) if key in params and params[key] else None
    return ImuLog(t, temp, acc, instance, device_id, str(path), notes, records)


def read_dataflash(path: str | Path) -> list[ImuLog]:
    """Every IMU instance of an ArduPilot DataFlash ``.bin`` log, in instance order.

    Raises
    ------
    MeasurementError
        Missing, empty, not a DataFlash log, or without IMU messages.
    """
    path = Path(path)
    require_signature(path, DATAFLASH_SIGNATURE, "DataFlash .bin log")
    imu, tclr, params = _messages(path)
    if not imu:
        raise MeasurementError(f"{path}: no IMU messages (accelerometer data) in this DataFlash log; "
                               "expected IMU with TimeUS, I, AccX, AccY, AccZ, T "
                               "(ArduPilot logs them when LOG_BITMASK includes IMU)")
    return [_imu_log(i, imu[i], tclr.get(i, []), params, path) for i in sorted(imu)]


def sniff_dataflash(path: Path) -> bool:
    with path.open("rb") as f:
        return f.read(2) == DATAFLASH_SIGNATURE


def _read(path: Path, options: ReadOptions) -> list[ImuLog]:
    return read_dataflash(path)


register_reader("dataflash", (".bin",), _read, sniff=sniff_dataflash,
                description="ArduPilot DataFlash binary log: IMU messages, every instance")
