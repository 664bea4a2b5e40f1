"""Measurements: logs read into one type, :class:`Measurement`, whatever their format."""

from twin.measurement.core import (
    STANDARD_GRAVITY,
    ColumnMap,
    Measurement,
    MeasurementError,
    check,
    concatenate,
    from_dataset,
    load_measurements,
    read_dataset_blind,
    read_table,
    write_canonical_csv,
)

__all__ = ["STANDARD_GRAVITY", "ColumnMap", "Measurement", "MeasurementError", "check", "concatenate",
           "from_dataset", "load_measurements", "read_dataset_blind", "read_table", "write_canonical_csv"]
