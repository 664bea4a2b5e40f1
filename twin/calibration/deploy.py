"""From a calibration document to what runs on the vehicle: firmware files, and the compensated log.

``export_calibration`` writes PX4 ``.params``, ArduPilot ``.parm``, the firmware JSON or a C header
from the document ``twin calibrate`` wrote; ``correction_g`` is the correction a method applies
to a log, the same arithmetic ``twin apply`` and the round-trip tests use.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from twin.calibration.lag import as_log, lagged_c, make_X
from twin.calibration.workflow import SCHEMA, SCHEMA_VERSION
from twin.errors import TwinError
from twin.firmware import (
    G0_M_S2,
    ardupilot_parm_text,
    c_header,
    cal_from_dict,
    cal_to_dict,
    px4_params_text,
)
from twin.io import atomic_write_text, read_text

FORMATS = ("px4", "ardupilot", "json", "c")


class CalibrationDocumentError(TwinError):
    """A calibration document is unreadable, of another schema, or lacks what is asked of it."""


def read_calibration(path: str | Path) -> dict:
    """The document ``twin calibrate -o`` wrote, checked for its schema."""
    path = Path(path)
    try:
        doc = json.loads(read_text(path, "calibration document", CalibrationDocumentError))
    except json.JSONDecodeError as exc:
        raise CalibrationDocumentError(f"{path}:{exc.lineno}: not JSON ({exc.msg})") from None
    if not isinstance(doc, dict) or doc.get("schema") != SCHEMA or doc.get("schema_version") != SCHEMA_VERSION:
        raise CalibrationDocumentError(f"{path}: not a '{SCHEMA}' document of schema_version {SCHEMA_VERSION}")
    if not doc.get("imus"):
        raise CalibrationDocumentError(f"{path}: key 'imus' is empty; expected at least one calibrated IMU")
    return doc


def imu_entry(doc: dict, instance: int | None, device_id: int | None = None, source: str = "calibration") -> dict:
    """The document's entry for an IMU instance (the only one when ``instance`` is None); a
    ``device_id`` that differs from the calibrated one is an error naming both."""
    imus = doc["imus"]
    if instance is None:
        if len(imus) > 1:
            raise CalibrationDocumentError(f"{source}: holds IMU instances {[i['instance'] for i in imus]}; "
                                           "name one with --imu")
        entry = imus[0]
    else:
        entry = next((i for i in imus if i["instance"] == instance), None)
        if entry is None:
            raise CalibrationDocumentError(f"{source}: no IMU instance {instance}; it holds "
                                           f"{[i['instance'] for i in imus]}")
    calibrated = entry.get("device_id")
    if device_id is not None and calibrated is not None and int(device_id) != int(calibrated):
        raise CalibrationDocumentError(f"{source}: calibrated for device_id {calibrated} (instance "
                                       f"{entry['instance']}), but the log's IMU has device_id {device_id}")
    return entry


def method_entry(entry: dict, method: str | None, target: str = "c") -> tuple[str, dict]:
    """(name, data) of ``method``, or of the recommended one for ``target`` when None."""
    name = method or entry["recommended"][target]
    if name not in entry["methods"]:
        raise CalibrationDocumentError(f"method {name!r} is not in the calibration; it holds "
                                       f"{sorted(entry['methods'])}")
    return name, entry["methods"][name]


def _firmware_cal(data: dict, name: str):
    if data.get("kind") != "firmware":
        raise CalibrationDocumentError(f"method {name!r} is not a firmware polynomial")
    return cal_from_dict(data["firmware"], name)


def correction_g(data: dict, time_s, temperature_c, run=None) -> np.ndarray:
    """What a method subtracts from the reading [g], (n, 3).

    Firmware polynomials give the firmware's own offset; the lag-aware twin gives its modelled
    drift minus its level (the constant the ordinary accelerometer calibration owns). A polynomial
    without lags (``tau_die_s`` absent) is evaluated in the raw temperature.
    """
    T = np.asarray(temperature_c, float)
    if data.get("kind") == "firmware":
        return _firmware_cal(data, "firmware").offset_m_s2(T) / G0_M_S2
    coef = np.asarray(data["coef_mg"], float)
    out = np.empty((T.size, coef.shape[0]))
    log = as_log(make_X(np.asarray(time_s, float), T, run))
    tau_die = data.get("tau_die_s")
    for a in range(coef.shape[0]):
        arg = (lagged_c(log, tau_die[a]) if tau_die is not None else T) - data["reference_c"]
        out[:, a] = np.polyval(coef[a, ::-1], arg) - coef[a, 0]
        tau_rate = (data.get("tau_rate_s") or [None] * 3)[a]
        if tau_rate is not None:
            out[:, a] += data["rate_mg_per_c"][a] * (T - lagged_c(log, tau_rate))
    return out * 1e-3


def export_calibration(doc: dict, fmt: str, path: str | Path, *, method: str | None = None,
                       instance: int | None = None, sample_rate_hz: float | None = None) -> Path:
    """Write the firmware file ``fmt`` (px4, ardupilot, json, c) for the document's IMUs."""
    if fmt not in FORMATS:
        raise CalibrationDocumentError(f"--format must be one of {', '.join(FORMATS)}, got {fmt!r}")
    entries = doc["imus"] if instance is None else [imu_entry(doc, instance)]
    path = Path(path)
    if fmt == "px4":
        cals = [_firmware_cal(method_entry(e, method or "px4", "px4")[1], "px4") for e in entries]
        return atomic_write_text(path, px4_params_text(cals))
    if fmt == "ardupilot":
        cals = [_firmware_cal(method_entry(e, method or "ardupilot", "ardupilot")[1], "ardupilot") for e in entries]
        return atomic_write_text(path, "".join(ardupilot_parm_text(c) for c in cals))
    if len(entries) > 1:
        raise CalibrationDocumentError(f"--format {fmt} writes one IMU; name it with --imu "
                                       f"(instances {[e['instance'] for e in entries]})")
    entry = entries[0]
    name, data = method_entry(entry, method, "c")
    provenance = {"inputs": doc["inputs"], "software_version": doc["software_version"],
                  "validation": entry["validation"]["heldout_rms_mg"].get(name), "method": name}
    if fmt == "json":
        if data.get("kind") == "firmware":
            out = cal_to_dict(_firmware_cal(data, name), provenance)
        else:
            out = {"schema_version": SCHEMA_VERSION, "kind": "lag_aware_accel_temperature_cal", "method": name,
                   "instance": entry["instance"], "device_id": entry["device_id"],
                   "parameters": {k: v for k, v in data.items() if k != "kind"}, "provenance": provenance}
        return atomic_write_text(path, json.dumps(out, indent=2, allow_nan=False) + "\n")
    rate = sample_rate_hz or entry["sample_rate_hz"]
    if data.get("kind") == "firmware":
        return atomic_write_text(path, c_header(_firmware_cal(data, name), rate))
    from twin.firmware import lag_aware_c_header

    return atomic_write_text(path, lag_aware_c_header(data, rate))
