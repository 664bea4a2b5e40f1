"""Measurements: logs read into one type, :class:`Measurement`, whatever their format.

Each format is one module that registers its reader when imported here (see
:mod:`twin.measurement.registry`); a user's format is one file loaded by
:func:`load_reader_plugin`. Flight logs and 3-axis tables also read as :class:`ImuLog`, one per
IMU instance (:func:`read_imu_logs`).
"""

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

__all__ = ["STANDARD_GRAVITY", "ColumnMap", "ImuLog", "Measurement", "MeasurementError", "ReadOptions", "Reader",
           "check", "concatenate", "find_reader", "from_dataset", "load_measurements", "load_reader_plugin",
           "read_dataflash", "read_dataset_blind", "imu_logs_by_instance", "read_imu_logs", "read_parquet", "read_table", "read_table_imu", "read_ulog",
           "readers", "register_reader", "unregister_reader", "usable_for_calibration", "write_canonical_csv"]
