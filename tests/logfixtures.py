"""Flight-log fixtures written from known arrays: PX4 ULog and ArduPilot DataFlash ``.bin``.

A simulated chamber run (:func:`chamber_run`): three accelerometer instances on a level board
(gravity −9.80665 m/s² on z, FRD), one on a heater (a higher, offset temperature), each axis with
a known cubic temperature offset; optionally each IMU's gyro too (a known linear bias). The
writers follow the formats' specifications:

* ULog: https://docs.px4.io/main/en/dev_log/ulog_file_format.html — header, flag bits, format
  (``F``), info (``I``), add-logged (``A``) and data (``D``) messages. pyulog (1.3) can write a
  ULog only by re-writing one it parsed (``ULog.write_ulog``); :func:`rewrite_with_pyulog` does
  that so the round trip covers pyulog's writer too.
* DataFlash: ArduPilot's AP_Logger format — each message ``0xA3 0x95 type payload``; ``FMT``
  (type 128, 89 bytes: Type B, Length B, Name char[4], Format char[16], Columns char[64]) defines
  every other type; format characters as in pymavlink's ``FORMAT_TO_STRUCT``.
"""

from __future__ import annotations

import struct
from dataclasses import dataclass
from pathlib import Path

import numpy as np

G_MS2 = 9.80665
T_REF_C = 25.0
# cubic offset per axis [m/s² per °C, per °C², per °C³], rows x, y, z: a few mg over ±40 °C
CUBIC_MS2 = np.array([[2.0e-3, 1.5e-5, -2.0e-7],
                      [-1.0e-3, -2.0e-5, 1.0e-7],
                      [3.0e-3, 1.0e-5, 3.0e-7]])
DEVICE_IDS = (2424842, 3670050, 2621474)
GYRO_DEVICE_IDS = (2424850, 3670058, 2621482)
HEATER_OFFSET_C = 15.0
# gyro bias per axis [rad/s] and its slope [rad/s per °C], rows x, y, z
GYRO_BIAS_RAD_S = np.array([[1.0e-3, 2.0e-5], [-2.0e-3, -1.0e-5], [5.0e-4, 3.0e-5]])


@dataclass(frozen=True)
class ImuTruth:
    """What a writer writes for one instance (the values the readers must give back)."""

    instance: int
    device_id: int
    time_us: np.ndarray  # uint64
    temperature_c: np.ndarray  # float32
    accel_ms2: np.ndarray  # float32, (n, 3), FRD
    gyro_rad_s: np.ndarray | None = None  # float32, (n, 3), on gyro_time_us (default: time_us)
    gyro_device_id: int | None = None
    gyro_time_us: np.ndarray | None = None  # uint64; ULog only (DataFlash logs gyro on the IMU rows)


def cubic_offset_ms2(temperature_c: np.ndarray) -> np.ndarray:
    """The known offset, shape (n, 3) [m/s²]."""
    dt = np.asarray(temperature_c, float)[:, None] - T_REF_C
    return CUBIC_MS2[:, 0] * dt + CUBIC_MS2[:, 1] * dt**2 + CUBIC_MS2[:, 2] * dt**3


def gyro_bias_rad_s(temperature_c: np.ndarray) -> np.ndarray:
    """The known gyro bias, shape (n, 3) [rad/s]."""
    dt = np.asarray(temperature_c, float)[:, None] - T_REF_C
    return GYRO_BIAS_RAD_S[:, 0] + GYRO_BIAS_RAD_S[:, 1] * dt


def chamber_run(n: int = 400, rate_hz: float = 1.0, seed: int = 0, heater: int = 0,
                gyro: bool = False) -> list[ImuTruth]:
    """Three instances through a −10 → 50 → −10 °C chamber triangle; instance ``heater`` runs hotter.

    ``gyro``: give each instance a gyro (:func:`gyro_bias_rad_s` plus noise) and a gyro device id;
    the accelerometer values do not change with it (the gyro noise has a generator of its own).
    """
    rng = np.random.default_rng(seed)
    gyro_rng = np.random.default_rng(seed + 1)
    phase = np.arange(n) / max(n - 1, 1)
    chamber_c = -10.0 + 60.0 * (1.0 - np.abs(2.0 * phase - 1.0))
    out = []
    for k, device_id in enumerate(DEVICE_IDS):
        time_us = (1_000_000 + np.arange(n) * int(1e6 / rate_hz) + 137 * k).astype(np.uint64)
        temp = chamber_c + (HEATER_OFFSET_C if k == heater else 0.4 * k)
        accel = cubic_offset_ms2(temp) + rng.normal(0.0, 2e-3, (n, 3))
        accel[:, 2] -= G_MS2
        rate = (gyro_bias_rad_s(temp) + gyro_rng.normal(0.0, 1e-4, (n, 3))).astype(np.float32) if gyro else None
        out.append(ImuTruth(k, device_id, time_us, temp.astype(np.float32), accel.astype(np.float32), rate,
                            GYRO_DEVICE_IDS[k] if gyro else None))
    return out


# ---- ULog -------------------------------------------------------------------------------------

ULOG_MAGIC = b"ULog\x01\x12\x35"
SENSOR_ACCEL_FORMAT = ("sensor_accel:uint64_t timestamp;uint64_t timestamp_sample;uint32_t device_id;"
                       "float x;float y;float z;float temperature;uint32_t error_count;uint8_t[3] clip_counter;"
                       "uint8_t samples;")
SENSOR_ACCEL_STRUCT = struct.Struct("<QQIffffI3BB")
SENSOR_GYRO_FORMAT = ("sensor_gyro:uint64_t timestamp;uint64_t timestamp_sample;uint32_t device_id;"
                      "float x;float y;float z;float temperature;uint32_t error_count;uint8_t[3] clip_counter;"
                      "uint8_t samples;")
SENSOR_GYRO_STRUCT = SENSOR_ACCEL_STRUCT  # PX4 sensor_gyro.msg has sensor_accel's layout
CPULOAD_FORMAT = "cpuload:uint64_t timestamp;float load;float ram_usage;"


def _ulog_msg(kind: str, payload: bytes) -> bytes:
    return struct.pack("<HB", len(payload), ord(kind)) + payload


def write_ulog(path: Path, imus: list[ImuTruth], *, with_accel: bool = True, with_cpuload: bool = True,
               with_gyro: bool = True) -> Path:
    """A ULog with ``sensor_accel`` (one multi_id per instance), optionally a ``cpuload`` topic, and
    ``sensor_gyro`` for the instances with a gyro (``with_gyro``; on ``gyro_time_us`` when given)."""
    gyros = [imu for imu in imus if imu.gyro_rad_s is not None] if with_gyro else []
    head = ULOG_MAGIC + bytes([1]) + struct.pack("<Q", 0)
    head += _ulog_msg("B", bytes(16) + struct.pack("<3Q", 0, 0, 0))
    head += _ulog_msg("F", SENSOR_ACCEL_FORMAT.encode()) + _ulog_msg("F", CPULOAD_FORMAT.encode())
    head += _ulog_msg("F", SENSOR_GYRO_FORMAT.encode()) if gyros else b""
    key = b"char[3] sys_name"
    head += _ulog_msg("I", bytes([len(key)]) + key + b"PX4")
    subs, rows = b"", []
    if with_accel:
        for msg_id, imu in enumerate(imus):
            subs += _ulog_msg("A", struct.pack("<BH", imu.instance, msg_id) + b"sensor_accel")
            for t, temp, (x, y, z) in zip(imu.time_us, imu.temperature_c, imu.accel_ms2):
                body = SENSOR_ACCEL_STRUCT.pack(int(t), int(t), imu.device_id, x, y, z, temp, 0, 0, 0, 0, 1)
                rows.append((int(t), _ulog_msg("D", struct.pack("<H", msg_id) + body)))
    if with_cpuload:
        cpu_id = len(imus)
        subs += _ulog_msg("A", struct.pack("<BH", 0, cpu_id) + b"cpuload")
        for t in imus[0].time_us[::10]:
            rows.append((int(t), _ulog_msg("D", struct.pack("<HQff", cpu_id, int(t), 0.3, 0.5))))
    for msg_id, imu in enumerate(gyros, start=len(imus) + 1):
        subs += _ulog_msg("A", struct.pack("<BH", imu.instance, msg_id) + b"sensor_gyro")
        rows += _gyro_rows(imu, msg_id)
    rows.sort(key=lambda r: r[0])
    path.write_bytes(head + subs + b"".join(r[1] for r in rows))
    return path


def _gyro_rows(imu: ImuTruth, msg_id: int) -> list[tuple[int, bytes]]:
    """``sensor_gyro`` data messages of one instance, keyed by time."""
    times = imu.gyro_time_us if imu.gyro_time_us is not None else imu.time_us
    device_id = imu.gyro_device_id if imu.gyro_device_id is not None else imu.device_id
    temps = np.interp(times.astype(float), imu.time_us.astype(float), imu.temperature_c)
    rows = []
    for t, temp, (x, y, z) in zip(times, temps, imu.gyro_rad_s):
        body = SENSOR_GYRO_STRUCT.pack(int(t), int(t), device_id, x, y, z, temp, 0, 0, 0, 0, 1)
        rows.append((int(t), _ulog_msg("D", struct.pack("<H", msg_id) + body)))
    return rows


def rewrite_with_pyulog(src: Path, dst: Path) -> Path:
    """``src`` parsed by pyulog and written back with pyulog's own writer."""
    from pyulog import ULog

    ULog(str(src)).write_ulog(str(dst))
    return dst


# ---- DataFlash --------------------------------------------------------------------------------

DF_HEAD = b"\xa3\x95"
FMT_TYPE = 128
FMT_STRUCT = struct.Struct("<BB4s16s64s")
DF_CHARS = {"b": "b", "B": "B", "h": "h", "H": "H", "i": "i", "I": "I", "f": "f", "d": "d", "q": "q", "Q": "Q",
            "n": "4s", "N": "16s", "Z": "64s"}
# IMU layouts by instance field: "I" is ArduPilot's since 4.1; None is the pre-4.1 layout (one
# message name per instance); "Instance" is a spelling the reader also accepts (a compact layout:
# IMU's 15 column names with "Instance" exceed the 64-character Columns field; it has no gyro).
IMU_LAYOUTS = {
    "I": ("QBffffffIIfBBHH", "TimeUS,I,GyrX,GyrY,GyrZ,AccX,AccY,AccZ,EG,EA,T,GH,AH,GHz,AHz"),
    None: ("QffffffIIfBBHH", "TimeUS,GyrX,GyrY,GyrZ,AccX,AccY,AccZ,EG,EA,T,GH,AH,GHz,AHz"),
    "Instance": ("QBffff", "TimeUS,Instance,AccX,AccY,AccZ,T"),
}
# older ArduPilot IMU layouts (one message name per instance, time in ms), by whether they log a
# temperature: Temp as in Solo 1.2 / Copter 3.2.x, none at all as in Copter 3.2
OLD_IMU_LAYOUTS = {
    True: ("IffffffIIf", "TimeMS,GyrX,GyrY,GyrZ,AccX,AccY,AccZ,ErrG,ErrA,Temp"),
    False: ("Iffffff", "TimeMS,GyrX,GyrY,GyrZ,AccX,AccY,AccZ"),
}
# IMU fields the fixtures do not model: error counts 0, healthy, 1 kHz
IMU_FILLERS = {"EG": 0, "EA": 0, "ErrG": 0, "ErrA": 0, "GH": 1, "AH": 1, "GHz": 1000, "AHz": 1000}
TCLR_FORMAT, TCLR_COLUMNS = "QBBffffI", "TimeUS,I,SType,Temp,X,Y,Z,NSamp"
PARM_FORMAT, PARM_COLUMNS = "QNf", "TimeUS,Name,Value"
LEGACY_NAMES = ("IMU", "IMU2", "IMU3")
ACC_ID_PARAMS = ("INS_ACC_ID", "INS_ACC2_ID", "INS_ACC3_ID")
GYR_ID_PARAMS = ("INS_GYR_ID", "INS_GYR2_ID", "INS_GYR3_ID")
TEXT_CHARS = "nNZ"
IMU_TYPE, PARM_TYPE, TCLR_TYPE = 70, 64, 90


def _df_struct(fmt: str) -> struct.Struct:
    return struct.Struct("<" + "".join(DF_CHARS[c] for c in fmt))


def _df_fmt(msg_type: int, name: str, fmt: str, columns: str) -> bytes:
    assert len(columns) <= 64, columns  # the Columns field is char[64]
    length = 3 + FMT_STRUCT.size if msg_type == FMT_TYPE else 3 + _df_struct(fmt).size
    return DF_HEAD + bytes([FMT_TYPE]) + FMT_STRUCT.pack(msg_type, length, name.encode(), fmt.encode(),
                                                         columns.encode())


def _df_msg(msg_type: int, fmt: str, *values) -> bytes:
    return DF_HEAD + bytes([msg_type]) + _df_struct(fmt).pack(*values)


def _per_instance_names(columns: str) -> bool:
    """Whether a layout names its instances by message (IMU, IMU2, IMU3): no instance column."""
    return not {"I", "Instance"} & set(columns.split(","))


def _imu_formats(fmt: str, columns: str) -> list[bytes]:
    if _per_instance_names(columns):
        return [_df_fmt(IMU_TYPE + k, name, fmt, columns) for k, name in enumerate(LEGACY_NAMES)]
    return [_df_fmt(IMU_TYPE, "IMU", fmt, columns)]


def _imu_msg(fmt: str, columns: str, instance: int, t_us: int, temp, accel, gyro) -> bytes:
    """One IMU message of any layout: each column's value by its name (a text-typed column gets the
    number as text, as a corrupt or foreign FMT would make pymavlink return it)."""
    known = {"TimeUS": t_us, "TimeMS": t_us // 1000, "I": instance, "Instance": instance, "T": temp, "Temp": temp,
             **dict(zip(("AccX", "AccY", "AccZ"), accel)), **dict(zip(("GyrX", "GyrY", "GyrZ"), gyro))}
    values = [known.get(c, IMU_FILLERS.get(c, 0)) for c in columns.split(",")]
    values = [f"{v:g}".encode() if c in TEXT_CHARS else v for c, v in zip(fmt, values)]
    return _df_msg(IMU_TYPE + (instance if _per_instance_names(columns) else 0), fmt, *values)


def _imu_layout(instance_field: str | None, old_names: bool, with_temperature: bool,
                imu_layout: tuple[str, str] | None) -> tuple[str, str]:
    if imu_layout is not None:
        return imu_layout
    if old_names:
        return OLD_IMU_LAYOUTS[with_temperature]
    return IMU_LAYOUTS[instance_field]


def _id_params(imus: list[ImuTruth], params: dict | None) -> dict[str, float]:
    """INS_ACCn_ID (and INS_GYRn_ID for a gyro with an id) per instance, then ``params`` over them."""
    values = {name: float(imu.device_id) for imu, name in zip(imus, ACC_ID_PARAMS)}
    values.update({name: float(imu.gyro_device_id) for imu, name in zip(imus, GYR_ID_PARAMS)
                   if imu.gyro_device_id is not None})
    return {**values, **(params or {})}


def write_dataflash(path: Path, imus: list[ImuTruth], *, instance_field: str | None = "I", with_imu: bool = True,
                    tclr_every: int = 50, old_names: bool = False, with_temperature: bool = True,
                    params: dict[str, float] | None = None, imu_layout: tuple[str, str] | None = None) -> Path:
    """A ``.bin`` with FMT, PARM (INS_ACCn_ID, INS_GYRn_ID), IMU and, every ``tclr_every`` samples,
    TCLR records (SType 0; SType 1 too for an instance with a gyro).

    ``instance_field``: a key of :data:`IMU_LAYOUTS`. ``old_names``: the older layout of
    :data:`OLD_IMU_LAYOUTS` instead (TimeMS [ms], Temp; no temperature at all without
    ``with_temperature``). ``params``: parameter values written instead of (or besides) the ids.
    ``imu_layout``: any ``(format, columns)`` for IMU. The gyro fields hold ``gyro_rad_s`` (on the
    accelerometer rows) or 0 where an instance has none.
    """
    fmt, columns = _imu_layout(instance_field, old_names, with_temperature, imu_layout)
    out = [_df_fmt(FMT_TYPE, "FMT", "BBnNZ", "Type,Length,Name,Format,Columns"),
           _df_fmt(PARM_TYPE, "PARM", PARM_FORMAT, PARM_COLUMNS), _df_fmt(TCLR_TYPE, "TCLR", TCLR_FORMAT, TCLR_COLUMNS)]
    out += _imu_formats(fmt, columns) if with_imu else []
    for name, value in _id_params(imus, params).items():
        out.append(_df_msg(PARM_TYPE, PARM_FORMAT, 0, name.encode(), value))
    rows = []
    for imu in imus:
        gyro = imu.gyro_rad_s if imu.gyro_rad_s is not None else np.zeros((imu.time_us.size, 3), np.float32)
        for j, (t, temp, acc, rate) in enumerate(zip(imu.time_us, imu.temperature_c, imu.accel_ms2, gyro)):
            if with_imu:
                rows.append((int(t), _imu_msg(fmt, columns, imu.instance, int(t), temp, acc, rate)))
            if tclr_every and j % tclr_every == tclr_every - 1:
                x, y, z = acc
                rows.append((int(t), _df_msg(TCLR_TYPE, TCLR_FORMAT, int(t), imu.instance, 0, temp, x, y, z + G_MS2,
                                             100)))
                if imu.gyro_rad_s is not None:
                    rows.append((int(t), _df_msg(TCLR_TYPE, TCLR_FORMAT, int(t), imu.instance, 1, temp, *rate, 100)))
    rows.sort(key=lambda r: r[0])
    path.write_bytes(b"".join(out) + b"".join(r[1] for r in rows))
    return path


# ---- one fixture per registered reader (the conformance test reads each) ----------------------

def write_canonical(path: Path) -> Path:
    """Instance 1's z axis of the chamber run as the canonical CSV."""
    from twin.measurement import write_canonical_csv

    imu = chamber_run()[1]
    n = imu.time_us.size
    write_canonical_csv(path, (imu.time_us - imu.time_us[0]) * 1e-6, imu.temperature_c, imu.accel_ms2[:, 2] / G_MS2,
                        np.full(n, -1.0), np.zeros(n, int), np.zeros(n, bool))
    return path


def write_twin_hdf5(path: Path) -> Path:
    """The logged columns a ``twin run`` HDF5 holds (what the blind reader reads)."""
    import h5py

    imu = chamber_run()[1]
    n = imu.time_us.size
    with h5py.File(path, "w") as f:
        f["time_s"] = (imu.time_us - imu.time_us[0]) * 1e-6
        f["temperature/thermometer_c"] = imu.temperature_c.astype(float)
        f["output/output_g"] = imu.accel_ms2[:, 2] / G_MS2
        f["test/applied_g"] = np.full(n, -1.0)
        f["test/run_index"] = np.zeros(n, np.int16)
        f["test/power_on"] = np.zeros(n, bool)
    return path


FIXTURES = {
    "delimited": ("chamber.csv", write_canonical),
    "hdf5": ("chamber.h5", write_twin_hdf5),
    "ulog": ("chamber.ulg", lambda p: write_ulog(p, chamber_run())),
    "dataflash": ("chamber.bin", lambda p: write_dataflash(p, chamber_run())),
}
