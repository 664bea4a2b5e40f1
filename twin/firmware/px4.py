"""PX4 accelerometer and gyro thermal calibration: the fit of ``Tools/process_sensor_caldata.py``,
the offset of ``TemperatureCompensation.cpp`` and when the vehicle republishes it (repo PX4/PX4-Autopilot).

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

Firmware (``calc_thermal_offsets_3D``, float32): ΔT = clip(T, TMIN, TMAX) − TREF,
offset = X0 + X1·ΔT + X2·ΔT² + X3·ΔT³; ``Accelerometer::Correct`` / ``Gyroscope::Correct``
(src/lib/sensor_calibration/) return rotation · ((raw − thermal_offset − CAL offset) ∘ scale).
The offset reaches them only through ``sensor_correction``, republished by
``TemperatureCompensationModule`` (see :func:`px4_vehicle_offsets`).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import ClassVar

import numpy as np
from scipy.signal import medfilt

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
REPUBLISH_THRESHOLD_C = 1.0  # update_offsets_accel/_gyro: fabsf(temperature - last_temperature) > 1.0f
CHECK_PERIOD_S = 1.0  # TemperatureCompensationModule::init: ScheduleOnInterval(1_s)
LAST_TEMPERATURE_RESET_C = -100.0  # TemperatureCompensation.h PerSensorData::reset_temperature


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
        """Predicted thermal offset (n, 3) in the sensor's unit: Σ X_k (clip(T) − TREF)^k."""
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
        """Predicted thermal offset (n, 3) in m/s²: Σ X_k (clip(T) − TREF)^k."""
        return self.offset(temperature_c)

    def correct(self, accel_m_s2, temperature_c) -> np.ndarray:
        """Corrected reading raw − offset (m/s², before CAL_ACC offset/scale and rotation)."""
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
        """Predicted gyro bias (n, 3) in rad/s: Σ X_k (clip(T) − TREF)^k."""
        return self.offset(temperature_c)

    def correct(self, gyro_rad_s, temperature_c) -> np.ndarray:
        """Corrected rate raw − offset (rad/s, before CAL_GYRn offsets and rotation)."""
        return np.asarray(gyro_rad_s, dtype=float) - self.offset_rad_s(temperature_c)


def median_filter(values: np.ndarray) -> np.ndarray:
    """``scipy.signal.medfilt(values, 31)``, as process_sensor_caldata.py ``median_filter``.

    medfilt pads with zeros, so the first and last 15 samples see zeros in their window; kept
    as is to reproduce the script (a soak at each end of the log makes it harmless).
    """
    return medfilt(np.asarray(values, dtype=float), MEDIAN_KERNEL)


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

    Returns
    -------
    (temp_rel_c, values) : tuple of (m,) arrays, m ≤ n_bins
    """
    x = np.asarray(temp_rel_c, dtype=float)
    y = np.asarray(values, dtype=float)
    x_min, x_max = float(np.min(x)), float(np.max(x))
    width = (x_max - x_min) / n_bins
    idx = np.full(x.shape, n_bins - 1, dtype=np.int64)
    below = x < x_max
    idx[below] = ((x[below] - x_min) / width).astype(np.int64)
    # the script would raise IndexError if rounding put x < max into bin n_bins; use the last bin
    idx = np.minimum(idx, n_bins - 1)
    count = np.bincount(idx, minlength=n_bins)
    keep = count != 0
    sum_x = np.bincount(idx, weights=x, minlength=n_bins)
    sum_y = np.bincount(idx, weights=y, minlength=n_bins)
    return sum_x[keep] / count[keep], sum_y[keep] / count[keep]


def _fit_cubic(temperature_c, samples, name: str, subtract_median: bool, resample: bool):
    """(tmin, tmax, tref, x, medians): the script's steps 1–5 on one sensor's three axes."""
    t = as_temperature(temperature_c)
    a = as_samples(samples, t.size, name)
    tmin, tmax = float(np.min(t)), float(np.max(t))
    if not tmax > tmin:
        raise FirmwareCalError(f"temperature_c is constant ({tmin:g} °C); PX4's fit needs a temperature span")
    tref = 0.5 * (tmin + tmax)
    temp_rel = t - tref
    coeffs, medians = [], []
    for axis in range(3):
        filtered = median_filter(a[:, axis])
        median = float(np.median(filtered))
        y = filtered - median if subtract_median else filtered
        xs, ys = resample_by_temperature(temp_rel, y) if resample else (temp_rel, y)
        if xs.size < 4:
            raise FirmwareCalError(f"only {xs.size} distinct temperature bins; a cubic needs at least 4")
        p = np.polyfit(xs, ys, 3)  # highest power first: X3, X2, X1, X0
        coeffs.append((float(p[3]), float(p[2]), float(p[1]), float(p[0])))
        medians.append(median)
    return tmin, tmax, tref, tuple(coeffs), tuple(medians)


def fit_px4(temperature_c, accel_m_s2, *, device_id: int = 0, instance: int = 0,
            resample: bool = True) -> Px4AccelCal:
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

    Returns
    -------
    Px4AccelCal

    Notes
    -----
    Steps (see module docstring): TMIN/TMAX/TREF from raw T → medfilt(31) per axis → subtract
    the median → 2000-bin temperature resampling → ``np.polyfit(deg=3)`` about TREF.
    """
    n = check_instance(instance, 0, PX4_INSTANCES - 1, "TC_A{}")
    tmin, tmax, tref, x, medians = _fit_cubic(temperature_c, accel_m_s2, "accel_m_s2", True, resample)
    return Px4AccelCal(n, int(device_id), tmin, tmax, tref, x, medians)


def fit_px4_gyro(temperature_c, gyro_rad_s, device_id: int = 0, instance: int = 0, *,
                 resample: bool = True) -> Px4GyroCal:
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
    tmin, tmax, tref, x, _ = _fit_cubic(temperature_c, gyro_rad_s, "gyro_rad_s", False, resample)
    return Px4GyroCal(n, int(device_id), tmin, tmax, tref, x)


def check_sensor(sensor: str) -> str:
    """``sensor`` if PX4 compensates it here (``accel`` or ``gyro``)."""
    if sensor not in SENSOR_PREFIX:
        raise FirmwareValueError(f"sensor {sensor!r} is not one PX4 compensates here; expected 'accel' or 'gyro'")
    return sensor


def _offsets32(values: Mapping[str, float], prefix: str, t: np.ndarray) -> np.ndarray:
    """``calc_thermal_offsets_3D`` on float32 temperatures ``t`` with the parameters under ``prefix``."""
    f32 = np.float32
    tmin, tmax, tref = (f32(values[prefix + k]) for k in ("TMIN", "TMAX", "TREF"))
    dt = np.where(t > tmax, tmax - tref, np.where(t < tmin, tmin - tref, t - tref)).astype(f32)
    dt2 = dt * dt
    dt3 = dt2 * dt
    out = np.empty(t.shape + (3,), dtype=f32)
    for i in range(3):
        x0, x1, x2, x3 = (f32(values[f"{prefix}X{k}_{i}"]) for k in range(4))
        out[..., i] = ((x0 + x1 * dt) + x2 * dt2) + x3 * dt3  # C evaluates left to right
    return out


def firmware_offset_px4(values: Mapping[str, float], temperature_c, instance: int = 0, *,
                        sensor: str = "accel") -> np.ndarray:
    """The offset PX4 firmware computes from loaded parameters, in float32 like the firmware.

    Follows ``TemperatureCompensation::calc_thermal_offsets_3D`` (PX4/PX4-Autopilot,
    src/modules/temperature_compensation/TemperatureCompensation.cpp): ΔT = T − TREF, or
    TMAX − TREF above TMAX, TMIN − TREF below TMIN; ΔT² = ΔT·ΔT, ΔT³ = ΔT²·ΔT;
    offset[i] = x0[i] + x1[i]·ΔT + x2[i]·ΔT² + x3[i]·ΔT³, all float. Zero when
    ``TC_A_ENABLE`` (``TC_G_ENABLE`` for the gyro) ≠ 1 (``update_offsets_accel``/``_gyro`` return
    early). The firmware then subtracts it: ``Accelerometer::Correct`` = raw − thermal_offset −
    CAL offset. The device-id → slot mapping (``set_sensor_id``) is not modelled here: the caller
    names the slot (see :func:`px4_vehicle_offsets` for that and for the republish rule).

    Parameters
    ----------
    values : mapping
        Parameter name → value as loaded (e.g. ``read_px4_params(path).values``).
    temperature_c : array
        Sensor temperature, °C (converted to float32 like ``sensor_accel.temperature``).
    instance : int
        n in ``TC_An``/``TC_Gn``.
    sensor : {"accel", "gyro"}

    Returns
    -------
    (n, 3) float32 array of offsets (m/s² for the accel, rad/s for the gyro).
    """
    base = SENSOR_PREFIX[check_sensor(sensor)]
    t = np.atleast_1d(np.asarray(temperature_c, dtype=np.float32))
    if int(values.get(base + "_ENABLE", 0)) != 1:
        return np.zeros(t.shape + (3,), dtype=np.float32)
    return _offsets32(values, f"{base}{int(instance)}_", t)


def _slot_for_device(values: Mapping[str, float], base: str, device_id: int) -> int | None:
    """``set_sensor_id``: the first slot j whose ``TC_xj_ID`` (as uint32) equals ``device_id``."""
    for j in range(PX4_INSTANCES):
        stored = values.get(f"{base}{j}_ID")
        if stored is not None and int(np.int64(stored)) & 0xFFFFFFFF == int(device_id) & 0xFFFFFFFF:
            return j
    return None


def px4_vehicle_offsets(values: Mapping[str, float], time_s, temperature_c, instance: int = 0,
                        sensor: str = "accel", *, device_id: int | None = None,
                        check_period_s: float = CHECK_PERIOD_S, first_check_s: float | None = None) -> np.ndarray:
    """The thermal offset PX4 actually subtracts from each sample of a log, republish rule included.

    ``TemperatureCompensationModule`` runs once a second (``init``: ``ScheduleOnInterval(1_s)``);
    each run ``accelPoll``/``gyroPoll`` takes the latest sample and ``update_offsets_accel``/
    ``_gyro`` (TemperatureCompensation.cpp) publishes a new ``sensor_correction`` only when
    ``fabsf(T − last_temperature) > 1.0f``, then sets ``last_temperature = T`` (reset to −100 °C).
    ``Accelerometer::SensorCorrectionsUpdate`` / ``Gyroscope::SensorCorrectionsUpdate``
    (src/lib/sensor_calibration/) copy the published offset, zero until the first publication.
    So the vehicle holds a staircase: the offset at the temperature of the last publication.

    Parameters
    ----------
    values : mapping
        Parameters as loaded.
    time_s : (n,) array
        Sample times (s), non-decreasing.
    temperature_c : (n,) array
        Sensor temperature (°C), held as float32 like ``sensor_accel.temperature``.
    instance : int
        Slot n of ``TC_An``/``TC_Gn`` (ignored when ``device_id`` is given).
    sensor : {"accel", "gyro"}
    device_id : int, optional
        The sensor's device id: the slot is then found as ``set_sensor_id`` does, and no slot
        matching means no compensation (all zeros), as on the vehicle.
    check_period_s : float
        Module period (1 s).
    first_check_s : float, optional
        Time of the first run (default: the first sample); the phase is not in the log.

    Returns
    -------
    (n, 3) float32 array: offset applied to each sample. A sample at a check instant was taken
    before that check's publication, so it still gets the previous offset.

    Notes
    -----
    Modelled for this sensor alone: a publication triggered by another sensor also carries this
    one's current offset (``_corrections`` is recomputed every run), which can only make the
    staircase finer on a vehicle.
    """
    base = SENSOR_PREFIX[check_sensor(sensor)]
    f32 = np.float32
    t = np.asarray(temperature_c, dtype=f32)
    time = np.asarray(time_s, dtype=float)
    if t.ndim != 1 or time.shape != t.shape or t.size == 0:
        raise FirmwareCalError(f"time_s and temperature_c must be 1-D of one length, got {time.shape} and {t.shape}")
    if not (np.all(np.isfinite(time)) and np.all(np.diff(time) >= 0)):
        raise FirmwareCalError("time_s must be finite and non-decreasing; sort the log by time first")
    if not check_period_s > 0:
        raise FirmwareCalError(f"check_period_s must be > 0 s, got {check_period_s}")
    out = np.zeros(t.shape + (3,), dtype=f32)
    if int(values.get(base + "_ENABLE", 0)) != 1:
        return out
    slot = int(instance) if device_id is None else _slot_for_device(values, base, device_id)
    if slot is None:
        return out
    start = float(time[0]) if first_check_s is None else float(first_check_s)
    checks = start + check_period_s * np.arange(max(int(np.floor((time[-1] - start) / check_period_s)) + 1, 0))
    latest = np.searchsorted(time, checks, side="right") - 1  # the sample each run reads
    last, previous = f32(LAST_TEMPERATURE_RESET_C), -1
    pub_time, pub_temp = [], []
    for when, i in zip(checks, latest):
        if i < 0 or i == previous:  # no new sample since the last run: update() returns false
            continue
        previous = i
        if abs(t[i] - last) > f32(REPUBLISH_THRESHOLD_C):
            last = t[i]
            pub_time.append(when)
            pub_temp.append(t[i])
    if not pub_time:
        return out
    published = _offsets32(values, f"{base}{slot}_", np.asarray(pub_temp, dtype=f32))
    k = np.searchsorted(np.asarray(pub_time), time, side="left") - 1  # last publication strictly before
    out[k >= 0] = published[k[k >= 0]]
    return out


def px4_republish_lag_c(time_s, temperature_c, check_period_s: float = CHECK_PERIOD_S) -> float:
    """Bound (°C) on |T(sample) − T(published)| after the first publication, on this log.

    At the latest run before a sample either the offset was republished or T had moved ≤ 1 °C
    since; since that run T moved at most max|dT/dt|·(period + longest sample gap). Multiplied by
    the largest |d offset/dT| this bounds the staircase's error against the ideal polynomial.
    """
    t = np.asarray(temperature_c, dtype=float)
    time = np.asarray(time_s, dtype=float)
    gaps = np.diff(time)
    rate = float(np.max(np.abs(np.diff(t)) / np.where(gaps > 0, gaps, np.inf))) if t.size > 1 else 0.0
    return REPUBLISH_THRESHOLD_C + rate * (check_period_s + (float(np.max(gaps)) if t.size > 1 else 0.0))
