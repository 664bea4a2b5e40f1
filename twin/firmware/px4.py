"""PX4 accelerometer thermal calibration: the fit of ``Tools/process_sensor_caldata.py`` and the
correction of ``TemperatureCompensation.cpp`` (repo PX4/PX4-Autopilot).

Fit, step by step as the script does for each accel instance (``sensor_accel`` topic, m/s²):

1. ``TC_An_TMIN``/``TMAX`` = min/max of the *raw* logged temperature; ``TREF`` = their midpoint.
2. Each axis (not the temperature) goes through ``scipy.signal.medfilt(data, 31)``.
3. The fitted quantity is ``filtered − median(filtered)`` per axis (the level is left to the
   ordinary CAL_ACC offset calibration the script's step 12 asks for).
4. Unless ``--no_resample``: ``resampleWithDeltaX`` puts (T − TREF, value) into 2000 equal-width
   temperature bins between the min and max of T − TREF and replaces each non-empty bin by the
   mean of its temperatures and the mean of its values.
5. ``np.polyfit(temp, values, 3)`` → ``X3, X2, X1, X0`` = coefficients of (T − TREF)^3..0.

Firmware (``calc_thermal_offsets_3D``, float32): ΔT = clip(T, TMIN, TMAX) − TREF,
offset = X0 + X1·ΔT + X2·ΔT² + X3·ΔT³; ``Accelerometer::Correct`` (src/lib/sensor_calibration/
Accelerometer.hpp) returns rotation · ((raw − thermal_offset − CAL offset) ∘ scale).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np
from scipy.signal import medfilt

from twin.firmware.common import (
    ClampedPolynomial,
    FirmwareCalError,
    as_samples,
    as_temperature,
)

MEDIAN_KERNEL = 31  # process_sensor_caldata.py: median_filter() = medfilt(data, 31)
N_BINS = 2000  # process_sensor_caldata.py: resampleWithDeltaX, nbInterval = 2000
PX4_ACCEL_INSTANCES = 4  # the script writes TC_A0..TC_A3


@dataclass(frozen=True)
class Px4AccelCal:
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

    @property
    def polynomial(self) -> ClampedPolynomial:
        """The firmware's offset as a float64 clamped polynomial about TREF."""
        return ClampedPolynomial(self.tmin_c, self.tmax_c, self.tref_c, self.x)

    def offset_m_s2(self, temperature_c) -> np.ndarray:
        """Predicted thermal offset (n, 3) in m/s²: Σ X_k (clip(T) − TREF)^k."""
        return self.polynomial.offset(temperature_c)

    def correct(self, accel_m_s2, temperature_c) -> np.ndarray:
        """Corrected reading raw − offset (m/s², before CAL_ACC offset/scale and rotation)."""
        return np.asarray(accel_m_s2, dtype=float) - self.offset_m_s2(temperature_c)


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
        The quantity to resample (here the median-removed accel axis, m/s²).

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
        ``TC_An_ID`` (the script takes the median logged ``device_id``).
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
    if not 0 <= int(instance) < PX4_ACCEL_INSTANCES:
        raise FirmwareCalError(f"PX4 accel instance must be 0..{PX4_ACCEL_INSTANCES - 1}, got {instance}")
    t = as_temperature(temperature_c)
    a = as_samples(accel_m_s2, t.size, "accel_m_s2")
    tmin, tmax = float(np.min(t)), float(np.max(t))
    if not tmax > tmin:
        raise FirmwareCalError(f"temperature_c is constant ({tmin:g} °C); PX4's fit needs a temperature span")
    tref = 0.5 * (tmin + tmax)
    temp_rel = t - tref
    coeffs, medians = [], []
    for axis in range(3):
        filtered = median_filter(a[:, axis])
        median = float(np.median(filtered))
        correction = filtered - median
        if resample:
            xs, ys = resample_by_temperature(temp_rel, correction)
        else:
            xs, ys = temp_rel, correction
        if xs.size < 4:
            raise FirmwareCalError(f"only {xs.size} distinct temperature bins; a cubic needs at least 4")
        p = np.polyfit(xs, ys, 3)  # highest power first: X3, X2, X1, X0
        coeffs.append((float(p[3]), float(p[2]), float(p[1]), float(p[0])))
        medians.append(median)
    return Px4AccelCal(int(instance), int(device_id), tmin, tmax, tref, tuple(coeffs), tuple(medians))


def firmware_offset_px4(values: Mapping[str, float], temperature_c, instance: int = 0) -> np.ndarray:
    """The offset PX4 firmware computes from loaded parameters, in float32 like the firmware.

    Follows ``TemperatureCompensation::calc_thermal_offsets_3D`` (PX4/PX4-Autopilot,
    src/modules/temperature_compensation/TemperatureCompensation.cpp): ΔT = T − TREF, or
    TMAX − TREF above TMAX, TMIN − TREF below TMIN; ΔT² = ΔT·ΔT, ΔT³ = ΔT²·ΔT;
    offset[i] = x0[i] + x1[i]·ΔT + x2[i]·ΔT² + x3[i]·ΔT³, all float. Zero when
    ``TC_A_ENABLE`` ≠ 1 (``update_offsets_accel`` returns early). The firmware then subtracts it:
    ``Accelerometer::Correct`` = raw − thermal_offset − CAL offset. The device-id → instance
    mapping (``set_sensor_id``) is not modelled: the caller names the instance.

    Parameters
    ----------
    values : mapping
        Parameter name → value as loaded (e.g. ``read_px4_params(path).values``).
    temperature_c : array
        Sensor temperature, °C (converted to float32 like ``sensor_accel.temperature``).

    Returns
    -------
    (n, 3) float32 array of offsets in m/s².
    """
    f32 = np.float32
    t = np.atleast_1d(np.asarray(temperature_c, dtype=f32))
    if int(values.get("TC_A_ENABLE", 0)) != 1:
        return np.zeros(t.shape + (3,), dtype=f32)
    p = f"TC_A{int(instance)}_"
    tmin, tmax, tref = (f32(values[p + k]) for k in ("TMIN", "TMAX", "TREF"))
    dt = np.where(t > tmax, tmax - tref, np.where(t < tmin, tmin - tref, t - tref)).astype(f32)
    dt2 = dt * dt
    dt3 = dt2 * dt
    out = np.empty(t.shape + (3,), dtype=f32)
    for i in range(3):
        x0, x1, x2, x3 = (f32(values[f"{p}X{k}_{i}"]) for k in range(4))
        out[..., i] = ((x0 + x1 * dt) + x2 * dt2) + x3 * dt3  # C evaluates left to right
    return out
