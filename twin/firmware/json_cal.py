"""Versioned JSON for any of the calibrations: what was fitted, in what units, and from what.

Layout (``schema_version`` 1)::

    {"schema_version": 1, "kind": "accel_temperature_calibration", "method": "px4" | "ardupilot" |
     "polynomial_heldout", "reference": <script/firmware the method follows>,
     "temperature_c": {"tmin": …, "tmax": …, "tref": …},
     "coefficients": {"x": {"powers": [k…], "values": […], "units": ["m/s^2/degC^k"…]}, "y": …, "z": …},
     "method_parameters": {…method-specific…},
     "firmware_polynomial": {"formula": …, "tmin": …, "tmax": …, "tref": …, "coefficients": {"x": […]…}},
     "provenance": {…as passed by the caller: input hashes, software version, validation figures…}}

``coefficients`` are the method's own numbers (PX4 X0..X3; ArduPilot ACC1..ACC3 unscaled, not
× 1e6); ``firmware_polynomial`` is the same correction as one clamped polynomial, for readers that
do not know the method. Floats are written by ``json`` (shortest repr), so they read back exactly.
A gyro calibration (PX4 ``TC_Gn``, ArduPilot ``INS_TCALn_GYR``) has ``"kind":
"gyro_temperature_calibration"`` and units in rad/s. Values are checked as the firmware would
hold them before anything is written (float32, TMIN < TMAX, the method's degree and instances);
a PX4 device id of 0 is allowed here, as a record, and refused by the ``.params`` writer.
"""

from __future__ import annotations

import json
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path

from twin.firmware.ardupilot import ArduPilotAccelCal, ArduPilotGyroCal
from twin.firmware.ardupilot_parm import check_ardupilot_cal
from twin.firmware.common import AXES, CalibrationFileError, ClampedPolynomial, check_polynomial
from twin.firmware.polynomial import HeldoutPolynomialFit
from twin.firmware.px4 import Px4AccelCal, Px4GyroCal
from twin.firmware.px4_params import check_px4_cal
from twin.io import atomic_write_text, read_json

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


def _units(powers, unit: str = "m/s^2") -> list[str]:
    return [unit if k == 0 else (f"{unit}/degC" if k == 1 else f"{unit}/degC^{k}") for k in powers]


def _axes_block(per_axis, powers, unit: str = "m/s^2") -> dict:
    return {AXES[i]: {"powers": list(powers), "values": [float(v) for v in c], "units": _units(powers, unit)}
            for i, c in enumerate(per_axis)}


def _poly_block(poly: ClampedPolynomial) -> dict:
    return {"formula": FORMULA, "tmin": poly.tmin_c, "tmax": poly.tmax_c, "tref": poly.tref_c,
            "coefficients": {AXES[i]: [float(v) for v in c] for i, c in enumerate(poly.coefficients)}}


def cal_to_dict(cal, provenance: Mapping | None = None) -> dict:
    """The JSON document (as a dict) for a PX4 or ArduPilot accel/gyro calibration or a HeldoutPolynomialFit.

    Raises
    ------
    FirmwareValueError
        A value the firmware could not hold (checked before the document is built).
    """
    kind, unit = (KIND_GYRO, "rad/s") if isinstance(cal, (Px4GyroCal, ArduPilotGyroCal)) else (KIND, "m/s^2")
    if isinstance(cal, (Px4AccelCal, Px4GyroCal)):
        check_px4_cal(cal, require_device_id=False)
        method, tref, powers, coeffs = "px4", cal.tref_c, range(4), cal.x
        extra = {"instance": cal.instance, "device_id": cal.device_id}
        if isinstance(cal, Px4AccelCal):
            extra["median_m_s2"] = None if cal.median_m_s2 is None else list(cal.median_m_s2)
    elif isinstance(cal, (ArduPilotAccelCal, ArduPilotGyroCal)):
        check_ardupilot_cal(cal)
        method, tref, powers, coeffs = "ardupilot", cal.polynomial.tref_c, range(1, 4), cal.terms
        extra = {"instance": cal.instance, "cal_temp_c": cal.cal_temp_c,
                 "data_tmin_c": cal.data_tmin_c, "data_tmax_c": cal.data_tmax_c, "parm_scale_factor": 1.0e6}
    elif isinstance(cal, HeldoutPolynomialFit):
        check_polynomial(cal.polynomial, "polynomial_heldout")
        method, tref, powers, coeffs = "polynomial_heldout", cal.tref_c, range(cal.order + 1), cal.coefficients
        extra = {"order": cal.order, "cv_rmse_m_s2": list(cal.cv_rmse), "cv_rmse_se_m_s2": list(cal.cv_rmse_se),
                 "folds": cal.folds, "blocks_per_fold": cal.blocks_per_fold}
    else:
        raise CalibrationFileError(f"cannot write a {type(cal).__name__} as a calibration JSON")
    doc = {"schema_version": SCHEMA_VERSION, "kind": kind, "method": method, "reference": REFERENCES[method],
           "temperature_c": {"tmin": cal.tmin_c, "tmax": cal.tmax_c, "tref": tref},
           "coefficients": _axes_block(coeffs, powers, unit), "method_parameters": extra,
           "firmware_polynomial": _poly_block(cal.polynomial), "provenance": dict(provenance or {})}
    try:
        json.dumps(doc, allow_nan=False)
    except (TypeError, ValueError) as exc:
        raise CalibrationFileError(f"provenance is not plain JSON (numbers, strings, lists, dicts): {exc}") from None
    return doc


def write_json_cal(path, cal, provenance: Mapping | None = None) -> Path:
    """Write the calibration JSON atomically to ``path``; return the path.

    Parameters
    ----------
    path : path-like
    cal : Px4AccelCal, ArduPilotAccelCal or HeldoutPolynomialFit
    provenance : mapping, optional
        Caller-supplied record (input file hashes, software version, validation figures); must be
        plain JSON.

    Raises
    ------
    FirmwareValueError
        A value the firmware could not hold; nothing is written.
    """
    text = json.dumps(cal_to_dict(cal, provenance), indent=2, allow_nan=False) + "\n"
    return atomic_write_text(Path(path), text)


def cal_from_dict(doc: Mapping, source: str = "<json>"):
    """Rebuild the calibration object from a document written by :func:`cal_to_dict`."""
    if not isinstance(doc, Mapping):
        raise CalibrationFileError(f"{source}: expected a JSON object, got {type(doc).__name__}")
    if doc.get("schema_version") != SCHEMA_VERSION or doc.get("kind") not in (KIND, KIND_GYRO):
        raise CalibrationFileError(f"{source}: not a schema_version {SCHEMA_VERSION} {KIND} document "
                                   f"(schema_version={doc.get('schema_version')!r}, kind={doc.get('kind')!r})")
    try:
        temp, extra, method = doc["temperature_c"], doc["method_parameters"], doc["method"]
        coeffs = tuple(tuple(float(v) for v in doc["coefficients"][a]["values"]) for a in AXES
                       if a in doc["coefficients"])
        gyro = doc["kind"] == KIND_GYRO
        if method == "px4":
            args = (int(extra["instance"]), int(extra["device_id"]), float(temp["tmin"]), float(temp["tmax"]),
                    float(temp["tref"]), coeffs)
            median = extra.get("median_m_s2")
            cal = Px4GyroCal(*args) if gyro else Px4AccelCal(
                *args, None if median is None else tuple(float(m) for m in median))
            check_px4_cal(cal, require_device_id=False)  # what PX4 can hold, before anything is computed from it
            return cal
        if method == "ardupilot":
            cls = ArduPilotGyroCal if gyro else ArduPilotAccelCal
            cal = cls(int(extra["instance"]), float(temp["tmin"]), float(temp["tmax"]), coeffs,
                      float(extra["cal_temp_c"]), extra.get("data_tmin_c"), extra.get("data_tmax_c"))
            check_ardupilot_cal(cal)  # three terms per axis, or its polynomial cannot be formed
            return cal
        if method == "polynomial_heldout":
            return HeldoutPolynomialFit(int(extra["order"]), coeffs, float(temp["tref"]), float(temp["tmin"]),
                                        float(temp["tmax"]), tuple(extra["cv_rmse_m_s2"]),
                                        tuple(extra["cv_rmse_se_m_s2"]), int(extra["folds"]),
                                        int(extra["blocks_per_fold"]))
    except (KeyError, TypeError, ValueError) as exc:
        raise CalibrationFileError(f"{source}: malformed calibration document ({type(exc).__name__}: {exc})") from None
    raise CalibrationFileError(f"{source}: unknown method {method!r}; expected one of {sorted(REFERENCES)}")


@dataclass(frozen=True)
class JsonCalibration:
    """A calibration JSON read back: the calibration object, its method and the provenance."""

    cal: object
    method: str
    schema_version: int
    provenance: dict


def read_json_cal(path) -> JsonCalibration:
    """Read a calibration JSON written by :func:`write_json_cal`."""
    path = Path(path)
    doc = read_json(path, "calibration JSON", CalibrationFileError)
    cal = cal_from_dict(doc, str(path))
    return JsonCalibration(cal, str(doc["method"]), int(doc["schema_version"]), dict(doc.get("provenance") or {}))
