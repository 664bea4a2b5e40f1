"""ArduPilot DataFlash binary logs (``.bin``) via pymavlink: ``IMU`` messages, one :class:`ImuLog` per instance.

``IMU`` fields used: time ``TimeUS`` [µs], ``AccX``, ``AccY``, ``AccZ`` [m/s², FRD body frame],
temperature ``T`` [°C], ``GyrX``, ``GyrY``, ``GyrZ`` [rad/s] when logged, and the instance: ``I``
since ArduPilot 4.1 (``Instance`` accepted too); logs from before 4.1 name the instances ``IMU``,
``IMU2``, ``IMU3`` instead. Older releases spelled fields differently (Copter 3.2: ``TimeMS`` [ms]
and no temperature; 3.3: ``Temp``): :data:`IMU_FIELD_NAMES` maps every spelling read.

``TCLR`` records (the firmware's own temperature-calibration learning; ``SType`` 0 accelerometer,
1 gyro) are kept per instance in :attr:`ImuLog.records`. Device ids come from the
``INS_ACC_ID``/``INS_ACC2_ID``/``INS_ACC3_ID`` and ``INS_GYR_ID``/``INS_GYR2_ID``/``INS_GYR3_ID``
parameters when logged; a value that cannot be a device id is left out with a note.
"""

from __future__ import annotations

import contextlib
import io
import math
import os
import sys
import tempfile
from collections import defaultdict
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from twin.measurement.core import STANDARD_GRAVITY, MeasurementError
from twin.measurement.imu import ImuLog, drop_unusable_rows
from twin.measurement.registry import ReadOptions, register_reader, require_signature

DATAFLASH_SIGNATURE = b"\xa3\x95"
IMU_MESSAGES = {"IMU": 0, "IMU2": 1, "IMU3": 2}  # pre-4.1 logs: one message name per instance
INSTANCE_FIELDS = ("I", "Instance")
# each quantity read from IMU, in row order → its field names, newest spelling first (ArduPilot
# libraries/AP_Logger/LogStructure.h: TimeMS up to Copter 3.2, Temp in 3.3, T since)
IMU_FIELD_NAMES = {
    "time": ("TimeUS", "TimeMS"),
    "accel_x": ("AccX",),
    "accel_y": ("AccY",),
    "accel_z": ("AccZ",),
    "temperature": ("T", "Temp"),
}
TIME_FACTORS_S = {"TimeUS": 1e-6, "TimeMS": 1e-3}
GYRO_FIELDS = ("GyrX", "GyrY", "GyrZ")
TCLR_FIELDS = {"TimeUS": "time_s", "SType": "sensor_type", "Temp": "temperature_c", "X": "x", "Y": "y", "Z": "z",
               "NSamp": "samples"}
TCLR_SENSOR_TYPES = {0: "accelerometer", 1: "gyro"}  # ArduPilot AP_InertialSensor_tempcal: SType
DEVICE_ID_PARAMS = ("INS_ACC_ID", "INS_ACC2_ID", "INS_ACC3_ID")
GYRO_DEVICE_ID_PARAMS = ("INS_GYR_ID", "INS_GYR2_ID", "INS_GYR3_ID")
DEVICE_ID_MAX = 2**32 - 1  # ArduPilot device ids are uint32


@dataclass(frozen=True)
class _Layout:
    """Which fields of one IMU message format are read (in row order), seconds per time unit, and
    whether it has the gyro."""

    fields: tuple[str, ...]
    time_factor_s: float
    has_gyro: bool


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


IMU_ROW_FIELDS = ("time", "AccX", "AccY", "AccZ", "temperature", *GYRO_FIELDS, "time scale")
CHUNK_ROWS = 1 << 16  # IMU rows held as Python lists before they become one float64 block


class _Rows:
    """One instance's IMU rows: Python lists only until :data:`CHUNK_ROWS` of them, then a float64
    block (a list row costs ~5× its floats: a long log's lists were the reader's peak)."""

    def __init__(self, path: Path):
        self.path, self.pending, self.blocks = path, [], []

    def append(self, row: list) -> None:
        self.pending.append(row)
        if len(self.pending) >= CHUNK_ROWS:
            self.blocks.append(_float_table(self.pending, IMU_ROW_FIELDS, "IMU", self.path))
            self.pending = []

    def __bool__(self) -> bool:
        return bool(self.pending or self.blocks)

    def table(self) -> np.ndarray:
        """Every row, (n, 9) float64."""
        if self.pending:
            self.blocks.append(_float_table(self.pending, IMU_ROW_FIELDS, "IMU", self.path))
            self.pending = []
        return self.blocks[0] if len(self.blocks) == 1 else np.concatenate(self.blocks)


def _messages(path: Path):
    """``(IMU rows by instance, gyro-less instances, TCLR rows by instance, parameters)`` from pymavlink's parse."""
    from pymavlink.DFReader import DFReader_binary

    imu, tclr, no_gyro, layouts = defaultdict(lambda: _Rows(path)), defaultdict(list), set(), {}
    try:
        with _quiet():
            log = DFReader_binary(str(path), zero_time_base=True)
            try:
                while (m := log.recv_match(type=[*IMU_MESSAGES, "TCLR"])) is not None:
                    _collect(m.to_dict(), imu, tclr, no_gyro, layouts, path)
                params = dict(log.params)
            finally:
                log.close()
    except MeasurementError:
        raise
    except Exception as exc:  # pymavlink raises bare Exception for unsupported format characters
        raise MeasurementError(f"{path}: not a readable DataFlash log ({type(exc).__name__}: {exc})") from None
    return imu, no_gyro, tclr, params


def _expected_fields() -> str:
    """``"TimeUS (or TimeMS), AccX, ..."``: the IMU fields read, for messages."""
    return ", ".join(" (or ".join(names) + ")" * (len(names) - 1) for names in IMU_FIELD_NAMES.values())


def _layout(msg: dict, path: Path) -> _Layout:
    """The layout of an IMU message format, from one of its messages (the first spelling found wins)."""
    fields, missing = [], []
    for names in IMU_FIELD_NAMES.values():
        found = next((f for f in names if f in msg), None)
        if found is None:
            missing.append(" or ".join(names))
        fields.append(found)
    if missing:
        raise MeasurementError(f"{path}: {msg['mavpackettype']} messages have no field(s) {', '.join(missing)}; "
                               f"expected {_expected_fields()}")
    has_gyro = all(f in msg for f in GYRO_FIELDS)
    fields += GYRO_FIELDS if has_gyro else ()
    # a format is fixed per message name: its first message shows every field's type; text is
    # refused even when it looks numeric (ArduPilot logs no quantity as text: a foreign FMT)
    text = next((f for f in fields if not _is_number(msg[f])), None)
    if text is not None:
        raise MeasurementError(f"{path}: {msg['mavpackettype']} field {text} holds text ({str(msg[text])[:40]!r}); "
                               "expected a number (the log's FMT gives it a text type)")
    return _Layout(tuple(fields), TIME_FACTORS_S[fields[0]], has_gyro)


def _is_number(value) -> bool:
    return isinstance(value, (int, float, np.integer, np.floating)) and not isinstance(value, bool)


def _instance(msg: dict, name: str, path: Path) -> int:
    """The IMU instance of a message: its instance field, else the message name's (pre-4.1)."""
    inst_field = next((f for f in INSTANCE_FIELDS if f in msg), None)
    if inst_field is None:
        return IMU_MESSAGES.get(name, 0)
    value = msg[inst_field]
    if not _is_number(value):
        raise MeasurementError(f"{path}: {name} field {inst_field} holds text ({value!r}); "
                               "expected an integer IMU instance number")
    return int(value)


def _collect(msg: dict, imu: dict, tclr: dict, no_gyro: set, layouts: dict, path: Path) -> None:
    name = msg["mavpackettype"]
    instance = _instance(msg, name, path)
    if name == "TCLR":
        tclr[instance].append([msg.get(f, np.nan) for f in TCLR_FIELDS])
        return
    layout = layouts.get(name)
    if layout is None:
        layout = layouts[name] = _layout(msg, path)
    if not layout.has_gyro:
        no_gyro.add(instance)
    # rows have one width whatever the format: an instance fed by a gyro-less format gets no gyro
    imu[instance].append([msg[f] for f in layout.fields] + ([] if layout.has_gyro else [math.nan] * 3)
                         + [layout.time_factor_s])


def _float_table(rows: list, fields: tuple[str, ...], what: str, path: Path) -> np.ndarray:
    """``rows`` as a float64 table; a text-typed field is named in one line."""
    try:
        return np.asarray(rows, dtype=np.float64)
    except (TypeError, ValueError):
        pass
    for row in rows:
        for field_name, value in zip(fields, row):
            if not _is_number(value):
                raise MeasurementError(f"{path}: {what} field {field_name} holds text ({str(value)[:40]!r}); "
                                       "expected a number (the log's FMT gives it a text type)")
    raise MeasurementError(f"{path}: {what} messages do not convert to numbers; expected numeric fields")


def _tclr_records(rows: list, path: Path) -> dict[str, dict[str, np.ndarray]]:
    if not rows:
        return {}
    table = _float_table(rows, tuple(TCLR_FIELDS), "TCLR", path)
    record = {key: table[:, k] for k, key in enumerate(TCLR_FIELDS.values())}
    record["time_s"] = record["time_s"] * 1e-6
    return {"TCLR": record}


def _tclr_note(records: dict, where: str) -> tuple[str, ...]:
    """What the TCLR records hold, by sensor type (a consumer separates them by ``sensor_type``)."""
    if not records:
        return ()
    kinds = records["TCLR"]["sensor_type"]
    counts = ", ".join(f"{int((kinds == code).sum())} {label}" for code, label in TCLR_SENSOR_TYPES.items())
    return (f"{where}: {kinds.size} TCLR record(s) (ArduPilot temperature-calibration learning; "
            f"SType: {counts})",)


def device_id_from_param(params: dict, name: str | None, where: str) -> tuple[int | None, tuple[str, ...]]:
    """The device id a parameter holds, and a note when its value cannot be one.

    Parameters
    ----------
    params : dict
        The log's parameters by name (values as pymavlink gives them, float).
    name : str or None
        The parameter (e.g. ``INS_ACC2_ID``); ``None`` for an instance beyond the three named.
    where : str
        The file and instance, for the note.

    Returns
    -------
    (int or None, tuple of str)
        ``None`` when the parameter is absent, 0 (no sensor), or not a whole number from 1 to
        2³²−1 (NaN, infinite, negative, a fraction, too large: then with a note).
    """
    if name is None or name not in params:
        return None, ()
    value = params[name]
    try:
        number = float(value)
    except (TypeError, ValueError):
        number = math.nan
    if math.isfinite(number) and number == int(number) and 0 <= number <= DEVICE_ID_MAX:
        return (int(number) or None), ()
    shown = f"{number:g}" if _is_number(value) else repr(value)[:40]
    return None, (f"{where}: parameter {name} = {shown} is not a device id (expected a whole number "
                  f"from 0 to {DEVICE_ID_MAX}); device id unknown",)


def _id_param(names: tuple[str, ...], instance: int) -> str | None:
    return names[instance] if instance < len(names) else None


def _imu_log(instance: int, rows: _Rows, has_gyro: bool, tclr_rows: list, params: dict, path: Path) -> ImuLog:
    where = f"{path} IMU instance {instance}"
    table = rows.table()
    if has_gyro and not np.any(table[:, 5:8]):  # a board without that gyro logs GyrX..Z as 0: no gyro, not a
        has_gyro = False  # still one (its calibration would write zero INS_TCALn_GYR* over the vehicle's)
    time_s = table[:, 0] * table[:, 8]
    accel_g = table[:, 1:4] / STANDARD_GRAVITY
    # gyro rides along with the accelerometer columns so the rows dropped are the same
    values = np.column_stack([accel_g, table[:, 5:8]]) if has_gyro else accel_g
    t, temp, kept, notes = drop_unusable_rows(time_s, table[:, 4], values, where)
    records = _tclr_records(tclr_rows, path)
    notes += _tclr_note(records, where)
    device_id, id_notes = device_id_from_param(params, _id_param(DEVICE_ID_PARAMS, instance), where)
    gyro_id, gyro_id_notes = device_id_from_param(params, _id_param(GYRO_DEVICE_ID_PARAMS, instance), where)
    gyro = np.ascontiguousarray(kept[:, 3:6]) if has_gyro else None
    rotation = params.get("AHRS_ORIENTATION")
    rotation = int(rotation) if _is_number(rotation) and float(rotation).is_integer() else None
    return ImuLog(t, temp, np.ascontiguousarray(kept[:, :3]), instance, device_id, str(path),
                  notes + id_notes + gyro_id_notes, records, gyro, gyro_id, rotation)


def read_dataflash(path: str | Path) -> list[ImuLog]:
    """Every IMU instance of an ArduPilot DataFlash ``.bin`` log, in instance order.

    Parameters
    ----------
    path : str or Path
        The ``.bin`` log.

    Returns
    -------
    list of ImuLog
        One per IMU instance: time [s], temperature [°C], acceleration [g], gyro [rad/s].

    Raises
    ------
    MeasurementError
        Missing, empty, not a DataFlash log, without IMU messages, or IMU/TCLR fields that are
        missing or of a text type.
    """
    path = Path(path)
    require_signature(path, DATAFLASH_SIGNATURE, "DataFlash .bin log")
    imu, no_gyro, tclr, params = _messages(path)
    if not imu:
        raise MeasurementError(f"{path}: no IMU messages (accelerometer data) in this DataFlash log; "
                               f"expected IMU with I and {_expected_fields()} "
                               "(ArduPilot logs them when LOG_BITMASK includes IMU)")
    return [_imu_log(i, imu[i], i not in no_gyro, tclr.get(i, []), params, path) for i in sorted(imu)]


def sniff_dataflash(path: Path) -> bool:
    """Whether ``path`` starts with the DataFlash signature (its first two bytes).

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
        return f.read(2) == DATAFLASH_SIGNATURE


def _read(path: Path, options: ReadOptions) -> list[ImuLog]:
    return read_dataflash(path)


register_reader("dataflash", (".bin",), _read, sniff=sniff_dataflash,
                description="ArduPilot DataFlash binary log: IMU messages, every instance")
