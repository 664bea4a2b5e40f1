"""Measurements in: canonical CSV, twin HDF5 datasets (read blind), and real logs via a column map.

Canonical CSV: ``time_s,temperature_c,output_g[,applied_g][,run][,power_on]`` with a header line.
Several files are several runs of one device. A column map (YAML or CLI options) reads any
delimited log: which columns hold time, temperature and output, unit conversions, banner lines to
skip, the delimiter. Bad input raises :class:`MeasurementError` naming the file, line and column.

pandas parses the text (≈10× faster than numpy.loadtxt on 500k rows, and it reports bad rows).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from twin.errors import TwinError

STANDARD_GRAVITY = 9.80665


class MeasurementError(TwinError):
    """A measurement that cannot be read or makes no physical sense."""


@dataclass
class ColumnMap:
    """How to read a delimited log.

    ``time``, ``temperature``, ``output``, ``applied``, ``run``, ``power_on``: column names, or
    0-based indices when the file has no header. Units: ``time_unit`` in s/ms/us; ``output_unit``
    in g/mg/m/s^2/digits (with ``digit_mg``); ``output_scale`` multiplies after conversion (e.g. 4
    for a ±4 g part logged in units of full scale/4); ``temperature_unit`` C or K.
    """

    time: str | int | None = "time_s"
    temperature: str | int = "temperature_c"
    output: str | int = "output_g"
    applied: str | int | None = "applied_g"
    run: str | int | None = "run"
    power_on: str | int | None = "power_on"
    time_unit: str = "s"
    temperature_unit: str = "C"
    output_unit: str = "g"
    output_scale: float = 1.0
    digit_mg: float = 0.98
    skip_lines: int = 0
    delimiter: str | None = None  # None: sniff ',', tab, ';', whitespace
    header: bool = True
    sample_rate_hz: float | None = None  # for logs without a time column
    invert_output: bool = False

    @classmethod
    def from_yaml(cls, path: str | Path) -> ColumnMap:
        import yaml

        p = Path(path)
        if not p.is_file():
            raise MeasurementError(f"{p}: column map not found")
        try:
            data = yaml.safe_load(p.read_text()) or {}
        except yaml.YAMLError as exc:
            raise MeasurementError(f"{p}: malformed YAML: {exc}") from None
        if not isinstance(data, dict):
            raise MeasurementError(f"{p}: a column map is a YAML mapping")
        known = set(cls.__dataclass_fields__)
        for key in data:
            if key not in known:
                import difflib

                close = difflib.get_close_matches(str(key), known, n=1)
                hint = f"; did you mean {close[0]!r}?" if close else f"; valid keys: {', '.join(sorted(known))}"
                raise MeasurementError(f"{p}: unknown column-map key {key!r}{hint}")
        return cls(**data)


@dataclass
class Measurement:
    """A measured (or exported) log on one time base, runs concatenated."""

    time_s: np.ndarray
    temperature_c: np.ndarray
    output_g: np.ndarray
    applied_g: np.ndarray
    run_index: np.ndarray
    power_on: np.ndarray
    applied_known: bool = True
    sources: list[str] = field(default_factory=list)
    bad_rows_skipped: int = 0
    notes: list[str] = field(default_factory=list)

    def __len__(self) -> int:
        return int(self.time_s.size)

    @property
    def sample_rate_hz(self) -> float:
        d = np.diff(self.time_s)
        d = d[d > 0]
        return float(1.0 / np.median(d)) if d.size else 1.0

    @property
    def runs(self) -> int:
        return int(self.run_index.max()) + 1 if self.run_index.size else 0

    def time_since_power_on_s(self) -> np.ndarray:
        """Time since the latest power-on flag (each run starts powered on)."""
        out = np.empty(self.time_s.size)
        for r in range(self.runs):
            idx = np.flatnonzero(self.run_index == r)
            if idx.size == 0:
                continue
            t = self.time_s[idx]
            flags = self.power_on[idx].astype(bool).copy()
            flags[0] = True
            starts = t[flags]
            out[idx] = t - starts[np.searchsorted(starts, t, side="right") - 1]
        return out


_TIME_FACTORS = {"s": 1.0, "ms": 1e-3, "us": 1e-6, "µs": 1e-6, "ns": 1e-9, "min": 60.0, "h": 3600.0}
_OUTPUT_UNITS = ("g", "mg", "m/s^2", "m/s2", "digits")


def _convert_output(values: np.ndarray, cmap: ColumnMap) -> np.ndarray:
    unit = cmap.output_unit
    if unit == "g":
        out = values
    elif unit == "mg":
        out = values * 1e-3
    elif unit in ("m/s^2", "m/s2"):
        out = values / STANDARD_GRAVITY
    elif unit == "digits":
        out = values * cmap.digit_mg * 1e-3
    else:
        raise MeasurementError(f"output_unit must be one of {', '.join(_OUTPUT_UNITS)}, got {unit!r}")
    out = out * cmap.output_scale
    return -out if cmap.invert_output else out


def _read_table(path: Path, cmap: ColumnMap, skip_bad_rows: bool):
    import pandas as pd

    if not path.is_file():
        raise MeasurementError(f"{path}: measurement file not found")
    with path.open("r", errors="replace") as f:
        lines = [f.readline() for _ in range(cmap.skip_lines + 50)][cmap.skip_lines:]
    sep = cmap.delimiter
    if sep is None:
        sample = "".join(lines[:3])
        sep = "\t" if "\t" in sample else ";" if sample.count(";") > sample.count(",") else "," if "," in sample else r"\s+"
    names = None
    if not cmap.header:
        # the most common field count, so one truncated first row does not set the width
        import re

        counts = [len(re.split(sep, ln.strip())) if sep == r"\s+" else ln.count(sep) + 1 for ln in lines if ln.strip()]
        names = list(range(max(set(counts), key=counts.count))) if counts else None
    try:
        df = pd.read_csv(path, sep=sep, skiprows=cmap.skip_lines, header=0 if cmap.header else None, names=names,
                         engine="c" if sep != r"\s+" else "python",
                         on_bad_lines="skip" if skip_bad_rows else "error", skipinitialspace=True)
    except pd.errors.ParserError as exc:
        raise MeasurementError(f"{path}: {exc} (use --skip-bad-rows to skip such lines)") from None
    except (UnicodeDecodeError, OSError) as exc:
        raise MeasurementError(f"{path}: cannot read: {exc}") from None
    if df.empty:
        raise MeasurementError(f"{path}: no data rows")
    df.columns = [str(c).strip() for c in df.columns]
    first_data_line = cmap.skip_lines + (2 if cmap.header else 1)
    return df, first_data_line


def _column(df, key, path: Path, role: str, required: bool):
    if key is None:
        return None
    if isinstance(key, int) or (isinstance(key, str) and key.isdigit() and key not in df.columns):
        idx = int(key)
        if idx >= df.shape[1]:
            raise MeasurementError(f"{path}: {role} column index {idx} out of range (the file has {df.shape[1]} columns)")
        return df.iloc[:, idx]
    if key in df.columns:
        return df[key]
    if required:
        import difflib

        close = difflib.get_close_matches(str(key), list(df.columns), n=1)
        hint = f"; did you mean {close[0]!r}?" if close else f"; columns are: {', '.join(df.columns)}"
        raise MeasurementError(f"{path}: no {role} column {key!r}{hint}")
    return None


def _numeric(series) -> tuple[np.ndarray, np.ndarray]:
    """Values as floats and a mask of the rows that are not finite numbers."""
    import pandas as pd

    if series.dtype.kind in "fiub":  # parsed as numbers by the C parser: nothing to coerce
        values = series.to_numpy(float)
    else:
        values = pd.to_numeric(series.astype(str).str.strip(), errors="coerce").to_numpy(float)
    return values, ~np.isfinite(values)


def read_table(path: str | Path, cmap: ColumnMap | None = None, *, run: int = 0, skip_bad_rows: bool = False,
               applied_g: float | None = None) -> Measurement:
    """Read one delimited file as one run.

    ``applied_g``: the acceleration along the axis when the file has no such column (``None``
    with no column means unknown).
    """
    cmap = cmap or ColumnMap()
    path = Path(path)
    df, first_line = _read_table(path, cmap, skip_bad_rows)
    cols = {}
    for role, key, required in (("temperature", cmap.temperature, True), ("output", cmap.output, True),
                                ("time", cmap.time, cmap.sample_rate_hz is None), ("applied", cmap.applied, False),
                                ("run", cmap.run, False), ("power_on", cmap.power_on, False)):
        cols[role] = _column(df, key, path, role, required)
    bad = np.zeros(len(df), bool)
    values = {}
    for role, series in cols.items():
        if series is None:
            continue
        v, b = _numeric(series)
        values[role] = v
        bad |= b
    if bad.any():
        lines = (np.flatnonzero(bad)[:5] + first_line).tolist()
        if not skip_bad_rows:
            raise MeasurementError(f"{path}: {int(bad.sum())} row(s) with missing or non-numeric values, first at "
                                   f"line(s) {', '.join(map(str, lines))} (use --skip-bad-rows to skip them)")
    keep = ~bad
    n_bad = int(bad.sum())
    if keep.sum() < 10:
        raise MeasurementError(f"{path}: fewer than 10 usable rows")
    if "time" in values:
        t = values["time"][keep] * _TIME_FACTORS.get(cmap.time_unit, np.nan)
        if not np.isfinite(_TIME_FACTORS.get(cmap.time_unit, np.nan)):
            raise MeasurementError(f"time_unit must be one of {', '.join(_TIME_FACTORS)}, got {cmap.time_unit!r}")
        t = t - t[0]
    else:
        t = np.arange(int(keep.sum())) / cmap.sample_rate_hz
    temp = values["temperature"][keep]
    if cmap.temperature_unit.upper() == "K":
        temp = temp - 273.15
    out = _convert_output(values["output"][keep], cmap)
    notes = []
    if "applied" in values:
        applied, known = values["applied"][keep], True
    elif applied_g is not None:
        applied, known = np.full(t.size, float(applied_g)), True
    else:
        applied, known = np.full(t.size, np.nan), False
    run_idx = values["run"][keep].astype(int) if "run" in values else np.full(t.size, run)
    power = values["power_on"][keep].astype(bool) if "power_on" in values else np.zeros(t.size, bool)
    m = Measurement(t, temp, out, applied, run_idx.astype(np.int16), power, known, [str(path)], n_bad, notes)
    check(m, str(path))
    return m


def check(m: Measurement, where: str) -> None:
    """Physical plausibility: increasing time, gaps, units."""
    for r in np.unique(m.run_index):
        t = m.time_s[m.run_index == r]
        d = np.diff(t)
        if np.any(d <= 0):
            k = int(np.flatnonzero(d <= 0)[0])
            raise MeasurementError(f"{where}: time is not increasing at row {k + 2} of run {r} "
                                   f"({t[k]:g} s then {t[k + 1]:g} s); check time_unit or sort the file")
        med = np.median(d) if d.size else 1.0
        gaps = np.flatnonzero(d > 20 * med)
        if gaps.size:
            m.notes.append(f"{where}: {gaps.size} gap(s) longer than 20 samples, largest {d.max():.3g} s at "
                           f"t = {t[gaps[np.argmax(d[gaps])]]:.6g} s (filters restart cleanly only at run starts)")
    temp = m.temperature_c
    if np.nanmedian(temp) > 150:
        raise MeasurementError(f"{where}: temperature median {np.nanmedian(temp):.1f} looks like kelvin; "
                               "set temperature_unit: K (or --temperature-unit K)")
    if np.nanmin(temp) < -80 or np.nanmax(temp) > 200:
        raise MeasurementError(f"{where}: temperature range {np.nanmin(temp):.1f}..{np.nanmax(temp):.1f} °C is implausible")
    med = np.nanmedian(np.abs(m.output_g))
    if med > 4.0:
        raise MeasurementError(f"{where}: output median |{med:.3g}| g is implausible for an accelerometer; "
                               "in m/s² set output_unit: m/s^2, in digits set output_unit: digits")


def concatenate(parts: list[Measurement]) -> Measurement:
    """Several files as several runs of one device, on one continuing time base."""
    t, offset = [], 0.0
    runs = []
    next_run = 0
    for p in parts:
        t.append(p.time_s - p.time_s[0] + offset)
        step = 1.0 / p.sample_rate_hz
        offset = t[-1][-1] + step
        mapping = {r: next_run + i for i, r in enumerate(np.unique(p.run_index))}
        runs.append(np.vectorize(mapping.get)(p.run_index).astype(np.int16))
        next_run += len(mapping)
    cat = lambda attr: np.concatenate([getattr(p, attr) for p in parts])  # noqa: E731
    return Measurement(np.concatenate(t), cat("temperature_c"), cat("output_g"), cat("applied_g"),
                       np.concatenate(runs), cat("power_on"), all(p.applied_known for p in parts),
                       [s for p in parts for s in p.sources], sum(p.bad_rows_skipped for p in parts),
                       [n for p in parts for n in p.notes])


def read_dataset_blind(path: str | Path) -> Measurement:
    """A ``twin run`` HDF5 file read as a measurement: the logged columns only, never the truth."""
    import h5py

    path = Path(path)
    try:
        with h5py.File(path, "r") as f:
            need = ["time_s", "temperature/thermometer_c", "output/output_g", "test/applied_g", "test/run_index",
                    "test/power_on"]
            missing = [k for k in need if k not in f]
            if missing:
                raise MeasurementError(f"{path}: not a twin dataset (missing {', '.join(missing)})")
            arrays = {k: f[k][()] for k in need}
    except OSError as exc:
        raise MeasurementError(f"{path}: not a readable HDF5 file ({exc})") from None
    m = Measurement(arrays["time_s"].astype(float), arrays["temperature/thermometer_c"].astype(float),
                    arrays["output/output_g"].astype(float), arrays["test/applied_g"].astype(float),
                    arrays["test/run_index"].astype(np.int16), arrays["test/power_on"].astype(bool), True, [str(path)])
    check(m, str(path))
    return m


def load_measurements(paths: list[str | Path], cmap: ColumnMap | None = None, *, skip_bad_rows: bool = False,
                      applied_g: float | None | str = 1.0) -> Measurement:
    """Read one or more files (CSV/TSV/log or twin HDF5) as runs of one device.

    ``applied_g``: value for files without an applied column; ``"unknown"`` when the orientation
    was not logged.
    """
    if not paths:
        raise MeasurementError("no measurement files given")
    unknown = isinstance(applied_g, str) and applied_g == "unknown"
    parts = []
    for i, p in enumerate(paths):
        p = Path(p)
        if p.suffix.lower() in (".h5", ".hdf5"):
            parts.append(read_dataset_blind(p))
        else:
            parts.append(read_table(p, cmap, run=0, skip_bad_rows=skip_bad_rows,
                                    applied_g=None if unknown else float(applied_g)))
    m = concatenate(parts) if len(parts) > 1 else parts[0]
    if unknown:
        m.applied_g = np.full(m.time_s.size, np.nan)
        m.applied_known = False
    return m


def write_canonical_csv(path: str | Path, time_s, temperature_c, output_g, applied_g, run, power_on) -> Path:
    """Write the canonical CSV form (atomically)."""
    import io

    from twin.io import atomic_write_text

    buf = io.StringIO()
    buf.write("time_s,temperature_c,output_g,applied_g,run,power_on\n")
    data = np.column_stack([time_s, temperature_c, output_g, applied_g, run, np.asarray(power_on, int)])
    np.savetxt(buf, data, delimiter=",", fmt=["%.3f", "%.4f", "%.7f", "%.4f", "%d", "%d"])
    return atomic_write_text(Path(path), buf.getvalue())


def from_dataset(ds) -> Measurement:
    """The logged columns of an in-memory simulated :class:`~twin.model.dataset.Dataset` (no truth)."""
    return Measurement(ds["time_s"].astype(float), ds["temperature/thermometer_c"].astype(float),
                       ds["output/output_g"].astype(float), ds["test/applied_g"].astype(float),
                       ds["test/run_index"].astype(np.int16), ds["test/power_on"].astype(bool), True, ["<dataset>"])
