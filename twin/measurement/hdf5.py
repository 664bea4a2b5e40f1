"""Twin HDF5 datasets read blind: the logged columns only, never the truth or the effects."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from twin.measurement.core import Measurement, MeasurementError, check
from twin.measurement.imu import ImuLog
from twin.measurement.registry import ReadOptions, register_reader

HDF5_SIGNATURE = b"\x89HDF\r\n\x1a\n"
LOGGED = ["time_s", "temperature/thermometer_c", "output/output_g", "test/applied_g", "test/run_index",
          "test/power_on"]


def read_dataset_blind(path: str | Path) -> Measurement:
    """A ``twin run`` HDF5 file read as a measurement: the logged columns only, never the truth."""
    import h5py

    path = Path(path)
    try:
        with h5py.File(path, "r") as f:
            missing = [k for k in LOGGED if k not in f]
            if missing:
                raise MeasurementError(f"{path}: not a twin dataset (missing {', '.join(missing)})")
            arrays = {k: f[k][()] for k in LOGGED}
    except OSError as exc:
        raise MeasurementError(f"{path}: not a readable HDF5 file ({exc})") from None
    m = Measurement(arrays["time_s"].astype(float), arrays["temperature/thermometer_c"].astype(float),
                    arrays["output/output_g"].astype(float), arrays["test/applied_g"].astype(float),
                    arrays["test/run_index"].astype(np.int16), arrays["test/power_on"].astype(bool), True, [str(path)])
    check(m, str(path))
    return m


def from_dataset(ds) -> Measurement:
    """The logged columns of an in-memory simulated :class:`~twin.model.dataset.Dataset` (no truth)."""
    return Measurement(ds["time_s"].astype(float), ds["temperature/thermometer_c"].astype(float),
                       ds["output/output_g"].astype(float), ds["test/applied_g"].astype(float),
                       ds["test/run_index"].astype(np.int16), ds["test/power_on"].astype(bool), True, ["<dataset>"])


def sniff_hdf5(path: Path) -> bool:
    """The HDF5 signature at offset 0 (where ``twin run`` writes it; no user block)."""
    with path.open("rb") as f:
        return f.read(8) == HDF5_SIGNATURE


def read_three_axis_blind(path: Path) -> ImuLog:
    """A three-axis ``twin run`` file (``device.axes``) as an :class:`ImuLog`: logged columns only."""
    from twin.model.axes import imu_log_fields
    from twin.model.dataset import read_hdf5

    return ImuLog(**{**imu_log_fields(read_hdf5(path)), "source": str(path)})


def _is_three_axis(path: Path) -> bool:
    import h5py

    try:
        with h5py.File(path, "r") as f:
            return "output/accel_x_g" in f
    except OSError:
        return False


def _read(path: Path, options: ReadOptions) -> Measurement | ImuLog:
    # a twin dataset logs its own orientation and runs: no options apply
    return read_three_axis_blind(path) if _is_three_axis(path) else read_dataset_blind(path)


register_reader("hdf5", (".h5", ".hdf5"), _read, sniff=sniff_hdf5,
                description="twin HDF5 dataset, read blind (logged columns only)")
