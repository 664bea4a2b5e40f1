"""Twin HDF5 datasets read blind: the logged columns only, never the truth or the effects."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from twin.measurement.columns import RUN_MAX
from twin.measurement.core import Measurement, MeasurementError, check, check_arrays
from twin.measurement.imu import ImuLog
from twin.measurement.registry import ReadOptions, register_reader

HDF5_SIGNATURE = b"\x89HDF\r\n\x1a\n"
LOGGED = ["time_s", "temperature/thermometer_c", "output/output_g", "test/applied_g", "test/run_index",
          "test/power_on"]


def logged_arrays(path: Path, names: list[str]) -> dict[str, np.ndarray]:
    """The datasets ``names`` of an HDF5 file, each checked before it is read: present, a 1-D
    numeric dataset, all of one non-zero length (a 2-D, text, empty or ragged file is one line).

    Parameters
    ----------
    path : Path
        The HDF5 file.
    names : list of str
        Dataset paths, the first one's length the reference.

    Returns
    -------
    dict of str to ndarray
        The arrays by path, in their stored units.
    """
    import h5py

    try:
        with h5py.File(path, "r") as f:
            missing = [k for k in names if k not in f]
            if missing:
                raise MeasurementError(f"{path}: not a twin dataset (missing {', '.join(missing)})")
            lengths = {}
            for k in names:
                d = f[k]
                if not isinstance(d, h5py.Dataset):
                    raise MeasurementError(f"{path}: {k} is a group; expected a 1-D numeric dataset")
                if d.ndim != 1 or d.dtype.kind not in ("fiu" if k == "time_s" else "fiub"):
                    raise MeasurementError(f"{path}: {k} has shape {d.shape} and type {d.dtype}; "
                                           "expected a 1-D numeric dataset")
                lengths[k] = d.shape[0]
            if len(set(lengths.values())) != 1:
                raise MeasurementError(f"{path}: columns of different lengths "
                                       f"({', '.join(f'{k} {n}' for k, n in lengths.items())}); expected one length")
            if not lengths[names[0]]:
                raise MeasurementError(f"{path}: the dataset holds no samples; expected a simulated run")
            return {k: f[k][()] for k in names}
    except (OSError, KeyError, TypeError, ValueError, RuntimeError, RecursionError) as exc:  # RuntimeError: a link loop
        raise MeasurementError(f"{path}: not a readable HDF5 file ({' '.join(str(exc).split())[:160]})") from None


def read_dataset_blind(path: str | Path) -> Measurement:
    """A ``twin run`` HDF5 file read as a measurement: the logged columns only, never the truth.

    Parameters
    ----------
    path : str or Path
        The dataset file.

    Returns
    -------
    Measurement
        Time [s], thermometer [°C], output and applied acceleration [g], runs, power-on flags.
    """
    path = Path(path)
    arrays = logged_arrays(path, LOGGED)
    run = arrays["test/run_index"]
    if not (np.isfinite(run).all() and run.min() >= 0 and run.max() <= RUN_MAX and np.all(run == np.round(run))):
        raise MeasurementError(f"{path}: test/run_index outside 0..{RUN_MAX} or not whole; expected run numbers")
    m = Measurement(arrays["time_s"].astype(float), arrays["temperature/thermometer_c"].astype(float),
                    arrays["output/output_g"].astype(float), arrays["test/applied_g"].astype(float),
                    arrays["test/run_index"].astype(np.int16), arrays["test/power_on"].astype(bool), True, [str(path)])
    check(m, str(path))
    return m


def from_dataset(ds) -> Measurement:
    """The logged columns of an in-memory simulated :class:`~twin.model.dataset.Dataset` (no truth).

    Parameters
    ----------
    ds : Dataset
        A one-axis simulated dataset.

    Returns
    -------
    Measurement
        Time [s], thermometer [°C], output and applied acceleration [g], runs, power-on flags.
    """
    return Measurement(ds["time_s"].astype(float), ds["temperature/thermometer_c"].astype(float),
                       ds["output/output_g"].astype(float), ds["test/applied_g"].astype(float),
                       ds["test/run_index"].astype(np.int16), ds["test/power_on"].astype(bool), True, ["<dataset>"])


def sniff_hdf5(path: Path) -> bool:
    """The HDF5 signature at offset 0 (where ``twin run`` writes it; no user block).

    Parameters
    ----------
    path : Path
        The file.

    Returns
    -------
    bool
        True for an HDF5 file.
    """
    with path.open("rb") as f:
        return f.read(8) == HDF5_SIGNATURE


def read_three_axis_blind(path: Path) -> ImuLog:
    """A three-axis ``twin run`` file (``device.axes``) as an :class:`ImuLog`: logged columns only.

    Parameters
    ----------
    path : Path
        The dataset file.

    Returns
    -------
    ImuLog
        Time [s], thermometer [°C], acceleration (n, 3) [g].
    """
    from twin.model.axes import imu_log_fields
    from twin.model.dataset import read_hdf5

    names = ["time_s", "temperature/thermometer_c"] + [f"output/accel_{a}_g" for a in "xyz"]
    arrays = logged_arrays(path, names)  # checked first: the model's reader trusts its own files
    m = Measurement(arrays["time_s"].astype(float), arrays["temperature/thermometer_c"].astype(float),
                    np.zeros(arrays["time_s"].size), np.full(arrays["time_s"].size, np.nan),
                    np.zeros(arrays["time_s"].size, np.int16), np.zeros(arrays["time_s"].size, bool), False)
    check_arrays(m, str(path))
    for a in "xyz":
        if not np.isfinite(arrays[f"output/accel_{a}_g"]).all():
            raise MeasurementError(f"{path}: output/accel_{a}_g holds non-finite values; expected finite g")
    try:
        return ImuLog(**{**imu_log_fields(read_hdf5(path)), "source": str(path)})
    except (KeyError, ValueError) as exc:
        raise MeasurementError(f"{path}: not a readable three-axis twin dataset ({exc})") from None


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
