"""The one type every reader produces, :class:`Measurement`, and the checks every reader shares.

A measurement is a single-axis log on one time base with its runs concatenated: what the
diagnosis calibrates and screens. Multi-axis, multi-IMU logs are :class:`~twin.measurement.imu.ImuLog`
and give a :class:`Measurement` per axis.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from twin.errors import TwinError

STANDARD_GRAVITY = 9.80665  # m/s² per g (CGPM 1901), the factor every m/s² log is divided by
# the readers' floor: fewer rows cannot separate a drift from an offset (every reader says so alike)
MIN_ROWS = 10


class MeasurementError(TwinError):
    """A measurement that cannot be read or makes no physical sense."""


@dataclass
class Measurement:
    """A measured (or exported) log on one time base, runs concatenated.

    Attributes
    ----------
    time_s, temperature_c, output_g, applied_g : numpy.ndarray
        Time [s], thermometer [°C], sensor output along the axis [g], acceleration applied along
        the axis [g] (NaN when unknown).
    run_index : numpy.ndarray
        Run number of each sample (int16), 0-based.
    power_on : numpy.ndarray
        True where the device was powered on at that sample.
    applied_known : bool
        False when the orientation was not logged.
    sources, notes : list of str
        The files read and what the readers noticed (gaps, skipped rows).
    bad_rows_skipped : int
        Rows dropped by ``skip_bad_rows``.
    """

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
        """Sample rate from the median positive time step [Hz] (1 for fewer than two samples)."""
        d = np.diff(self.time_s)
        if not (d > 0).all():  # a long log's increasing time: no second copy of its differences
            d = d[d > 0]
        return float(1.0 / np.median(d, overwrite_input=True)) if d.size else 1.0

    @property
    def runs(self) -> int:
        """Number of runs (highest run index + 1) [1]."""
        return int(self.run_index.max()) + 1 if self.run_index.size else 0

    def time_since_power_on_s(self) -> np.ndarray:
        """Time since the latest power-on flag (each run starts powered on).

        Returns
        -------
        ndarray
            Time since power-on [s], one per sample.
        """
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


def check(m: Measurement, where: str) -> None:
    """Physical plausibility: increasing time, gaps, units.

    Parameters
    ----------
    m : Measurement
        The measurement (gaps are noted in ``m.notes``).
    where : str
        What to name in messages (the file).

    Raises
    ------
    MeasurementError
        Too few samples, arrays of different lengths or non-finite values (row named), time not
        increasing, temperature in kelvin or implausible, output not in g.
    """
    check_arrays(m, where)
    single = m.run_index.size == 0 or m.run_index.min() == m.run_index.max()
    # one run: its number, not a sort of a long log's run column (np.unique: 0.1 s at 8.64 M rows)
    for r in (m.run_index[:1] if single else np.unique(m.run_index)):
        t = m.time_s if single else m.time_s[m.run_index == r]  # one run: no copy of a long log
        d = np.diff(t)
        if np.any(d <= 0):
            k = int(np.flatnonzero(d <= 0)[0])
            raise MeasurementError(f"{where}: time is not increasing at row {k + 2} of run {r} "
                                   f"({t[k] + 0.0:g} s then {t[k + 1] + 0.0:g} s); check time_unit or sort the file")
        med = np.median(d, overwrite_input=True) if d.size else 1.0  # partitions d: recomputed below,
        d = None  # so a long log holds one difference array at a time, not two
        d = np.diff(t)
        gaps = np.flatnonzero(d > 20 * med)
        if gaps.size:
            m.notes.append(f"{where}: {gaps.size} gap(s) longer than 20 samples, largest {d.max():.3g} s at "
                           f"t = {t[gaps[np.argmax(d[gaps])]]:.6g} s (filters restart cleanly only at run starts)")
        del d
    temp = m.temperature_c  # finite (check_arrays): plain median, min and max
    if _median_may_exceed(np.count_nonzero(temp > 150), temp.size) and (med := float(np.median(temp))) > 150:
        raise MeasurementError(f"{where}: temperature median {med:.1f} looks like kelvin; "
                               "set temperature_unit: K or F (or --temperature-unit K|F)")
    if temp.min() < -80 or temp.max() > 200:
        raise MeasurementError(f"{where}: temperature range {temp.min():.1f}..{temp.max():.1f} °C is implausible; "
                               "expected -80..200 °C (set temperature_unit: K or F if it is not °C)")
    out = m.output_g
    if (_median_may_exceed(np.count_nonzero(out > 4.0) + np.count_nonzero(out < -4.0), out.size)
            and (med := float(np.median(np.abs(out), overwrite_input=True))) > 4.0):
        raise MeasurementError(f"{where}: output median |{med:.3g}| g is implausible for an accelerometer; "
                               "in m/s² set output_unit: m/s^2, in digits set output_unit: digits")


def _median_may_exceed(above: int, n: int) -> bool:
    """Whether the median of ``n`` values can exceed a level ``above`` of them exceed: only when at
    least n − ⌊n/2⌋ do (else the upper middle value, and so the median, is at or below it). Counts
    are one pass without a copy: the median itself (a copy and a partition, 0.1 s at 8.6 M rows)
    is computed only then, and the check is the same."""
    return above >= n - n // 2


def check_arrays(m: Measurement, where: str) -> None:
    """One length for every column, at least :data:`MIN_ROWS` rows, finite time, temperature and
    output, and applied acceleration finite where the orientation is known (else all NaN).

    Parameters
    ----------
    m : Measurement
        The measurement.
    where : str
        What to name in messages (the file).
    """
    n = m.time_s.size
    columns = {"time": m.time_s, "temperature": m.temperature_c, "output": m.output_g, "applied": m.applied_g,
               "run": m.run_index, "power_on": m.power_on}
    shapes = {name: np.shape(a) for name, a in columns.items()}
    if any(shape != (n,) for shape in shapes.values()):
        raise MeasurementError(f"{where}: columns of different shapes ({', '.join(f'{k} {v}' for k, v in shapes.items())}); "
                               "expected one length for every column")
    if n < MIN_ROWS:
        raise MeasurementError(f"{where}: {n} sample(s); expected at least {MIN_ROWS}")
    finite = ["time", "temperature", "output"] + (["applied"] if m.applied_known else [])
    for name in finite:
        values = columns[name]
        bad = ~np.isfinite(values)
        if bad.any():
            k = int(np.flatnonzero(bad)[0])
            raise MeasurementError(f"{where}: {int(bad.sum())} non-finite {name} value(s), first {values[k]} at row "
                                   f"{k + 1}; expected finite numbers (--skip-bad-rows drops such rows in text logs)")
    if m.run_index.size and m.run_index.min() < 0:
        raise MeasurementError(f"{where}: negative run index {int(m.run_index.min())}; expected runs numbered from 0")


def concatenate(parts: list[Measurement]) -> Measurement:
    """Several files as several runs of one device, on one continuing time base.

    Parameters
    ----------
    parts : list of Measurement
        The files' measurements, in time order.

    Returns
    -------
    Measurement
        Runs renumbered from 0; each part starts one sample step after the previous one ends [s].
    """
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
