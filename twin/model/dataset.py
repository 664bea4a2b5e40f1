"""Dataset: arrays on one time base with units, written to self-describing HDF5.

A simulation and a measurement are the same type, so one compare and one plot serve both
(architecture principle 9). The layout is documented in ``docs/dataset.md`` and listed in
:data:`LAYOUT`; every dataset carries a ``units`` and a ``description`` attribute.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import h5py
import numpy as np

from twin.errors import DatasetError
from twin.io import atomic_hdf5

LAYOUT_VERSION = "1"

#: path → (units, description). ``truth/effects/<name>_g`` is added per effect.
LAYOUT: dict[str, tuple[str, str]] = {
    "time_s": ("s", "sample time from the start of the first run"),
    "program/setpoint_c": ("degC", "chamber set-point"),
    "program/segment": ("1", "set-point direction: 0 dwell, +1 heating, -1 cooling"),
    "temperature/air_c": ("degC", "chamber air (well-mixed node)"),
    "temperature/board_c": ("degC", "board / fixture node"),
    "temperature/die_c": ("degC", "die (sensing element) temperature - truth, not observable"),
    "temperature/thermometer_true_c": ("degC", "temperature of the thermometer element (before its noise)"),
    "temperature/thermometer_c": ("degC", "reference thermometer reading as logged"),
    "test/applied_g": ("g", "acceleration applied along the sensing axis (orientation)"),
    "test/run_index": ("1", "run number, 0-based"),
    "test/power_on": ("1", "true on the first sample after each power-on"),
    "test/time_since_power_on_s": ("s", "time since the latest power-on"),
    "output/output_g": ("g", "sensor output as logged (quantised)"),
    "output/output_digits": ("digit", "12-bit output in digits (raw register >> 4)"),
    "truth/drift_g": ("g", "total drift: zero-g offset plus the sum of truth/effects"),
    "truth/turn_on_bias_g": ("g", "bias drawn afresh at each run's start"),
    "truth/bias_g": ("g", "total bias (zero-g offset and turn-on bias included)"),
    "truth/scale_factor_error": ("1", "relative scale-factor change"),
    "truth/noise_white_g": ("g", "white noise"),
    "truth/noise_bias_instability_g": ("g", "Gauss-Markov bias instability"),
    "truth/quantisation_g": ("g", "quantisation error: output minus the output before quantisation"),
    "truth/saturated": ("1", "true where the output hit the 12-bit limits"),
}


@dataclass
class Dataset:
    """Named arrays (``group/name`` paths), their units, and file attributes.

    Attributes
    ----------
    arrays : dict of str to ndarray
        Arrays on one time base, by path [units in ``units``].
    units : dict of str to str
        Unit of each array (e.g. ``"degC"``, ``"g"``).
    attrs : dict
        File attributes (scenario, seed, runs …).
    descriptions : dict of str to str
        Description of each array.
    """

    arrays: dict[str, np.ndarray]
    units: dict[str, str]
    attrs: dict[str, object] = field(default_factory=dict)
    descriptions: dict[str, str] = field(default_factory=dict)

    def __getitem__(self, path: str) -> np.ndarray:
        return self.arrays[path]

    def __len__(self) -> int:
        return int(self.arrays["time_s"].size)

    def add(self, path: str, values: np.ndarray, units: str | None = None, description: str | None = None) -> None:
        """Add an array; units and description default to :data:`LAYOUT`.

        Parameters
        ----------
        path : str
            ``group/name`` path.
        values : ndarray
            The array [``units``].
        units : str, optional
            Its unit; required for a path not in :data:`LAYOUT`.
        description : str, optional
            Its description.
        """
        lay_units, lay_desc = LAYOUT.get(path, (None, ""))
        units = units if units is not None else lay_units
        if units is None:
            raise DatasetError(f"array {path!r} needs units")
        self.arrays[path] = np.asarray(values)
        self.units[path] = units
        self.descriptions[path] = description if description is not None else lay_desc

    @property
    def effect_names(self) -> list[str]:
        """Names of the effects with a ``truth/effects/<name>_g`` array."""
        prefix = "truth/effects/"
        return [p[len(prefix):-2] for p in self.arrays if p.startswith(prefix)]


def write_hdf5(ds: Dataset, path: str | Path, compression: str = "lzf") -> Path:
    """Write atomically: the file is built in memory, written to a temporary file beside ``path``,
    then renamed. An interrupted or failed write (full disk, file-size limit) never leaves a
    truncated file under the final name, nor a temporary one.

    Parameters
    ----------
    ds : Dataset
        The dataset.
    path : str or Path
        Output HDF5 file.
    compression : str
        h5py compression filter, or ``"none"``.

    Returns
    -------
    Path
        The file written.
    """
    comp = None if compression == "none" else compression
    with atomic_hdf5(Path(path)) as f:  # built in memory: the disk is written by Python, errors are OSError
        for key, value in ds.attrs.items():
            f.attrs[key] = value
        for name, values in ds.arrays.items():
            values = np.asarray(values)
            chunks = (min(values.size, 1 << 16),) if values.size else None
            d = f.create_dataset(name, data=values, chunks=chunks, compression=comp,
                                 shuffle=comp is not None and values.size > 0)
            d.attrs["units"] = ds.units[name]
            d.attrs["description"] = ds.descriptions.get(name, "")
    return Path(path)


def read_hdf5(path: str | Path) -> Dataset:
    """Read a dataset written by :func:`write_hdf5`.

    Parameters
    ----------
    path : str or Path
        HDF5 file.

    Returns
    -------
    Dataset
        Arrays, units, attributes and descriptions.
    """
    path = Path(path)
    if not path.is_file():
        raise DatasetError(f"{path}: dataset file not found")
    arrays: dict[str, np.ndarray] = {}
    units: dict[str, str] = {}
    desc: dict[str, str] = {}
    try:
        with h5py.File(path, "r") as f:
            attrs = {k: (v.decode() if isinstance(v, bytes) else v) for k, v in f.attrs.items()}

            def visit(name: str, obj: object) -> None:
                if isinstance(obj, h5py.Dataset):
                    arrays[name] = obj[()]
                    units[name] = str(obj.attrs.get("units", ""))
                    desc[name] = str(obj.attrs.get("description", ""))

            f.visititems(visit)
    except OSError as exc:
        raise DatasetError(f"{path}: not a readable HDF5 dataset ({exc})") from None
    if "time_s" not in arrays:
        raise DatasetError(f"{path}: no 'time_s' dataset; not a twin dataset")
    return Dataset(arrays, units, attrs, desc)
