"""The calibration document ``twin calibrate`` writes (``-o CAL.json``): versioned, strict JSON
holding every fitted method as data, the validation tables, the log-quality tables and the
inputs' provenance, so that ``twin apply`` and ``twin firmware`` need nothing else."""

from __future__ import annotations

import datetime as _dt
import hashlib
import json
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from twin.calibration.composed import ComposedCompensator
from twin.calibration.lagaware import LagAwareCompensator
from twin.calibration.models import AXES
from twin.calibration.validate import ValidationResult
from twin.firmware import cal_to_dict
from twin.io import strict_json

if TYPE_CHECKING:
    from twin.calibration.workflow import GyroCalibration, ImuCalibration

SCHEMA = "tde-twin calibration"
SCHEMA_VERSION = 1
AS_APPLIED = "_as_applied"  # suffix of a firmware method scored as the vehicle applies its file


def file_provenance(paths) -> list[dict]:
    """Path, size and SHA-256 of each input file."""
    out = []
    for p in map(Path, paths):
        h = hashlib.sha256()
        with p.open("rb") as f:
            for chunk in iter(lambda: f.read(1 << 20), b""):
                h.update(chunk)
        out.append({"path": str(p), "bytes": p.stat().st_size, "sha256": h.hexdigest()})
    return out


def _validation_json(v: ValidationResult, unit: str = "mg") -> dict:
    """The validation table; ``unit`` names the figures (mg for the accelerometer, mrad_s for the gyro)."""
    tests = {}
    for s in v.scores:
        key = f"{s.fold}: {s.test}"
        tests.setdefault(key, {"samples": s.n, "extrapolated_fraction": s.extrapolated_fraction, f"rms_{unit}": {}})
        tests[key][f"rms_{unit}"][s.method] = dict(zip(AXES, s.rms_mg))
    return {f"noise_floor_{unit}": dict(zip(AXES, v.noise_floor_mg)),
            f"heldout_rms_{unit}": {m: dict(zip(AXES, map(float, v.rms_mg(m)))) for m in v.methods},
            "best_overall": dict(zip(AXES, v.best_method)), "tests": tests, "notes": list(v.notes),
            "as_applied": f"'<method>{AS_APPLIED}': the file written for the method, applied as the vehicle does "
                          "(float32; PX4 republishes its offset only after the temperature moved > 1 °C, checked "
                          "once a second; ArduPilot re-references at the calibration temperature)"}


def _gyro_json(g: GyroCalibration) -> dict:
    return {"device_id": g.device_id, "unit": "rad/s", "validation": _validation_json(g.validation, "mrad_s"),
            "recommended": g.recommended(), "flags": {n: f for n, f in g.flags.items() if f},
            "methods": {name: method_json(name, est) for name, est in g.fitted.items()}}


def method_json(name: str, est) -> dict:
    """A fitted method as data: firmware calibrations in their own schema; the twin's lags and coefficients."""
    if hasattr(est, "cal_"):
        level = "level_g" if est.sensor == "accel" else "level_rad_s"
        return {"kind": "firmware", level: list(map(float, est.level_g_)), "firmware": cal_to_dict(est.cal_),
                "equation": est.equation()}
    doc = {"kind": type(est).__name__, "reference_c": est.reference_c, "coef_mg": est.coef_mg_.tolist(),
           "equation": est.equation()}
    if isinstance(est, ComposedCompensator):
        doc.update(axes=est.axes_)
    if isinstance(est, LagAwareCompensator):
        doc.update(tau_die_s=est.tau_die_s_.tolist(), tau_rate_s=[None if not np.isfinite(t) else float(t)
                                                                   for t in est.tau_rate_s_],
                   rate_mg_per_c=est.rate_mg_per_c_.tolist(), tau_die_ci95_s=est.tau_die_ci95_s_.tolist(),
                   shared=bool(est.shared_))
    return doc


def calibration_json(imus: list[ImuCalibration], inputs: list[dict], version: str,
                     skipped: dict[int, str] | None = None) -> dict:
    """The versioned calibration document (``-o CAL.json``); ``skipped``: instance → why not calibrated."""
    return strict_json({
        "schema": SCHEMA, "schema_version": SCHEMA_VERSION, "software_version": version,
        "created_utc": _dt.datetime.now(_dt.timezone.utc).isoformat(timespec="seconds"),
        "inputs": inputs,
        "skipped": [{"instance": k, "reason": r} for k, r in sorted((skipped or {}).items())],
        "imus": [{
            "instance": c.instance, "device_id": c.device_id, "sources": list(c.sources), "samples": c.samples,
            "temperature_span_c": list(c.temperature_span_c), "sample_rate_hz": c.sample_rate_hz,
            "protocol": c.protocol, "validation": _validation_json(c.validation),
            "recommended": c.recommended(),
            **({"recommendation": c.recommendation.to_json()} if c.recommendation else {}),
            "flags": {name: list(f) for name, f in (c.flags or {}).items() if f},
            "notes": list(c.notes),
            "board_orientation": c.board_orientation,
            "log_quality": [json.loads(q.to_json()) for q in c.quality],
            **({"orientations": c.orientations} if c.orientations else {}),
            **({"gyro": _gyro_json(c.gyro)} if c.gyro else {}),
            "methods": {name: method_json(name, est) for name, est in c.fitted.items()},
        } for c in imus],
    })
