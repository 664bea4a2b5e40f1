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
from twin.firmware.common import AXES, CalibrationFileError
from twin.firmware.json_record import KIND, KIND_GYRO, REFERENCES, SCHEMA_VERSION, cal_record
from twin.firmware.polynomial import HeldoutPolynomialFit
from twin.firmware.px4 import Px4AccelCal, Px4GyroCal
from twin.firmware.px4_params import check_px4_cal
from twin.io import atomic_write_text, read_json
from twin.results import to_json


def cal_to_dict(cal, provenance: Mapping | None = None) -> dict:
    """The JSON document (as a dict) for a PX4 or ArduPilot accel/gyro calibration or a HeldoutPolynomialFit.

    Parameters
    ----------
    cal : Px4AccelCal, Px4GyroCal, ArduPilotAccelCal, ArduPilotGyroCal or HeldoutPolynomialFit
        The calibration.
    provenance : mapping, optional
        Caller-supplied record; must be plain JSON.

    Returns
    -------
    dict
        Schema version, kind, method, temperatures [°C], coefficients with their units (m/s^2 or
        rad/s per °C^k), method parameters, the firmware polynomial and the provenance.

    Raises
    ------
    FirmwareValueError
        A value the firmware could not hold (checked before the document is built).
    """
    # the record (twin.firmware.json_record) holds the layout; only the caller's provenance is added here
    doc = {**to_json(cal_record(cal)), "provenance": dict(provenance or {})}
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
        Output ``.json`` file.
    cal : Px4AccelCal, ArduPilotAccelCal or HeldoutPolynomialFit
        The calibration (the gyro ones too).
    provenance : mapping, optional
        Caller-supplied record (input file hashes, software version, validation figures); must be
        plain JSON.

    Returns
    -------
    Path
        The file written.

    Raises
    ------
    FirmwareValueError
        A value the firmware could not hold; nothing is written.
    """
    text = json.dumps(cal_to_dict(cal, provenance), indent=2, allow_nan=False) + "\n"
    return atomic_write_text(Path(path), text)


def cal_from_dict(doc: Mapping, source: str = "<json>"):
    """Rebuild the calibration object from a document written by :func:`cal_to_dict`.

    Parameters
    ----------
    doc : mapping
        The parsed JSON document.
    source : str
        Name in messages.

    Returns
    -------
    Px4AccelCal, Px4GyroCal, ArduPilotAccelCal, ArduPilotGyroCal or HeldoutPolynomialFit
        The calibration, checked as the firmware would hold it.
    """
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
    """A calibration JSON read back: the calibration object, its method and the provenance.

    Attributes
    ----------
    cal : object
        The calibration (:func:`cal_from_dict`).
    method : str
        ``"px4"``, ``"ardupilot"`` or ``"polynomial_heldout"``.
    schema_version : int
        Version of the document's schema.
    provenance : dict
        The caller's record.
    """

    cal: object
    method: str
    schema_version: int
    provenance: dict


def read_json_cal(path) -> JsonCalibration:
    """Read a calibration JSON written by :func:`write_json_cal`.

    Parameters
    ----------
    path : str or Path
        The file.

    Returns
    -------
    JsonCalibration
        The calibration, its method, schema version and provenance.
    """
    path = Path(path)
    doc = read_json(path, "calibration JSON", CalibrationFileError)
    cal = cal_from_dict(doc, str(path))
    return JsonCalibration(cal, str(doc["method"]), int(doc["schema_version"]), dict(doc.get("provenance") or {}))
