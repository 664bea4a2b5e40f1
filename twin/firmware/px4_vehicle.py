"""What a PX4 vehicle subtracts: the firmware's thermal offset from loaded ``TC_A``/``TC_G``
parameters, and when ``TemperatureCompensationModule`` republishes it (repo PX4/PX4-Autopilot).

Firmware (``TemperatureCompensation::calc_thermal_offsets_3D``, float32): ΔT = clip(T, TMIN,
TMAX) − TREF, offset = X0 + X1·ΔT + X2·ΔT² + X3·ΔT³; ``Accelerometer::Correct`` /
``Gyroscope::Correct`` (src/lib/sensor_calibration/) return rotation · ((raw − thermal_offset −
CAL offset) ∘ scale). The offset reaches them only through ``sensor_correction``, republished by
``TemperatureCompensationModule`` (see :func:`px4_vehicle_offsets`). The fit that makes the
parameters is in :mod:`twin.firmware.px4`.
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from twin.arrays import temperature_rate_c_per_s
from twin.firmware.common import FirmwareCalError
from twin.firmware.px4 import PX4_INSTANCES, SENSOR_PREFIX, check_sensor

REPUBLISH_THRESHOLD_C = 1.0  # update_offsets_accel/_gyro: fabsf(temperature - last_temperature) > 1.0f
CHECK_PERIOD_S = 1.0  # TemperatureCompensationModule::init: ScheduleOnInterval(1_s)
LAST_TEMPERATURE_RESET_C = -100.0  # TemperatureCompensation.h PerSensorData::reset_temperature


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
        Which parameters (``TC_A`` or ``TC_G``).

    Returns
    -------
    ndarray
        (n, 3) float32 offsets [m/s² for the accel, rad/s for the gyro].
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
        Which parameters (``TC_A`` or ``TC_G``).
    device_id : int, optional
        The sensor's device id: the slot is then found as ``set_sensor_id`` does, and no slot
        matching means no compensation (all zeros), as on the vehicle.
    check_period_s : float
        Module period (1 s).
    first_check_s : float, optional
        Time of the first run (default: the first sample); the phase is not in the log.

    Returns
    -------
    ndarray
        (n, 3) float32 offset applied to each sample [m/s² or rad/s]. A sample at a check
        instant was taken before that check's publication, so it still gets the previous offset.

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
    """Bound (°C) on abs(T(sample) − T(published)) after the first publication, on this log.

    At the latest run before a sample either the offset was republished or T had moved ≤ 1 °C
    since; since that run T moved at most max|dT/dt|·(period + longest sample gap). Multiplied by
    the largest |d offset/dT| this bounds the staircase's error against the ideal polynomial.

    Parameters
    ----------
    time_s, temperature_c : array_like
        Sample times [s] and temperature [°C].
    check_period_s : float
        Period of the module's check [s] (PX4: 1 s).

    Returns
    -------
    float
        The bound [°C].
    """
    t = np.asarray(temperature_c, dtype=float)
    time = np.asarray(time_s, dtype=float)
    gaps = np.diff(time)
    # the steepest step between two samples (a centred rate would average it away): a bound
    rate = float(np.max(np.abs(temperature_rate_c_per_s(time, t, method="forward")))) if t.size > 1 else 0.0
    return REPUBLISH_THRESHOLD_C + rate * (check_period_s + (float(np.max(gaps)) if t.size > 1 else 0.0))
