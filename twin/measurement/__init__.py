"""Measurements: logs read into one type, :class:`Measurement`, whatever their format.

Each format is one module that registers its reader when imported here (see
:mod:`twin.measurement.registry`); a user's format is one file loaded by
:func:`load_reader_plugin`. Flight logs and 3-axis tables also read as :class:`ImuLog`, one per
IMU instance (:func:`read_imu_logs`); :func:`concatenate_imu_logs` joins runs of one IMU.
"""

import numpy as np

from twin.measurement.columns import ColumnMap
from twin.measurement.core import (
    STANDARD_GRAVITY,
    Measurement,
    MeasurementError,
    check,
    concatenate,
)
from twin.measurement.dataflash import read_dataflash  # noqa: E402  (registers "dataflash")
from twin.measurement.delimited import read_table, read_table_imu, write_canonical_csv  # noqa: E402

# Reader modules register themselves on import (the text reader sniffs last: it has priority -1).
from twin.measurement.hdf5 import from_dataset, read_dataset_blind  # noqa: E402  (registers "hdf5")
from twin.measurement.imu import ImuLog, usable_for_calibration
from twin.measurement.parquet import read_parquet  # noqa: E402  (registers "parquet")
from twin.measurement.log_quality import LogQuality, LogQualityError, QualitySettings
from twin.measurement.quality import assess_log, assess_measurement, cluster_directions, thermal_directions
from twin.measurement.quality_records import Stretch
from twin.measurement.registry import (
    Reader,
    ReadOptions,
    find_reader,
    load_measurements,
    load_reader_plugin,
    imu_logs_by_instance,
    read_imu_logs,
    readers,
    register_reader,
    unregister_reader,
)
from twin.measurement.ulog import read_ulog  # noqa: E402  (registers "ulog")


def _shared(values: list):
    """The one value every part has, else ``None``."""
    return values[0] if all(v == values[0] for v in values) else None


def concatenate_imu_logs(logs: list[ImuLog]) -> ImuLog:
    """Several logs of one IMU (several runs) as one :class:`ImuLog` on one continuing time base.

    Each part's time starts one sample step (its median) after the previous part ends, as
    :func:`concatenate` does for single-axis runs. The gyro is kept when every part has one (else
    dropped, with a note); device ids when every part agrees; records whose message every part has.

    Parameters
    ----------
    logs : list of ImuLog
        The parts, in time order.

    Returns
    -------
    ImuLog
        The joined log: time [s], temperature [°C], acceleration [g], gyro [rad/s].

    Raises
    ------
    MeasurementError
        No logs given.
    """
    if not logs:
        raise MeasurementError("no IMU logs to concatenate; expected one or more")
    if len(logs) == 1:
        return logs[0]
    times, offset_s = [], 0.0
    for log in logs:
        step_s = float(np.median(np.diff(log.time_s))) if len(log) > 1 else 1.0
        times.append(log.time_s - log.time_s[0] + offset_s)
        offset_s = times[-1][-1] + step_s
    notes = tuple(n for log in logs for n in log.notes)
    with_gyro = [log.gyro_rad_s is not None for log in logs]
    gyro = np.concatenate([log.gyro_rad_s for log in logs]) if all(with_gyro) else None
    if any(with_gyro) and not all(with_gyro):
        notes += (f"{sum(with_gyro)} of {len(logs)} runs have a gyro; the joined log has none",)
    shared = set.intersection(*(set(log.records) for log in logs))
    records = {name: {key: np.concatenate([log.records[name][key] for log in logs])
                      for key in logs[0].records[name] if all(key in log.records[name] for log in logs)}
               for name in shared}
    return ImuLog(np.concatenate(times), np.concatenate([log.temperature_c for log in logs]),
                  np.concatenate([log.accel_g for log in logs]), logs[0].instance,
                  _shared([log.device_id for log in logs]), "; ".join(log.source for log in logs), notes, records,
                  gyro, _shared([log.gyro_device_id for log in logs]))


__all__ = ["STANDARD_GRAVITY", "ColumnMap", "ImuLog", "Measurement", "MeasurementError", "ReadOptions", "Reader",
           "check", "concatenate", "concatenate_imu_logs", "find_reader", "from_dataset", "load_measurements", "load_reader_plugin",
           "read_dataflash", "read_dataset_blind", "imu_logs_by_instance", "read_imu_logs", "read_parquet", "read_table", "read_table_imu", "read_ulog",
           "readers", "register_reader", "unregister_reader", "usable_for_calibration", "write_canonical_csv"]
__all__ += ["LogQuality", "LogQualityError", "QualitySettings", "Stretch", "assess_log", "assess_measurement",
            "cluster_directions", "thermal_directions"]
