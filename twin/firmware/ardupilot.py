"""ArduPilot IMU temperature calibration: the fit of ``Tools/scripts/tempcal_IMU.py`` and the
correction of ``libraries/AP_InertialSensor/AP_InertialSensor_tempcal.cpp`` (repo ArduPilot/ardupilot).

Fit, as the script does for the accelerometer (``IMU`` log messages, m/s²):

1. A moving average over 2 s (``IMUData.Filter(2)``) of T, X, Y, Z and time: window =
   ``int(n_samples / duration_s) * 2`` samples, applied only when > 1, "valid" part only.
2. ``INS_TCALn_TMIN``/``TMAX`` = min/max of the filtered temperature, written with ``%.1f``.
3. ``np.polyfit(T − 35, accel − ofs, 3)`` per axis (``POLY_ORDER = 3``, ``TEMP_REF = 35.0``).
   The fit has a constant term, but only the 1st–3rd order coefficients are written
   (``INS_TCALn_ACC{1,2,3}_{X,Y,Z}`` × ``SCALE_FACTOR = 1e6``): the constant belongs to the
   ordinary accel offsets. ``ofs`` (mean, or the value at INS_ACCn_CALTEMP) only moves that
   dropped constant, so it does not change any written number.

The gyro (``IMU.GyrX..Z``, rad/s → ``INS_TCALn_GYR{1,2,3}_{X,Y,Z}``) is fitted the same way from
the same filtered data, ``np.polyfit(T − 35, gyro, 3)`` with no offset removed (the constant is
dropped all the same); TMIN/TMAX are the IMU's, shared by accel and gyro.

Firmware (``TCal::correct_sensor``, float): T and cal_temp are both clamped to [TMIN, TMAX];
P(d) = (c1 + (c2 + c3·d)·d)·d·1e-6; v −= P(T − 35); v += P(cal_temp − 35) — the correction is
zero at the calibration temperature, where the ordinary offsets were measured. cal_temp is
``INS_ACCn_CALTEMP`` for the accel (``correct_accel``) and ``INS_GYRn_CALTEMP`` for the gyro
(``correct_gyro``, called with ``_imu.caltemp_gyro(instance)``), both −300 when unset. It runs
before offsets, scaling and board rotation (``AP_InertialSensor_Backend::_rotate_and_correct_accel``
/ ``_rotate_and_correct_gyro``), on every sample: unlike PX4 nothing is held between updates.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from twin.firmware.common import (
    CalibrationRangeError,
    ClampedPolynomial,
    FirmwareCalError,
    FirmwareValueError,
    as_samples,
    as_temperature,
    check_instance,
)
from twin.firmware.lstsq import polyfit_rows

TEMP_REF_C = 35.0  # tempcal_IMU.py TEMP_REF and AP_InertialSensor_tempcal.cpp TEMP_REFERENCE
SCALE_FACTOR = 1.0e6  # tempcal_IMU.py / AP_InertialSensor_tempcal.cpp SCALE_FACTOR
TEMP_RANGE_MIN_C = 10.0  # AP_InertialSensor_tempcal.cpp TEMP_RANGE_MIN; INS_TCALn_TMAX doc: ≥ 10 °C above TMIN
CALTEMP_UNSET_C = -300.0  # default of INS_ACCn_CALTEMP / INS_GYRn_CALTEMP (no calibration recorded)
FILTER_WIDTH_S = 2  # tempcal_IMU.py: data.Filter(2)
AP_INSTANCES = (1, 3)  # INS_TCAL1..INS_TCAL3
SENSOR_TERM = {"accel": "ACC", "gyro": "GYR"}  # INS_TCALn_ACCk_* / _GYRk_*, INS_ACCn_/INS_GYRn_CALTEMP


class ArduPilotCalBase:
    """What the accel and gyro ``INS_TCALn`` calibrations share: names and the anchored cubic."""

    sensor: ClassVar[str] = "accel"

    @property
    def terms(self) -> tuple[tuple[float, float, float], ...]:
        """Per axis the unscaled coefficients of (T − 35)^1..3 (``acc`` or ``gyr``)."""
        return self.acc if self.sensor == "accel" else self.gyr

    @property
    def caltemp_name(self) -> str:
        """``INS_ACC{n}_CALTEMP`` or ``INS_GYR{n}_CALTEMP``, the anchor the firmware reads."""
        return f"INS_{SENSOR_TERM[self.sensor]}{self.instance}_CALTEMP"

    @property
    def polynomial(self) -> ClampedPolynomial:
        """The firmware's offset −(correction) as one clamped cubic about 35 °C.

        offset(T) = P(clip(T) − 35) − P(clip(cal_temp) − 35): the constant term is the anchor.
        """
        anchor = float(np.clip(self.cal_temp_c, self.tmin_c, self.tmax_c)) - TEMP_REF_C
        coeffs = []
        for a1, a2, a3 in self.terms:
            c0 = -((a1 + (a2 + a3 * anchor) * anchor) * anchor)
            coeffs.append((c0, a1, a2, a3))
        return ClampedPolynomial(self.tmin_c, self.tmax_c, TEMP_REF_C, tuple(coeffs))

    def offset(self, temperature_c) -> np.ndarray:
        """Predicted offset (n, 3) the firmware subtracts (zero at cal_temp_c), in the sensor's unit.

        Parameters
        ----------
        temperature_c : float or array_like
            IMU temperature [°C].

        Returns
        -------
        ndarray
            Offset [m/s² for the accel, rad/s for the gyro].

        References
        ----------
        ArduPilot ``TCal::correct_sensor`` (AP_InertialSensor_tempcal.cpp), as the module docstring.
        """
        return self.polynomial.offset(temperature_c)


@dataclass(frozen=True)
class ArduPilotAccelCal(ArduPilotCalBase):
    """One IMU's ``INS_TCAL{instance}_*`` accelerometer calibration (ArduPilot tempcal_IMU.py).

    Attributes
    ----------
    instance : int
        n in ``INS_TCALn`` (1..3).
    tmin_c, tmax_c : float
        ``INS_TCALn_TMIN``/``TMAX`` as written (rounded to 0.1 °C by the script's ``%.1f``), so the
        prediction clamps where the firmware will.
    acc : tuple of tuple of float
        ``acc[axis][k-1]`` = coefficient of (T − 35)^k, k = 1..3, in m/s²/°C^k (unscaled: the
        ``.parm`` holds these × 1e6).
    cal_temp_c : float
        ``INS_ACCn_CALTEMP``, the temperature the accel offsets were calibrated at; −300 (unset)
        is clamped to TMIN by the firmware like any other value.
    data_tmin_c, data_tmax_c : float
        Unrounded temperature span of the fitted data (°C).
    """

    instance: int
    tmin_c: float
    tmax_c: float
    acc: tuple[tuple[float, float, float], ...]
    cal_temp_c: float = CALTEMP_UNSET_C
    data_tmin_c: float | None = None
    data_tmax_c: float | None = None
    sensor: ClassVar[str] = "accel"

    def offset_m_s2(self, temperature_c) -> np.ndarray:
        """Predicted offset (n, 3) in m/s² that the firmware subtracts (zero at cal_temp_c).

        Parameters
        ----------
        temperature_c : float or array_like
            IMU temperature [°C].

        Returns
        -------
        ndarray
            Offset [m/s²], as :meth:`offset`.
        """
        return self.offset(temperature_c)

    def correct(self, accel_m_s2, temperature_c) -> np.ndarray:
        """Corrected reading (m/s², before INS_ACCOFFS/INS_ACCSCAL and board rotation).

        Parameters
        ----------
        accel_m_s2 : array_like
            Raw reading, (n, 3) or (3,) [m/s²].
        temperature_c : float or array_like
            IMU temperature [°C].

        Returns
        -------
        ndarray
            Reading minus :meth:`offset_m_s2` [m/s²], in float64.
        """
        return np.asarray(accel_m_s2, dtype=float) - self.offset_m_s2(temperature_c)


@dataclass(frozen=True)
class ArduPilotGyroCal(ArduPilotCalBase):
    """One IMU's ``INS_TCAL{instance}_GYR*`` gyro calibration (ArduPilot tempcal_IMU.py).

    Attributes
    ----------
    instance : int
        n in ``INS_TCALn`` (1..3).
    tmin_c, tmax_c : float
        The IMU's ``INS_TCALn_TMIN``/``TMAX`` (shared with the accel), as written.
    gyr : tuple of tuple of float
        ``gyr[axis][k-1]`` = coefficient of (T − 35)^k in rad/s/°C^k (the ``.parm`` holds × 1e6).
    cal_temp_c : float
        ``INS_GYRn_CALTEMP``, the temperature of the gyro offset calibration (−300 unset).
    data_tmin_c, data_tmax_c : float
        Unrounded temperature span of the fitted data (°C).
    """

    instance: int
    tmin_c: float
    tmax_c: float
    gyr: tuple[tuple[float, float, float], ...]
    cal_temp_c: float = CALTEMP_UNSET_C
    data_tmin_c: float | None = None
    data_tmax_c: float | None = None
    sensor: ClassVar[str] = "gyro"

    def offset_rad_s(self, temperature_c) -> np.ndarray:
        """Predicted gyro offset (n, 3) in rad/s that the firmware subtracts (zero at cal_temp_c).

        Parameters
        ----------
        temperature_c : float or array_like
            IMU temperature [°C].

        Returns
        -------
        ndarray
            Offset [rad/s], as :meth:`offset`.
        """
        return self.offset(temperature_c)

    def correct(self, gyro_rad_s, temperature_c) -> np.ndarray:
        """Corrected rate (rad/s, before INS_GYROFFS and board rotation).

        Parameters
        ----------
        gyro_rad_s : array_like
            Raw rate, (n, 3) or (3,) [rad/s].
        temperature_c : float or array_like
            IMU temperature [°C].

        Returns
        -------
        ndarray
            Rate minus :meth:`offset_rad_s` [rad/s], in float64.
        """
        return np.asarray(gyro_rad_s, dtype=float) - self.offset_rad_s(temperature_c)


def moving_average(values: np.ndarray, window: int) -> np.ndarray:
    """``IMUData.moving_average`` of tempcal_IMU.py: cumulative-sum mean, valid part (n − w + 1).

    Parameters
    ----------
    values : ndarray
        Samples along axis 0 [any unit].
    window : int
        Window [samples].

    Returns
    -------
    ndarray
        Means over each full window [unit of ``values``].
    """
    ret = np.cumsum(np.asarray(values, dtype=float), axis=0)
    ret[window:] = ret[window:] - ret[:-window]
    return ret[window - 1:] / window


def _filtered_cubic(temperature_c, samples, name: str, time_s, filter_width_s: int):
    """(tmin, tmax, terms): the script's filter, range check and ``polyfit`` about 35 °C."""
    t = as_temperature(temperature_c)
    a = as_samples(samples, t.size, name)
    if time_s is not None:
        time = as_samples(time_s, t.size, "time_s", axes=None)
        duration = float(time[-1] - time[0])
        if not duration > 0:
            raise FirmwareCalError("time_s must increase from first to last sample")
        window = int(t.size / duration) * int(filter_width_s)
        if window >= t.size:
            raise FirmwareCalError(f"the {filter_width_s} s moving average needs more than {window} samples; "
                                   f"got {t.size}")
        if window > 1:
            t, a = moving_average(t, window), moving_average(a, window)
    tmin, tmax = float(np.min(t)), float(np.max(t))
    if tmax - tmin < TEMP_RANGE_MIN_C:
        raise CalibrationRangeError(
            f"ArduPilot temperature calibration needs at least {TEMP_RANGE_MIN_C:g} °C of range "
            f"(TEMP_RANGE_MIN in AP_InertialSensor_tempcal.cpp); the data span {tmax - tmin:.1f} °C "
            f"({tmin:.1f} to {tmax:.1f} °C)")
    # the script's three polyfits share their abscissa: one least squares with three right-hand
    # sides, reduced a chunk of rows at a time (twin.firmware.lstsq: np.polyfit's answer to rounding)
    p = polyfit_rows(t - TEMP_REF_C, a[:, :3], 3)  # (4, 3); p[3] (constant) is not written, as in the script
    return tmin, tmax, tuple((float(p[2, k]), float(p[1, k]), float(p[0, k])) for k in range(3))


def fit_ardupilot(temperature_c, accel_m_s2, *, time_s=None, cal_temp_c: float | None = None,
                  instance: int = 1, filter_width_s: int = FILTER_WIDTH_S) -> ArduPilotAccelCal:
    """Fit ``INS_TCAL{instance}_ACC*`` as ArduPilot Tools/scripts/tempcal_IMU.py does.

    Parameters
    ----------
    temperature_c : (n,) array
        IMU temperature (``IMU.T``), °C.
    accel_m_s2 : (n, 3) array
        Accelerometer in the sensor frame, m/s², the board still.
    time_s : (n,) array, optional
        Sample times; when given, the script's 2 s moving average is applied first.
    cal_temp_c : float, optional
        ``INS_ACCn_CALTEMP`` of the board (the temperature of its accel calibration); None means
        unset (−300, which the firmware clamps to TMIN).
    instance : int
        n in ``INS_TCALn`` (1..3).
    filter_width_s : int
        Moving-average width (the script's 2 s).

    Returns
    -------
    ArduPilotAccelCal
        TMIN/TMAX [°C] and the cubic's coefficients [m/s²/°C^k].

    Raises
    ------
    CalibrationRangeError
        If the (filtered) temperature spans less than 10 °C, the firmware's minimum
        (``TEMP_RANGE_MIN`` in AP_InertialSensor_tempcal.cpp; the script itself does not check).
    """
    n = check_instance(instance, *AP_INSTANCES, "INS_TCAL{}")
    tmin, tmax, acc = _filtered_cubic(temperature_c, accel_m_s2, "accel_m_s2", time_s, filter_width_s)
    cal_temp = CALTEMP_UNSET_C if cal_temp_c is None else float(cal_temp_c)
    # TMIN/TMAX as the script writes them ('%.1f'), so predictions clamp where the firmware does
    return ArduPilotAccelCal(n, float("%.1f" % tmin), float("%.1f" % tmax), acc, cal_temp, tmin, tmax)


def fit_ardupilot_gyro(temperature_c, gyro_rad_s, *, time_s=None, cal_temp_c: float | None = None,
                       instance: int = 1, filter_width_s: int = FILTER_WIDTH_S) -> ArduPilotGyroCal:
    """Fit ``INS_TCAL{instance}_GYR*`` as ArduPilot Tools/scripts/tempcal_IMU.py does.

    Parameters
    ----------
    temperature_c : (n,) array
        IMU temperature (``IMU.T``), °C: the same samples as the accel fit, so TMIN/TMAX agree.
    gyro_rad_s : (n, 3) array
        Gyro in the sensor frame, rad/s, the board still.
    time_s : (n,) array, optional
        Sample times; when given, the script's 2 s moving average is applied first.
    cal_temp_c : float, optional
        ``INS_GYRn_CALTEMP`` (temperature of the gyro offset calibration); None means unset (−300).
    instance : int
        n in ``INS_TCALn`` (1..3).
    filter_width_s : int
        Moving-average width (the script's 2 s).

    Returns
    -------
    ArduPilotGyroCal
        TMIN/TMAX [°C] and the cubic's coefficients [rad/s/°C^k].

    Notes
    -----
    ``np.polyfit(T − 35, gyro, 3)`` with nothing removed first; the constant is not written. The
    firmware anchors the correction at INS_GYRn_CALTEMP (``correct_gyro``), so only the change
    of bias since the gyro calibration is removed.
    """
    n = check_instance(instance, *AP_INSTANCES, "INS_TCAL{}")
    tmin, tmax, gyr = _filtered_cubic(temperature_c, gyro_rad_s, "gyro_rad_s", time_s, filter_width_s)
    cal_temp = CALTEMP_UNSET_C if cal_temp_c is None else float(cal_temp_c)
    return ArduPilotGyroCal(n, float("%.1f" % tmin), float("%.1f" % tmax), gyr, cal_temp, tmin, tmax)


def firmware_correct_ardupilot(values: Mapping[str, float], accel_m_s2, temperature_c,
                               instance: int = 1, cal_temp_c: float | None = None, *,
                               sensor: str = "accel") -> np.ndarray:
    """What ArduPilot does to a reading with these parameters loaded, in float32 like the firmware.

    Follows ``TCal::correct_sensor`` / ``polynomial_eval`` (ArduPilot/ardupilot,
    libraries/AP_InertialSensor/AP_InertialSensor_tempcal.cpp): unchanged unless
    ``INS_TCALn_ENABLE`` is 1; T and cal_temp clamped to [TMIN, TMAX]; tdiff = (float)(T − 35.0);
    P = (c0 + (c1 + c2·tdiff)·tdiff)·tdiff·1e-6f with c_k = ``INS_TCALn_ACC{k+1}`` (``GYR`` for
    the gyro); v −= P(T − 35); v += P(cal_temp − 35).

    Parameters
    ----------
    values : mapping
        Parameter name → value (e.g. ``read_ardupilot_parm(path)``).
    accel_m_s2 : (n, 3) or (3,) array
        Raw reading, m/s² (rad/s for the gyro).
    temperature_c : (n,) array or float
        IMU temperature, °C.
    cal_temp_c : float, optional
        Overrides ``INS_ACCn_CALTEMP`` / ``INS_GYRn_CALTEMP`` (else taken from ``values``, else −300).
    sensor : {"accel", "gyro"}

    Returns
    -------
    (n, 3) float32 array: the corrected reading.
    """
    if sensor not in SENSOR_TERM:
        raise FirmwareValueError(f"sensor {sensor!r} is not one ArduPilot compensates; expected 'accel' or 'gyro'")
    f32 = np.float32
    t = np.atleast_1d(np.asarray(temperature_c, dtype=f32))
    v = np.broadcast_to(np.asarray(accel_m_s2, dtype=f32), t.shape + (3,)).copy()
    p = f"INS_TCAL{int(instance)}_"
    if int(values.get(p + "ENABLE", 0)) != 1:
        return v
    term = SENSOR_TERM[sensor]
    if cal_temp_c is None:
        cal_temp_c = values.get(f"INS_{term}{int(instance)}_CALTEMP", CALTEMP_UNSET_C)
    tmin, tmax = f32(values[p + "TMIN"]), f32(values[p + "TMAX"])
    coeff = np.array([[values[f"{p}{term}{k}_{ax}"] for ax in "XYZ"] for k in (1, 2, 3)], dtype=f32)

    def poly(temp: np.ndarray) -> np.ndarray:
        tdiff = (np.minimum(np.maximum(temp, tmin), tmax).astype(np.float64) - TEMP_REF_C).astype(f32)
        d = tdiff[..., None]
        return ((coeff[0] + (coeff[1] + coeff[2] * d) * d) * d) * f32(1.0e-6)

    v -= poly(t)
    v += poly(np.full(t.shape, cal_temp_c, dtype=f32))
    return v


def ardupilot_vehicle_correct(values: Mapping[str, float], reading, temperature_c, instance: int = 1,
                              cal_temp_c: float | None = None, sensor: str = "accel") -> np.ndarray:
    """The reading (n, 3) as the vehicle corrects it with the written file loaded (float32).

    ArduPilot applies ``correct_accel``/``correct_gyro`` to every sample with the current
    temperature (no held value, unlike PX4's republish rule), re-referenced at
    ``INS_ACCn_CALTEMP``/``INS_GYRn_CALTEMP``: this is :func:`firmware_correct_ardupilot`.

    Parameters
    ----------
    values : mapping
        Parameter name → value (e.g. ``read_ardupilot_parm(path)``).
    reading : array_like
        Raw reading, (n, 3) or (3,) [m/s², rad/s for the gyro].
    temperature_c : float or array_like
        IMU temperature [°C].
    instance : int
        n in ``INS_TCALn``.
    cal_temp_c : float, optional
        Overrides ``INS_ACCn_CALTEMP`` / ``INS_GYRn_CALTEMP`` [°C].
    sensor : {"accel", "gyro"}
        Which calibration applies.

    Returns
    -------
    ndarray
        Corrected reading, float32 [unit of ``reading``].
    """
    return firmware_correct_ardupilot(values, reading, temperature_c, instance, cal_temp_c, sensor=sensor)


def ardupilot_vehicle_offsets(values: Mapping[str, float], temperature_c, instance: int = 1,
                              cal_temp_c: float | None = None, sensor: str = "accel") -> np.ndarray:
    """The offset (n, 3) the vehicle subtracts, comparable with ``cal.offset(T)``: −correct(0).

    Parameters
    ----------
    values : mapping
        Parameter name → value.
    temperature_c : float or array_like
        IMU temperature [°C].
    instance, cal_temp_c, sensor
        As :func:`ardupilot_vehicle_correct`.

    Returns
    -------
    ndarray
        Offset, float32 [m/s², rad/s for the gyro].
    """
    t = np.atleast_1d(np.asarray(temperature_c, dtype=float))
    return -ardupilot_vehicle_correct(values, np.zeros(3), t, instance, cal_temp_c, sensor)
