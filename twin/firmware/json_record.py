"""One firmware calibration as typed records: the layout :mod:`twin.firmware.json_cal` writes.

:func:`cal_record` builds the record of a PX4 or ArduPilot accelerometer or gyro calibration, or of
a held-out polynomial, after checking every value as the firmware will hold it. The calibration
JSON (:func:`twin.firmware.json_cal.cal_to_dict`) is this record with the caller's provenance, and
the calibration document of ``twin calibrate`` holds it under each firmware method's ``firmware``
key, so both write the same layout from one builder.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Literal, Union

from twin.firmware.ardupilot import ArduPilotAccelCal, ArduPilotGyroCal
from twin.firmware.ardupilot_parm import check_ardupilot_cal
from twin.firmware.common import CalibrationFileError, ClampedPolynomial, check_polynomial
from twin.firmware.polynomial import HeldoutPolynomialFit
from twin.firmware.px4 import Px4AccelCal, Px4GyroCal
from twin.firmware.px4_params import check_px4_cal
from twin.results import PerAxis

SCHEMA_VERSION = 1
KIND = "accel_temperature_calibration"
KIND_GYRO = "gyro_temperature_calibration"
FORMULA = "offset = sum_k c[k] * (clip(T, tmin, tmax) - tref)^k; corrected = raw - offset"
REFERENCES = {
    "px4": "PX4/PX4-Autopilot Tools/process_sensor_caldata.py; "
           "src/modules/temperature_compensation/TemperatureCompensation.cpp",
    "ardupilot": "ArduPilot/ardupilot Tools/scripts/tempcal_IMU.py; "
                 "libraries/AP_InertialSensor/AP_InertialSensor_tempcal.cpp",
    "polynomial_heldout": "tde-twin twin/firmware/polynomial.py (order chosen on interleaved time blocks)",
}


@dataclass(frozen=True)
class TemperatureRange:
    """The calibrated span and the polynomial's reference temperature.

    Attributes
    ----------
    tmin, tmax : float
        Calibrated span [°C]; the firmware clamps the temperature to it.
    tref : float
        Reference temperature of the polynomial [°C].
    """

    tmin: float
    tmax: float
    tref: float


@dataclass(frozen=True)
class PolynomialTerms:
    """One axis' coefficients as the method states them.

    Attributes
    ----------
    powers : tuple of int
        k of each coefficient, of (T − tref)^k.
    values : tuple of float
        The coefficients, each in its unit.
    units : tuple of str
        ``m/s^2/degC^k`` (accelerometer) or ``rad/s/degC^k`` (gyro), per coefficient.
    """

    powers: tuple[int, ...]
    values: tuple[float, ...]
    units: tuple[str, ...]


@dataclass(frozen=True)
class Px4AccelParameters:
    """PX4 ``TC_An``: the slot and the median removed before the fit.

    Attributes
    ----------
    instance : int
        n in ``TC_An_*`` (0..3).
    device_id : int
        ``TC_An_ID`` (0: not known).
    median_m_s2 : tuple of float or None
        Per-axis median of the filtered data subtracted before the fit [m/s²] (None when read
        back from a parameter file).
    """

    instance: int
    device_id: int
    median_m_s2: tuple[float, ...] | None


@dataclass(frozen=True)
class Px4GyroParameters:
    """PX4 ``TC_Gn``: the slot.

    Attributes
    ----------
    instance : int
        n in ``TC_Gn_*`` (0..3).
    device_id : int
        ``TC_Gn_ID`` (0: not known).
    """

    instance: int
    device_id: int


@dataclass(frozen=True)
class ArduPilotParameters:
    """ArduPilot ``INS_TCALn``: the slot, the offset calibration's temperature and the data span.

    Attributes
    ----------
    instance : int
        n in ``INS_TCALn`` (1..3).
    cal_temp_c : float
        ``INS_ACCn_CALTEMP`` / ``INS_GYRn_CALTEMP`` [°C] (−300: unset).
    data_tmin_c, data_tmax_c : float or None
        Unrounded temperature span of the fitted data [°C].
    parm_scale_factor : float
        What the ``.parm`` multiplies the coefficients by (1e6) [1].
    """

    instance: int
    cal_temp_c: float
    data_tmin_c: float | None
    data_tmax_c: float | None
    parm_scale_factor: float


@dataclass(frozen=True)
class HeldoutPolynomialParameters:
    """The held-out order selection of a polynomial.

    Attributes
    ----------
    order : int
        Chosen order.
    cv_rmse_m_s2, cv_rmse_se_m_s2 : tuple of float
        Mean held-out RMSE per order 0..max and its standard error [m/s²].
    folds, blocks_per_fold : int
        Cross-validation layout.
    """

    order: int
    cv_rmse_m_s2: tuple[float, ...]
    cv_rmse_se_m_s2: tuple[float, ...]
    folds: int
    blocks_per_fold: int


@dataclass(frozen=True)
class FirmwarePolynomial:
    """The same correction as one clamped polynomial, for readers that do not know the method.

    Attributes
    ----------
    formula : str
    tmin, tmax, tref : float
        Clamp span and reference temperature [°C].
    coefficients : PerAxis of tuple of float
        c[k] per axis, ascending powers, in the offset unit per °C^k (m/s² or rad/s).
    """

    formula: str
    tmin: float
    tmax: float
    tref: float
    coefficients: PerAxis[tuple[float, ...]]


MethodParameters = Union[Px4AccelParameters, Px4GyroParameters, ArduPilotParameters, HeldoutPolynomialParameters]


@dataclass(frozen=True)
class FirmwareCalibration:
    """One firmware calibration (``schema_version`` 1): what was fitted, in what units.

    Attributes
    ----------
    schema_version : int
    kind : str
        ``accel_temperature_calibration`` or ``gyro_temperature_calibration``.
    method : str
        ``px4``, ``ardupilot`` or ``polynomial_heldout``.
    reference : str
        The script and firmware source the method follows.
    temperature_c : TemperatureRange
        [°C].
    coefficients : PerAxis of PolynomialTerms
        The method's own numbers (PX4 X0..X3; ArduPilot ACC1..ACC3 unscaled).
    method_parameters : Px4AccelParameters, Px4GyroParameters, ArduPilotParameters or HeldoutPolynomialParameters
    firmware_polynomial : FirmwarePolynomial
    provenance : dict of str to str
        The caller's record (:func:`twin.firmware.json_cal.cal_to_dict` writes it); empty here.
    """

    schema_version: int
    kind: Literal["accel_temperature_calibration", "gyro_temperature_calibration"]
    method: Literal["px4", "ardupilot", "polynomial_heldout"]
    reference: str
    temperature_c: TemperatureRange
    coefficients: PerAxis[PolynomialTerms]
    method_parameters: MethodParameters
    firmware_polynomial: FirmwarePolynomial
    provenance: dict[str, str] = field(default_factory=dict)


def _units(powers, unit: str) -> tuple[str, ...]:
    return tuple(unit if k == 0 else (f"{unit}/degC" if k == 1 else f"{unit}/degC^{k}") for k in powers)


def _polynomial(poly: ClampedPolynomial) -> FirmwarePolynomial:
    return FirmwarePolynomial(FORMULA, poly.tmin_c, poly.tmax_c, poly.tref_c,
                              PerAxis.of(tuple(float(v) for v in c) for c in poly.coefficients))


def cal_record(cal) -> FirmwareCalibration:
    """The record of a PX4 or ArduPilot accel/gyro calibration or a HeldoutPolynomialFit.

    Parameters
    ----------
    cal : Px4AccelCal, Px4GyroCal, ArduPilotAccelCal, ArduPilotGyroCal or HeldoutPolynomialFit
        The calibration.

    Returns
    -------
    FirmwareCalibration
        Empty provenance.

    Raises
    ------
    FirmwareValueError
        A value the firmware could not hold (checked before the record is built).
    CalibrationFileError
        Not a calibration this layout holds.
    """
    kind, unit = (KIND_GYRO, "rad/s") if isinstance(cal, (Px4GyroCal, ArduPilotGyroCal)) else (KIND, "m/s^2")
    if isinstance(cal, (Px4AccelCal, Px4GyroCal)):
        check_px4_cal(cal, require_device_id=False)
        method, tref, powers, coeffs = "px4", cal.tref_c, range(4), cal.x
        params = Px4GyroParameters(cal.instance, cal.device_id) if isinstance(cal, Px4GyroCal) else \
            Px4AccelParameters(cal.instance, cal.device_id,
                               None if cal.median_m_s2 is None else tuple(cal.median_m_s2))
    elif isinstance(cal, (ArduPilotAccelCal, ArduPilotGyroCal)):
        check_ardupilot_cal(cal)
        method, tref, powers, coeffs = "ardupilot", cal.polynomial.tref_c, range(1, 4), cal.terms
        params = ArduPilotParameters(cal.instance, cal.cal_temp_c, cal.data_tmin_c, cal.data_tmax_c, 1.0e6)
    elif isinstance(cal, HeldoutPolynomialFit):
        check_polynomial(cal.polynomial, "polynomial_heldout")
        method, tref, powers, coeffs = "polynomial_heldout", cal.tref_c, range(cal.order + 1), cal.coefficients
        params = HeldoutPolynomialParameters(cal.order, tuple(cal.cv_rmse), tuple(cal.cv_rmse_se), cal.folds,
                                             cal.blocks_per_fold)
    else:
        raise CalibrationFileError(f"cannot write a {type(cal).__name__} as a calibration JSON")
    terms = PerAxis.of(PolynomialTerms(tuple(powers), tuple(float(v) for v in c), _units(powers, unit))
                       for c in coeffs)
    return FirmwareCalibration(SCHEMA_VERSION, kind, method, REFERENCES[method],
                               TemperatureRange(cal.tmin_c, cal.tmax_c, tref), terms, params,
                               _polynomial(cal.polynomial))
