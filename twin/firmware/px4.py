"""PX4 accelerometer and gyro thermal calibration: the ``TC_A``/``TC_G`` parameters and the fit
of ``Tools/process_sensor_caldata.py`` (repo PX4/PX4-Autopilot).

Fit, step by step as the script does for each accel instance (``sensor_accel`` topic, m/s²):

1. ``TC_An_TMIN``/``TMAX`` = min/max of the *raw* logged temperature; ``TREF`` = their midpoint.
2. Each axis (not the temperature) goes through ``scipy.signal.medfilt(data, 31)``.
3. The fitted quantity is ``filtered − median(filtered)`` per axis (the level is left to the
   ordinary CAL_ACC offset calibration the script's step 12 asks for).
4. Unless ``--no_resample``: ``resampleWithDeltaX`` puts (T − TREF, value) into 2000 equal-width
   temperature bins between the min and max of T − TREF and replaces each non-empty bin by the
   mean of its temperatures and the mean of its values.
5. ``np.polyfit(temp, values, 3)`` → ``X3, X2, X1, X0`` = coefficients of (T − TREF)^3..0.

The gyro (``sensor_gyro``, rad/s → ``TC_Gn_*``) goes through the same steps except 3: the script
fits the filtered rate itself, so X0 is the absolute bias at TREF, not a deviation from a median.

Firmware (``calc_thermal_offsets_3D``): ΔT = clip(T, TMIN, TMAX) − TREF, offset = X0 + X1·ΔT +
X2·ΔT² + X3·ΔT³, evaluated here in float64 (:meth:`Px4CalBase.offset`); the float32 arithmetic
of the firmware and the vehicle's republish rule are in :mod:`twin.firmware.px4_vehicle`.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

import numpy as np
from scipy import ndimage

from twin.firmware.common import (
    ClampedPolynomial,
    FirmwareCalError,
    FirmwareValueError,
    as_samples,
    as_temperature,
    check_instance,
)

MEDIAN_KERNEL = 31  # process_sensor_caldata.py: median_filter() = medfilt(data, 31)
N_BINS = 2000  # process_sensor_caldata.py: resampleWithDeltaX, nbInterval = 2000
PX4_INSTANCES = 4  # TC_A0..TC_A3 and TC_G0..TC_G3 (ACCEL_COUNT_MAX, GYRO_COUNT_MAX)
PX4_TERMS = 4  # X0..X3: calc_thermal_offsets_3D is a cubic
SENSOR_PREFIX = {"accel": "TC_A", "gyro": "TC_G"}


class Px4CalBase:
    """What the ``TC_A`` and ``TC_G`` calibrations share: the parameter prefix and the clamped cubic."""

    sensor: ClassVar[str] = "accel"

    @property
    def prefix(self) -> str:
        """``TC_A{n}_`` or ``TC_G{n}_``."""
        return f"{SENSOR_PREFIX[self.sensor]}{self.instance}_"

    @property
    def polynomial(self) -> ClampedPolynomial:
        """The firmware's offset as a float64 clamped polynomial about TREF."""
        return ClampedPolynomial(self.tmin_c, self.tmax_c, self.tref_c, self.x)

    def offset(self, temperature_c) -> np.ndarray:
        """Predicted thermal offset (n, 3) in the sensor's unit: Σ X_k (clip(T) − TREF)^k.

        PX4 ``calc_thermal_offsets_3D`` in float64 (the firmware's float32 evaluation is
        :func:`twin.firmware.px4_vehicle.firmware_offset_px4`).

        Parameters
        ----------
        temperature_c : array_like
            Sensor temperature [°C].

        Returns
        -------
        ndarray
            Offset (n, 3) [m/s² for the accel, rad/s for the gyro].
        """
        return self.polynomial.offset(temperature_c)


@dataclass(frozen=True)
class Px4AccelCal(Px4CalBase):
    """One accelerometer's ``TC_A{instance}_*`` parameters (PX4 process_sensor_caldata.py).

    Attributes
    ----------
    instance : int
        n in ``TC_An_*`` (0..3).
    device_id : int
        ``TC_An_ID``: the sensor's device id (the firmware maps calibrations to sensors by it).
    tmin_c, tmax_c, tref_c : float
        ``TC_An_TMIN``, ``TMAX``, ``TREF`` in °C.
    x : tuple of tuple of float
        ``x[axis][k]`` = ``TC_An_X{k}_{axis}`` in m/s²/°C^k, k = 0..3, axis 0..2 = x, y, z.
    median_m_s2 : tuple of float or None
        Per-axis median of the filtered data that was subtracted before the fit (None when the
        calibration was read back from a parameter file).
    """

    instance: int
    device_id: int
    tmin_c: float
    tmax_c: float
    tref_c: float
    x: tuple[tuple[float, float, float, float], ...]
    median_m_s2: tuple[float, float, float] | None = None
    sensor: ClassVar[str] = "accel"

    def offset_m_s2(self, temperature_c) -> np.ndarray:
        """Predicted thermal offset (n, 3) in m/s²: Σ X_k (clip(T) − TREF)^k.

        Parameters
        ----------
        temperature_c : array_like
            Sensor temperature [°C].

        Returns
        -------
        ndarray
            Offset (n, 3) [m/s²].
        """
        return self.offset(temperature_c)

    def correct(self, accel_m_s2, temperature_c) -> np.ndarray:
        """Corrected reading raw − offset (m/s², before CAL_ACC offset/scale and rotation).

        Parameters
        ----------
        accel_m_s2 : array_like
            Raw acceleration (n, 3) [m/s²].
        temperature_c : array_like
            Sensor temperature [°C].

        Returns
        -------
        ndarray
            Corrected acceleration (n, 3) [m/s²].
        """
        return np.asarray(accel_m_s2, dtype=float) - self.offset_m_s2(temperature_c)


@dataclass(frozen=True)
class Px4GyroCal(Px4CalBase):
    """One gyro's ``TC_G{instance}_*`` parameters (PX4 process_sensor_caldata.py).

    Attributes
    ----------
    instance : int
        n in ``TC_Gn_*`` (0..3).
    device_id : int
        ``TC_Gn_ID``: the gyro's device id.
    tmin_c, tmax_c, tref_c : float
        ``TC_Gn_TMIN``, ``TMAX``, ``TREF`` in °C.
    x : tuple of tuple of float
        ``x[axis][k]`` = ``TC_Gn_X{k}_{axis}`` in rad/s/°C^k; X0 is the absolute bias at TREF.
    """

    instance: int
    device_id: int
    tmin_c: float
    tmax_c: float
    tref_c: float
    x: tuple[tuple[float, float, float, float], ...]
    sensor: ClassVar[str] = "gyro"

    def offset_rad_s(self, temperature_c) -> np.ndarray:
        """Predicted gyro bias (n, 3) in rad/s: Σ X_k (clip(T) − TREF)^k.

        Parameters
        ----------
        temperature_c : array_like
            Sensor temperature [°C].

        Returns
        -------
        ndarray
            Bias (n, 3) [rad/s].
        """
        return self.offset(temperature_c)

    def correct(self, gyro_rad_s, temperature_c) -> np.ndarray:
        """Corrected rate raw − offset (rad/s, before CAL_GYRn offsets and rotation).

        Parameters
        ----------
        gyro_rad_s : array_like
            Raw angular rate (n, 3) [rad/s].
        temperature_c : array_like
            Sensor temperature [°C].

        Returns
        -------
        ndarray
            Corrected rate (n, 3) [rad/s].
        """
        return np.asarray(gyro_rad_s, dtype=float) - self.offset_rad_s(temperature_c)


def median_filter(values: np.ndarray) -> np.ndarray:
    """``scipy.signal.medfilt(values, 31)``, as process_sensor_caldata.py ``median_filter``.

    medfilt pads with zeros, so the first and last 15 samples see zeros in their window; kept
    as is to reproduce the script (a soak at each end of the log makes it harmless).

    Parameters
    ----------
    values : ndarray
        One axis [m/s² or rad/s].

    Returns
    -------
    ndarray
        Filtered values [unit of ``values``].
    """
    # ndimage's median over medfilt's zero-padded windows: its values, without importing scipy.signal
    return ndimage.median_filter(np.asarray(values, dtype=float), MEDIAN_KERNEL, mode="constant", cval=0.0)


def median_filter_rows(filtered_all: np.ndarray, values_all: np.ndarray, index: np.ndarray,
                       scale: float = 1.0) -> np.ndarray:
    """:func:`median_filter` of ``values_all[index] * scale`` from :func:`median_filter` of
    ``values_all * scale``.

    A median is a selection, so a row whose 31-sample window in the selected rows is the same 31
    rows of the whole log has the same filtered value: it is read from ``filtered_all``. Only the
    rows within 15 of a jump in ``index`` (a held-out branch or a dwell left out) or of either end
    (the zero padding) are filtered again, from their own neighbourhood. The result is identical
    to filtering the selected rows; the cost is a gather, not a filter, per selection.

    Parameters
    ----------
    filtered_all : (n,) or (n, k) ndarray
        ``median_filter`` of each column of ``values_all * scale``.
    values_all : (n,) or (n, k) ndarray
        The whole log, in any unit.
    index : (m,) ndarray of int
        Rows selected, increasing.
    scale : float
        To the unit of ``filtered_all`` (e.g. g → m/s²): applied to the rows filtered again only.

    Returns
    -------
    (m,) or (m, k) ndarray
        ``median_filter`` of each column of ``values_all[index] * scale``.
    """
    half = MEDIAN_KERNEL // 2
    index = np.asarray(index)
    out = filtered_all[index]
    same = np.zeros(index.size, bool)  # the window of row j holds the rows index[j] − 15 … + 15
    if index.size > 2 * half:
        same[half:-half] = index[2 * half:] - index[: -2 * half] == 2 * half
    edges = np.diff(np.r_[0, (~same).astype(np.int8), 0])
    for p, q in zip(np.flatnonzero(edges == 1), np.flatnonzero(edges == -1)):
        # the rows within 15 on either side, and at least a kernel of them (no shorter filter: the
        # same values, without scipy's warning of a kernel longer than its input)
        hi = min(q + half, index.size)
        lo = max(min(p - half, hi - MEDIAN_KERNEL), 0)
        hi = min(max(hi, lo + MEDIAN_KERNEL), index.size)
        near = values_all[index[lo:hi]] * scale
        for k in range(1 if near.ndim == 1 else near.shape[1]):
            col = near if near.ndim == 1 else near[:, k]
            (out if out.ndim == 1 else out[:, k])[p:q] = median_filter(col)[p - lo:q - lo]
    return out


def resample_by_temperature(temp_rel_c: np.ndarray, values: np.ndarray, n_bins: int = N_BINS):
    """Bin means of temperature and value, as process_sensor_caldata.py ``resampleWithDeltaX``.

    Bin width = (max − min)/n_bins; a sample goes to bin ``int((x − min)/width)`` if x < max,
    else to the last bin; empty bins are dropped; each bin becomes (mean x, mean y).

    Parameters
    ----------
    temp_rel_c : (n,) array
        Temperature relative to TREF (°C).
    values : (n,) array
        The quantity to resample (the median-removed accel axis, or the gyro axis).
    n_bins : int
        Number of equal-width temperature bins.

    Returns
    -------
    (temp_rel_c, values) : tuple of (m,) arrays, m ≤ n_bins
    """
    bins = TemperatureBins(temp_rel_c, n_bins)
    return bins.mean_x, bins.mean(values)


class TemperatureBins:
    """The bins of :func:`resample_by_temperature`, found once for every axis binned on them.

    Parameters
    ----------
    temp_rel_c : (n,) array
        Temperature relative to TREF (°C).
    n_bins : int
        Number of equal-width temperature bins.

    Attributes
    ----------
    mean_x : (m,) ndarray
        Mean temperature of each non-empty bin, m ≤ n_bins.
    """

    def __init__(self, temp_rel_c, n_bins: int = N_BINS):
        x = np.asarray(temp_rel_c, dtype=float)
        x_min, x_max = float(np.min(x)), float(np.max(x))
        width = (x_max - x_min) / n_bins
        idx = np.full(x.shape, n_bins - 1, dtype=np.int64)
        below = x < x_max
        idx[below] = ((x[below] - x_min) / width).astype(np.int64)
        # the script would raise IndexError if rounding put x < max into bin n_bins; use the last bin
        self.idx, self.n_bins = np.minimum(idx, n_bins - 1), n_bins
        count = np.bincount(self.idx, minlength=n_bins)
        self.keep = count != 0
        self.count = count[self.keep]
        self.mean_x = self.mean(x)

    def mean(self, values) -> np.ndarray:
        """Mean of ``values`` in each non-empty bin.

        Parameters
        ----------
        values : (n,) array-like, one value per sample binned

        Returns
        -------
        (m,) ndarray, the mean in each non-empty bin in bin order
        """
        total = np.bincount(self.idx, weights=np.asarray(values, dtype=float), minlength=self.n_bins)
        return total[self.keep] / self.count


def _fit_cubic(temperature_c, samples, name: str, subtract_median: bool, resample: bool, filtered=None):
    """(tmin, tmax, tref, x, medians): the script's steps 1–5 on one sensor's three axes
    (``filtered``: the samples already through :func:`median_filter`, column by column)."""
    t = as_temperature(temperature_c)
    a = as_samples(samples, t.size, name)
    if filtered is not None and np.shape(filtered) != a.shape:
        raise FirmwareCalError(f"filtered must be {a.shape} like {name}; got {np.shape(filtered)}")
    tmin, tmax = float(np.min(t)), float(np.max(t))
    if not tmax > tmin:
        raise FirmwareCalError(f"temperature_c is constant ({tmin:g} °C); PX4's fit needs a temperature span")
    tref = 0.5 * (tmin + tmax)
    temp_rel = t - tref
    coeffs, medians = [], []
    bins = TemperatureBins(temp_rel) if resample else None  # the same bins for the three axes
    for axis in range(3):
        column = median_filter(a[:, axis]) if filtered is None else filtered[:, axis]
        median = float(np.median(column))
        y = column - median if subtract_median else column
        xs, ys = (bins.mean_x, bins.mean(y)) if resample else (temp_rel, y)
        if xs.size < 4:
            raise FirmwareCalError(f"only {xs.size} distinct temperature bins; a cubic needs at least 4")
        p = np.polyfit(xs, ys, 3)  # highest power first: X3, X2, X1, X0
        coeffs.append((float(p[3]), float(p[2]), float(p[1]), float(p[0])))
        medians.append(median)
    return tmin, tmax, tref, tuple(coeffs), tuple(medians)


def fit_px4(temperature_c, accel_m_s2, *, device_id: int = 0, instance: int = 0,
            resample: bool = True, filtered=None) -> Px4AccelCal:
    """Fit ``TC_A{instance}_*`` exactly as PX4 Tools/process_sensor_caldata.py does.

    Parameters
    ----------
    temperature_c : (n,) array
        The sensor's own temperature (``sensor_accel.temperature``), °C.
    accel_m_s2 : (n, 3) array
        Accelerometer x, y, z in m/s², the board held still.
    device_id : int
        ``TC_An_ID`` (the script takes the median logged ``device_id``). 0 is accepted here for
        analysis; the ``.params`` writer refuses it (PX4 would never apply the calibration).
    instance : int
        n in ``TC_An`` (0..3).
    resample : bool
        False reproduces the script's ``--no_resample`` (fit the raw filtered samples).
    filtered : (n, 3) array, optional
        ``accel_m_s2`` already through :func:`median_filter`, column by column (e.g. from
        :func:`median_filter_rows`); by default filtered here.

    Returns
    -------
    Px4AccelCal

    Notes
    -----
    Steps (see module docstring): TMIN/TMAX/TREF from raw T → medfilt(31) per axis → subtract
    the median → 2000-bin temperature resampling → ``np.polyfit(deg=3)`` about TREF.
    """
    n = check_instance(instance, 0, PX4_INSTANCES - 1, "TC_A{}")
    tmin, tmax, tref, x, medians = _fit_cubic(temperature_c, accel_m_s2, "accel_m_s2", True, resample, filtered)
    return Px4AccelCal(n, int(device_id), tmin, tmax, tref, x, medians)


def fit_px4_gyro(temperature_c, gyro_rad_s, device_id: int = 0, instance: int = 0, *,
                 resample: bool = True, filtered=None) -> Px4GyroCal:
    """Fit ``TC_G{instance}_*`` as PX4 Tools/process_sensor_caldata.py does for ``sensor_gyro``.

    Parameters
    ----------
    temperature_c : (n,) array
        The gyro's own temperature (``sensor_gyro.temperature``), °C.
    gyro_rad_s : (n, 3) array
        Angular rate x, y, z in rad/s, the board held still.
    device_id : int
        ``TC_Gn_ID`` (median logged ``device_id`` of the gyro).
    instance : int
        n in ``TC_Gn`` (0..3).
    resample : bool
        False reproduces ``--no_resample``.
    filtered : (n, 3) array, optional
        ``gyro_rad_s`` already through :func:`median_filter`, column by column.

    Returns
    -------
    Px4GyroCal

    Notes
    -----
    Same steps as :func:`fit_px4` except that the median is *not* subtracted: the script fits
    ``median_filter(sensor_gyro['x'])`` directly, so X0 carries the gyro's absolute bias at TREF
    (a still gyro should read 0; the accelerometer's level is gravity and stays with CAL_ACC).
    """
    n = check_instance(instance, 0, PX4_INSTANCES - 1, "TC_G{}")
    tmin, tmax, tref, x, _ = _fit_cubic(temperature_c, gyro_rad_s, "gyro_rad_s", False, resample, filtered)
    return Px4GyroCal(n, int(device_id), tmin, tmax, tref, x)


def check_sensor(sensor: str) -> str:
    """``sensor`` if PX4 compensates it here (``accel`` or ``gyro``).

    Parameters
    ----------
    sensor : str
        The sensor kind.

    Returns
    -------
    str
        ``sensor`` itself.

    Raises
    ------
    FirmwareValueError
        Any other kind.
    """
    if sensor not in SENSOR_PREFIX:
        raise FirmwareValueError(f"sensor {sensor!r} is not one PX4 compensates here; expected 'accel' or 'gyro'")
    return sensor
