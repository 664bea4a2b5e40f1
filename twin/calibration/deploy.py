"""From a calibration document to what runs on the vehicle: firmware files, and the compensated log.

``export_calibration`` writes PX4 ``.params``, ArduPilot ``.parm``, the firmware JSON or a C header
from the document ``twin calibrate`` wrote; ``correction_g`` is the correction a method applies
to a log, the same arithmetic ``twin apply`` and the round-trip tests use.
"""

from __future__ import annotations

import json
import warnings
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
    check_document(doc, str(path))
    return doc


def _finite(value) -> bool:
    return isinstance(value, (int, float)) and not isinstance(value, bool) and bool(np.isfinite(value))


def check_document(doc: dict, path: str) -> None:
    """Every IMU entry has what the exporters and ``twin apply`` read, and every method's correction
    is finite over the calibrated span (an edited or corrupted document is one line, not a crash
    or a firmware file of NaN).

    Raises
    ------
    CalibrationDocumentError
        ``path: imus[k].key: what was found, expected what``.
    """
    imus = doc["imus"]
    if not isinstance(imus, list) or not all(isinstance(e, dict) for e in imus):
        raise CalibrationDocumentError(f"{path}: imus: got {type(imus).__name__}, expected a list of IMU entries")
    if not isinstance(doc.get("inputs"), list) or not isinstance(doc.get("software_version"), str):
        raise CalibrationDocumentError(f"{path}: inputs / software_version missing; expected what twin calibrate wrote")
    for k, e in enumerate(imus):
        at = f"{path}: imus[{k}]"
        inst, dev, span, rate = (e.get(key) for key in ("instance", "device_id", "temperature_span_c", "sample_rate_hz"))
        if isinstance(inst, bool) or not isinstance(inst, int) or not 0 <= inst < 256:
            raise CalibrationDocumentError(f"{at}.instance: got {inst!r}, expected an IMU instance 0..255")
        if isinstance(e.get("samples"), bool) or not isinstance(e.get("samples"), int) or e["samples"] < 0:
            raise CalibrationDocumentError(f"{at}.samples: got {e.get('samples')!r}, expected a whole number >= 0")
        if dev is not None and (isinstance(dev, bool) or not isinstance(dev, int)):
            raise CalibrationDocumentError(f"{at}.device_id: got {dev!r}, expected an integer or null")
        if not (isinstance(span, list) and len(span) == 2 and all(_finite(v) for v in span) and span[0] <= span[1]):
            raise CalibrationDocumentError(f"{at}.temperature_span_c: got {span!r}, expected [low, high] in °C, finite")
        if not (_finite(rate) and 0 < rate < 1e6):
            raise CalibrationDocumentError(f"{at}.sample_rate_hz: got {rate!r}, expected a finite rate > 0 [Hz]")
        methods, rec, val = e.get("methods"), e.get("recommended"), e.get("validation")
        if not (isinstance(methods, dict) and methods and all(isinstance(m, dict) for m in methods.values())):
            raise CalibrationDocumentError(f"{at}.methods: expected a mapping of method names to fitted methods")
        if not (isinstance(rec, dict) and all(isinstance(v, str) for v in rec.values())):
            raise CalibrationDocumentError(f"{at}.recommended: expected a mapping of targets to method names")
        if not (isinstance(val, dict) and isinstance(val.get("heldout_rms_mg"), dict)):
            raise CalibrationDocumentError(f"{at}.validation: expected the held-out RMS per method")
        temperature_c, time_s = np.linspace(span[0], span[1], 16), np.arange(16.0)
        for name, data in methods.items():
            level = data.get("level_g", [0.0, 0.0, 0.0])
            taus = [t for key in ("tau_die_s", "tau_rate_s") for t in (data.get(key) or [])]
            if not all(t is None or _finite(t) and 0 <= t <= 1e7 for t in taus):
                raise CalibrationDocumentError(f"{at}.methods.{name}: time constants {taus}; expected each null or a "
                                               "finite number of seconds in 0..1e7")
            try:  # the arithmetic every consumer runs, on the calibrated span (its warnings are this line's)
                with warnings.catch_warnings(), np.errstate(all="ignore"):
                    warnings.simplefilter("ignore")
                    corr = correction_g(data, time_s, temperature_c)
            except (KeyError, TypeError, ValueError, IndexError, TwinError) as exc:
                raise CalibrationDocumentError(f"{at}.methods.{name}: malformed ({type(exc).__name__}: "
                                               f"{' '.join(str(exc).split())[:160]}); expected what twin calibrate wrote") from None
            if corr.shape != (16, 3) or not np.all(np.isfinite(corr)) or not (
                    isinstance(level, list) and len(level) == 3 and all(_finite(v) for v in level)):
                raise CalibrationDocumentError(f"{at}.methods.{name}: not finite over {span[0]:g}..{span[1]:g} °C; "
                                               "expected finite coefficients, levels and time constants")


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
