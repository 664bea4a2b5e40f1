"""From a calibration document to what runs on the vehicle: firmware files, and the compensated log.

``export_calibration`` writes PX4 ``.params``, ArduPilot ``.parm``, the firmware JSON or a C header
from the document ``twin calibrate`` wrote; ``correction_g`` is the correction a method applies
to a log, the same arithmetic ``twin apply`` and the round-trip tests use.
"""

from __future__ import annotations

import dataclasses
import json
import warnings
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from twin.calibration.correction import CalibrationDocumentError, correction_g
from twin.calibration.correction import firmware_cal as _firmware_cal
from twin.calibration.document import SCHEMA, SCHEMA_VERSION
from twin.calibration.plausibility import limits_for_part, method_flags
from twin.calibration.instances import MAX_DEVICE_ID, PX4_INSTANCES
from twin.errors import TwinError
from twin.firmware import (
    ArduPilotAccelCal,
    FirmwareValueError,
    Px4AccelCal,
    c_header,
    cal_from_dict,
    cal_to_dict,
    checked_ardupilot_parm_text,
    checked_px4_params_text,
)
from twin.io import atomic_write_text, read_json, strict_json

FORMATS = ("px4", "ardupilot", "json", "c")
FIRMWARE_CAL = {"px4": Px4AccelCal, "ardupilot": ArduPilotAccelCal}  # what each parameter file holds
NO_GYRO = {  # what loading an accel-only file does to the vehicle's gyro temperature calibration
    "px4": "accel only (the log had no gyro): no TC_G line, so the vehicle's TC_G* calibration is left as it is",
    "ardupilot": "accel only (the log had no gyro): no INS_TCALn_GYR* line, so the vehicle's gyro terms stay, and "
                 "with INS_TCALn_ENABLE 1 and this TMIN/TMAX they apply: check them (or zero them) before flight",
}
AFTER_LOADING = {
    "px4": "after loading: reboot, then redo the accelerometer (and gyro) calibration: TC_An_X0 holds the offset at "
           "TREF, which the old CAL_ACCn offsets would count twice",
    "ardupilot": "after loading: reboot; the correction is zero at INS_ACCn_CALTEMP / INS_GYRn_CALTEMP, so the "
                 "existing accelerometer and gyro calibrations stay valid",
}


def read_calibration(path: str | Path) -> dict:
    """The document ``twin calibrate -o`` wrote, checked for its schema.

    Parameters
    ----------
    path : str or Path
        The JSON document.

    Returns
    -------
    dict
        The checked document.
    """
    path = Path(path)
    doc = read_json(path, "calibration document", CalibrationDocumentError)
    if not isinstance(doc, dict) or doc.get("schema") != SCHEMA or doc.get("schema_version") != SCHEMA_VERSION:
        raise CalibrationDocumentError(f"{path}: not a '{SCHEMA}' document of schema_version {SCHEMA_VERSION}")
    if not doc.get("imus"):
        raise CalibrationDocumentError(f"{path}: key 'imus' is empty; expected at least one calibrated IMU")
    try:
        check_document(doc, str(path))
    except (AttributeError, TypeError, KeyError, IndexError, ValueError) as exc:  # a shape no check foresaw
        raise CalibrationDocumentError(f"{path}: malformed calibration document ({type(exc).__name__}: "
                                       f"{' '.join(str(exc).split())[:160]}); expected what twin calibrate wrote") from None
    return doc


def _finite(value) -> bool:
    return isinstance(value, (int, float)) and not isinstance(value, bool) and bool(np.isfinite(value))


def check_document(doc: dict, path: str) -> None:
    """Every IMU entry has what the exporters and ``twin apply`` read, and every method's correction
    is finite over the calibrated span (an edited or corrupted document is one line, not a crash
    or a firmware file of NaN).

    Parameters
    ----------
    doc, path : dict, str
        The document, and where it came from (for messages).

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
        if isinstance(inst, bool) or not isinstance(inst, int) or inst not in PX4_INSTANCES:
            raise CalibrationDocumentError(f"{at}.instance: got {inst!r}, expected an IMU instance 0..3 "
                                           "(PX4 TC_A0..3; ArduPilot INS_TCAL1..3 for 0..2)")
        if isinstance(e.get("samples"), bool) or not isinstance(e.get("samples"), int) or e["samples"] < 0:
            raise CalibrationDocumentError(f"{at}.samples: got {e.get('samples')!r}, expected a whole number >= 0")
        if dev is not None and (isinstance(dev, bool) or not isinstance(dev, int) or not 0 < dev <= MAX_DEVICE_ID):
            raise CalibrationDocumentError(f"{at}.device_id: got {dev!r}, expected an integer 1..{MAX_DEVICE_ID} "
                                           "(uint32) or null")
        if not (isinstance(span, list) and len(span) == 2 and all(_finite(v) for v in span) and span[0] < span[1]):
            raise CalibrationDocumentError(f"{at}.temperature_span_c: got {span!r}, expected [low, high] in °C, "
                                           "finite, low < high")
        if not (_finite(rate) and 0 < rate < 1e6):
            raise CalibrationDocumentError(f"{at}.sample_rate_hz: got {rate!r}, expected a finite rate > 0 [Hz]")
        methods, rec, val = e.get("methods"), e.get("recommended"), e.get("validation")
        if not (isinstance(methods, dict) and methods and all(isinstance(m, dict) for m in methods.values())):
            raise CalibrationDocumentError(f"{at}.methods: expected a mapping of method names to fitted methods")
        if not (isinstance(rec, dict) and all(v is None or isinstance(v, str) for v in rec.values())):
            raise CalibrationDocumentError(f"{at}.recommended: expected a mapping of targets to method names or null")
        flags = e.get("flags", {})
        if not (isinstance(flags, dict) and all(isinstance(f, list) and all(isinstance(x, str) for x in f)
                                                for f in flags.values())):
            raise CalibrationDocumentError(f"{at}.flags: expected a mapping of method names to lists of reasons")
        if not (isinstance(val, dict) and isinstance(val.get("heldout_rms_mg"), dict)):
            raise CalibrationDocumentError(f"{at}.validation: expected the held-out RMS per method")
        temperature_c, time_s = np.linspace(span[0], span[1], 16), np.arange(16.0)
        if inst in [i.get("instance") for i in imus[:k]]:
            raise CalibrationDocumentError(f"{at}.instance: IMU instance {inst} appears twice; expected one entry each")
        for name, data in _gyro_methods(e, at).items():  # checked as the firmware holds them
            _check_slot(data, inst, e, f"{at}.gyro.methods.{name}")
            try:
                cal_from_dict(data["firmware"], f"{at}.gyro.methods.{name}")
            except (FirmwareValueError, KeyError, TypeError) as exc:
                raise CalibrationDocumentError(f"{at}.gyro.methods.{name}: {' '.join(str(exc).split())[:200]}") from None
        for name, data in methods.items():
            _check_slot(data, inst, e, f"{at}.methods.{name}")
            level = data.get("level_g", [0.0, 0.0, 0.0])
            if any(data.get(key) is not None and not isinstance(data.get(key), list) for key in ("tau_die_s", "tau_rate_s")):
                raise CalibrationDocumentError(f"{at}.methods.{name}: tau_die_s / tau_rate_s must be lists (one per "
                                               "axis) or null; expected what twin calibrate wrote")
            taus = [t for key in ("tau_die_s", "tau_rate_s") for t in (data.get(key) or [])]
            if not all(t is None or _finite(t) and 0 <= t <= 1e7 for t in taus):
                raise CalibrationDocumentError(f"{at}.methods.{name}: time constants {taus}; expected each null or a "
                                               "finite number of seconds in 0..1e7")
            try:  # the arithmetic every consumer runs, on the calibrated span (its warnings are this line's)
                with warnings.catch_warnings(), np.errstate(all="ignore"):
                    warnings.simplefilter("ignore")
                    corr = correction_g(data, time_s, temperature_c)
            except FirmwareValueError as exc:  # names the parameter and what the firmware holds: say where too
                raise CalibrationDocumentError(f"{at}.methods.{name}: {exc}") from None
            except (KeyError, TypeError, ValueError, IndexError, TwinError) as exc:
                raise CalibrationDocumentError(f"{at}.methods.{name}: malformed ({type(exc).__name__}: "
                                               f"{' '.join(str(exc).split())[:160]}); expected what twin calibrate wrote") from None
            if corr.shape != (16, 3) or not np.all(np.isfinite(corr)) or not (
                    isinstance(level, list) and len(level) == 3 and all(_finite(v) for v in level)):
                raise CalibrationDocumentError(f"{at}.methods.{name}: not finite over {span[0]:g}..{span[1]:g} °C; "
                                               "expected finite coefficients, levels and time constants")


def _gyro_methods(entry: dict, at: str) -> dict:
    gyro = entry.get("gyro")
    if gyro is None:
        return {}
    if not (isinstance(gyro, dict) and isinstance(gyro.get("methods"), dict)
            and all(isinstance(m, dict) for m in gyro["methods"].values())):
        raise CalibrationDocumentError(f"{at}.gyro: expected the gyro's fitted methods")
    return gyro["methods"]


def _numbers(node, where: str) -> None:
    """Every number in a firmware block a real number: JSON ``true`` or ``"0.002"`` is not one."""
    if isinstance(node, dict):
        for key, value in node.items():
            if key not in ("units", "reference", "method") and key != "kind":
                _numbers(value, f"{where}.{key}")
    elif isinstance(node, list):
        for i, value in enumerate(node):
            _numbers(value, f"{where}[{i}]")
    elif isinstance(node, (bool, str)):
        raise CalibrationDocumentError(f"{where}: got {node!r}, expected a number")


def _check_slot(data: dict, instance: int, entry: dict, where: str) -> None:
    """A firmware method's own instance and device id agree with its IMU entry's (an edit of one
    would write IMU 0's calibration into another slot, or pair it with another sensor)."""
    if data.get("kind") != "firmware":
        return
    block = data.get("firmware")
    if not isinstance(block, dict):
        raise CalibrationDocumentError(f"{where}.firmware: expected the firmware calibration")
    _numbers({k: block.get(k) for k in ("temperature_c", "coefficients", "method_parameters")}, f"{where}.firmware")
    params = block.get("method_parameters") or {}
    if not isinstance(params, dict):
        raise CalibrationDocumentError(f"{where}.firmware.method_parameters: got {params!r}, expected a mapping")
    slot = instance + (1 if block.get("method") == "ardupilot" else 0)
    if params.get("instance") != slot:
        raise CalibrationDocumentError(f"{where}.firmware.method_parameters.instance: got {params.get('instance')!r}, "
                                       f"expected {slot} for IMU instance {instance}")
    gyro = ".gyro.methods." in where
    logged = (entry.get("gyro") or {}).get("device_id") if gyro else entry.get("device_id")
    if block.get("method") == "px4" and params.get("device_id") not in (0, logged):
        raise CalibrationDocumentError(f"{where}.firmware.method_parameters.device_id: got {params.get('device_id')!r}, "
                                       f"expected the IMU entry's {'gyro ' if gyro else ''}device_id {logged!r}")


def imu_entry(doc: dict, instance: int | None, device_id: int | None = None, source: str = "calibration") -> dict:
    """The document's entry for an IMU instance (the only one when ``instance`` is None); a
    ``device_id`` that differs from the calibrated one is an error naming both.

    Parameters
    ----------
    doc : dict
        The calibration document.
    instance, device_id : int or None
        IMU instance; the log's IMU device id.
    source : str
        Name for messages.

    Returns
    -------
    dict
        The IMU entry.
    """
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


def method_entry(entry: dict, method: str | None, target: str = "c", force: bool = False) -> tuple[str, dict]:
    """(name, data) of ``method``, or of the recommended one for ``target`` when None.

    A method the calibration flagged as implausible is refused unless ``force``: what goes into a
    vehicle must not be a fit of motion, a crash or a time constant the data could not fix.

    Parameters
    ----------
    entry : dict
        The IMU entry.
    method, target : str or None, str
        Method name; the target (``"c"``, ``"px4"``, ``"ardupilot"``) whose recommendation is used.
    force : bool
        Accept a flagged method.

    Returns
    -------
    (str, dict)
        The method's name and stored data.
    """
    flags = entry.get("flags") or {}
    name = method or entry["recommended"].get(target)
    where = f"IMU instance {entry['instance']}"
    if name is None:
        why = "; ".join(f for m, fl in flags.items() for f in fl[:1]) or "none fitted"
        raise CalibrationDocumentError(f"{where}: no plausible method for {target} ({why}); inspect the report, "
                                       "then name one with --method and --force to export it anyway")
    if name not in entry["methods"]:
        raise CalibrationDocumentError(f"{where}: method {name!r} is not in the calibration; it holds "
                                       f"{sorted(entry['methods'])}")
    if flags.get(name) and not force:
        raise CalibrationDocumentError(f"{where}: method {name!r} is flagged: {flags[name][0]}"
                                       f"{f' (and {len(flags[name]) - 1} more)' if len(flags[name]) > 1 else ''}; "
                                       "pass --force to export it anyway")
    data = entry["methods"][name]
    # checked again as loaded: a document edited after twin calibrate carries no flag for what it now holds
    again = [] if force else method_flags(name, data, correction_g, tuple(entry["temperature_span_c"]), limits_for_part())
    if again:
        raise CalibrationDocumentError(f"{where}: method {name!r} fails the plausibility checks as loaded: {again[0]}; "
                                       "pass --force to export it anyway")
    return name, data


@dataclass(frozen=True)
class Export:
    """What ``twin firmware`` wrote: the file, its line count, and what the user should know.

    Attributes
    ----------
    path, lines : Path, int
        The file written and its line count.
    notes, methods : tuple of str
        What the user should know; the method written for each IMU.
    """

    path: Path
    lines: int
    notes: tuple[str, ...] = ()
    methods: tuple[str, ...] = ()  # the method written for each IMU


def _with_device_id(cal, entry: dict, device_id: int | None, sensor: str):
    """A PX4 calibration carrying the sensor's device id, or a refusal saying why the file would be inert.

    PX4 applies ``TC_An`` only to the sensor whose ``device_id`` equals ``TC_An_ID``
    (``TemperatureCompensation::set_sensor_id``); an id of 0 matches no sensor.
    """
    logged = cal.device_id or None
    if device_id is not None and logged is not None and device_id != logged:
        raise CalibrationDocumentError(f"IMU instance {entry['instance']}: the calibration is for {sensor} device_id "
                                       f"{logged}, --device-id says {device_id}; expected the same sensor")
    chosen = logged if logged is not None else device_id
    if chosen is None:
        raise CalibrationDocumentError(
            f"IMU instance {entry['instance']}: no {sensor} device id; PX4 applies TC_{'A' if sensor == 'accel' else 'G'}"
            f"{cal.instance} only to the sensor whose device_id equals its ID, so this file would load and change "
            f"nothing; pass --device-id (the vehicle's CAL_{'ACC' if sensor == 'accel' else 'GYRO'}{cal.instance}_ID) "
            "or calibrate from a log that records it")
    return dataclasses.replace(cal, device_id=int(chosen))


def _gyro_cal(entry: dict, target: str, force: bool):
    """The entry's gyro calibration for ``target`` (px4, ardupilot), or None when the log had no gyro."""
    gyro = entry.get("gyro")
    if not gyro or target not in gyro.get("methods", {}):
        return None
    if gyro.get("flags", {}).get(target) and not force:
        raise CalibrationDocumentError(f"IMU instance {entry['instance']}: gyro method {target!r} is flagged: "
                                       f"{gyro['flags'][target][0]}; pass --force to export it anyway")
    return cal_from_dict(gyro["methods"][target]["firmware"], f"imus.gyro.{target}")


def export_calibration(doc: dict, fmt: str, path: str | Path, *, method: str | None = None,
                       instance: int | None = None, sample_rate_hz: float | None = None,
                       device_id: int | None = None, gyro_device_id: int | None = None,
                       force: bool = False) -> Export:
    """Write the firmware file ``fmt`` (px4, ardupilot, json, c) for the document's IMUs.

    PX4 and ArduPilot files carry the gyro calibration when the log had the gyro, and no gyro line
    otherwise (a zero line would erase the vehicle's own). Every value is checked as the firmware
    holds it, and the text is read back as the ground station loads it before the atomic rename.

    Parameters
    ----------
    doc, fmt, path : dict, str, str or Path
        The calibration document, one of :data:`FORMATS`, the output file.
    method, instance : str, int, optional
        Method written (default: recommended) and IMU written (default: all).
    sample_rate_hz : float, optional
        Sample rate [Hz] of the C header (default: the log's).
    device_id, gyro_device_id, force : int, int, bool
        PX4 ``TC_An_ID`` / ``TC_Gn_ID`` when the calibration lacks them; export a flagged method anyway.

    Returns
    -------
    Export
        The file written, its line count and notes.

    Raises
    ------
    CalibrationDocumentError
        A flagged method without ``force``, a PX4 file without a device id, a ``device_id`` for
        several IMUs or in conflict with the calibrated one.
    FirmwareValueError
        A value the firmware cannot hold (non-finite, beyond float32, TMIN ≥ TMAX, degree > 3).
    """
    if fmt not in FORMATS:
        raise CalibrationDocumentError(f"--format must be one of {', '.join(FORMATS)}, got {fmt!r}")
    entries = doc["imus"] if instance is None else [imu_entry(doc, instance)]
    for option, value in (("--device-id", device_id), ("--gyro-device-id", gyro_device_id)):
        if value is not None and len(entries) > 1:
            raise CalibrationDocumentError(f"{option} names one sensor, but the calibration holds IMU instances "
                                           f"{[e['instance'] for e in entries]}; choose one with --imu")
    path = Path(path)
    if fmt in ("px4", "ardupilot"):
        accel, gyros, notes, names = [], [], [], []
        for e in entries:
            if fmt == "ardupilot" and e["instance"] > 2 and instance is None:  # INS_TCAL1..3 only
                notes.append(f"IMU {e['instance']}: not written: ArduPilot has INS_TCAL1..3 for IMU instances 0..2")
                continue
            if fmt == "ardupilot" and e.get("board_orientation"):  # not even with --force: the axes would be wrong
                raise CalibrationDocumentError(
                    f"IMU instance {e['instance']}: the log's AHRS_ORIENTATION is {e['board_orientation']}: its IMU "
                    "axes are the vehicle's, but INS_TCALn corrects in the sensor's own axes, so this file would "
                    "correct the wrong axes; calibrate from a log recorded with AHRS_ORIENTATION 0")
            name, data = method_entry(e, method or fmt, fmt, force)
            cal = _firmware_cal(data, name)
            if not isinstance(cal, FIRMWARE_CAL[fmt]):
                raise CalibrationDocumentError(f"IMU instance {e['instance']}: method {name!r} is a "
                                               f"{type(cal).__name__}; --format {fmt} writes the {fmt} method only")
            gyro, note = _gyro_cal(e, fmt, force), None
            if fmt == "px4":
                cal = _with_device_id(cal, e, device_id, "accel")
                if gyro is not None and not gyro.device_id and gyro_device_id is None:
                    gyro, note = None, (f"IMU {e['instance']}: accel only: the gyro calibration has no device id, and "
                                        f"PX4 applies TC_G{cal.instance} only to the gyro whose device_id equals its "
                                        f"ID; pass --gyro-device-id (the vehicle's CAL_GYRO{cal.instance}_ID) to "
                                        "write it")
                elif gyro is not None:
                    gyro = _with_device_id(gyro, e, gyro_device_id, "gyro")
            accel.append(cal)
            names.append(name)
            if gyro is not None:
                gyros.append(gyro)
            notes.append(note or f"IMU {e['instance']}: " + ("accel and gyro" if gyro is not None else NO_GYRO[fmt]))
        if not accel:
            raise CalibrationDocumentError(f"no IMU of the calibration has a slot in {fmt}: " + "; ".join(notes))
        ids = [c.device_id for c in accel] if fmt == "px4" else []
        twice = next((d for k, d in enumerate(ids) if d in ids[:k]), None)
        if twice is not None:  # set_sensor_id takes the first slot with the id: one would be dead
            raise CalibrationDocumentError(f"IMU instances {[e['instance'] for e, c in zip(entries, accel) if c.device_id == twice]} "
                                           f"share device_id {twice}; PX4 matches a sensor to the first TC_An_ID that "
                                           "equals its id, so expected one id per IMU (--imu writes one)")
        text = (checked_px4_params_text(accel, gyro=gyros or None) if fmt == "px4"
                else checked_ardupilot_parm_text(accel, gyro=gyros or None))
        atomic_write_text(path, text)
        return Export(path, text.count("\n"), tuple(notes) + (AFTER_LOADING[fmt],), tuple(names))
    if len(entries) > 1:
        raise CalibrationDocumentError(f"--format {fmt} writes one IMU; name it with --imu "
                                       f"(instances {[e['instance'] for e in entries]})")
    entry = entries[0]
    name, data = method_entry(entry, method, "c", force)
    provenance = {"inputs": doc["inputs"], "software_version": doc["software_version"],
                  "validation": entry["validation"]["heldout_rms_mg"].get(name), "method": name}
    if fmt == "json":
        if data.get("kind") == "firmware":
            out = cal_to_dict(_firmware_cal(data, name), provenance)
        else:
            kind = "composed_accel_temperature_cal" if data.get("kind") == "ComposedCompensator" else \
                "lag_aware_accel_temperature_cal"
            out = {"schema_version": SCHEMA_VERSION, "kind": kind, "method": name,
                   "instance": entry["instance"], "device_id": entry["device_id"],
                   "parameters": {k: v for k, v in data.items() if k != "kind"}, "provenance": provenance}
        text = json.dumps(strict_json(out), indent=2, allow_nan=False) + "\n"
    elif data.get("kind") == "firmware":
        text = c_header(_firmware_cal(data, name), sample_rate_hz or entry["sample_rate_hz"])
    elif data.get("kind") == "ComposedCompensator":
        from twin.firmware.composed_header import composed_c_header

        text = composed_c_header(data)
    else:
        from twin.firmware import lag_aware_c_header

        text = lag_aware_c_header(data, sample_rate_hz)
    atomic_write_text(path, text)
    return Export(path, text.count("\n"), methods=(name,))
