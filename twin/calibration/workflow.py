"""``twin calibrate``: logs of one or several IMUs → methods fitted side by side → held-out
validation → the compensation each firmware can run, in one versioned JSON document.

The document keeps every fitted method (so ``twin apply`` and the exporters need nothing else),
the validation table, and provenance (input hashes, software version, validation figures).
"""

from __future__ import annotations

import datetime as _dt
import hashlib
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from twin.calibration.branches import protocol_heating_vs_cooling
from twin.calibration.lag import make_X
from twin.calibration.lagaware import LagAwareCompensator
from twin.calibration.methods import ArduPilotMethod, Px4Method
from twin.calibration.models import AXES, PolynomialCompensator
from twin.calibration.orientation import cluster_orientations, detect_static_segments, fit_offset_scale
from twin.calibration.validate import ValidationResult, validate
from twin.errors import TwinError
from twin.firmware import cal_to_dict
from twin.measurement import ImuLog, usable_for_calibration

SCHEMA = "tde-twin calibration"
SCHEMA_VERSION = 1
# what each firmware can run: its own polynomial in the raw temperature, or (custom C) the lag-aware model
DEPLOYABLE = {"px4": ("px4",), "ardupilot": ("ardupilot",), "c": ("twin", "polynomial", "px4", "ardupilot")}


class CalibrationInputError(TwinError):
    """A log cannot be calibrated: too short, too narrow in temperature, NaN or frozen temperature."""


@dataclass(frozen=True, eq=False)
class ImuCalibration:
    """One IMU: its data summary, the validation table, and every method fitted on all of its data."""

    instance: int
    device_id: int | None
    sources: tuple[str, ...]
    samples: int
    temperature_span_c: tuple[float, float]
    sample_rate_hz: float
    protocol: str
    validation: ValidationResult
    fitted: dict  # method name → estimator fitted on every sample
    orientations: dict | None = None  # several orientations found: which, and offset + scale factor vs T

    def heldout_rms_mg(self, method: str) -> np.ndarray:
        """Held-out RMS [mg] per axis of ``method``, pooled over folds and test branches."""
        return self.validation.rms_mg(method)

    def recommended(self) -> dict[str, str]:
        """Per target firmware, the deployable method with the lowest pooled held-out RMS (summed over axes)."""
        out = {}
        for target, methods in DEPLOYABLE.items():
            have = [m for m in methods if m in self.fitted]
            out[target] = min(have, key=lambda m: float(np.sum(self.heldout_rms_mg(m) ** 2)))
        return out


def _check_log(log: ImuLog) -> None:
    t = log.temperature_c
    where = f"{log.source} instance {log.instance}"
    if not np.all(np.isfinite(t)):
        raise CalibrationInputError(f"{where}: {int(np.sum(~np.isfinite(t)))} temperature sample(s) are NaN or "
                                    "infinite; expected a finite temperature on every row")
    if len(log) > 1 and np.all(np.diff(t) == 0):
        raise CalibrationInputError(f"{where}: the temperature is frozen at {t[0]:g} °C on every row; expected a "
                                    "live IMU temperature")
    if not np.all(np.isfinite(log.accel_g)):
        raise CalibrationInputError(f"{where}: acceleration has NaN or infinite samples")
    ok, reason = usable_for_calibration(log)
    if not ok:
        raise CalibrationInputError(reason)


def methods_for(instance: int, device_id: int | None, extra: dict | None = None) -> dict:
    """The methods compared: PX4, ArduPilot, held-out polynomial, lag-aware twin, plus ``extra``."""
    models = {"px4": Px4Method(instance=min(max(instance, 0), 3), device_id=int(device_id or 0)),
              "ardupilot": ArduPilotMethod(instance=min(max(instance + 1, 1), 3)),
              "polynomial": PolynomialCompensator(),
              "twin": LagAwareCompensator()}
    models.update(extra or {})
    return models


def calibrate_imu(logs: list[ImuLog], extra_methods: dict | None = None, reverse: bool = True) -> ImuCalibration:
    """Validate and fit every method on one IMU's logs (several logs = several runs).

    Raises
    ------
    CalibrationInputError
        When a log is unusable (the message says why).
    """
    for log in logs:
        _check_log(log)
    time_s = np.concatenate([log.time_s for log in logs])
    temperature_c = np.concatenate([log.temperature_c for log in logs])
    accel_g = np.concatenate([log.accel_g for log in logs])
    run = np.concatenate([np.full(len(log), k) for k, log in enumerate(logs)])
    orientations = None
    if len(logs) == 1:  # several orientations in one log: calibrate offset(T) AND scale factor(T)
        found = orientation_calibration(time_s, temperature_c, accel_g)
        if found is not None:
            orientations, keep, gravity_g = found
            time_s, temperature_c, accel_g, run = time_s[keep], temperature_c[keep], accel_g[keep] - gravity_g, run[keep]
    run_or_none = run if len(logs) > 1 else None
    first = logs[0]
    models = methods_for(first.instance, first.device_id, extra_methods)
    protocol = protocol_heating_vs_cooling(time_s, temperature_c, run=run_or_none, reverse=reverse)
    validation = validate(models, time_s, temperature_c, accel_g, protocol, run=run_or_none)
    X = make_X(time_s, temperature_c, run_or_none)
    fitted = {name: est.clone().fit(X, accel_g) for name, est in models.items()}
    rate = float(1.0 / np.median(np.diff(first.time_s)))
    return ImuCalibration(first.instance, first.device_id, tuple(log.source for log in logs), int(time_s.size),
                          (float(temperature_c.min()), float(temperature_c.max())), rate, protocol.name,
                          validation, fitted, orientations)


def orientation_calibration(time_s, temperature_c, accel_g):
    """Orientations found in a log, and per axis offset(T) and scale factor(T) from its static segments.

    Returns None for a log in one orientation. Otherwise (summary for the document, the static rows,
    the nominal gravity of each of those rows): the firmware methods and the twin are then fitted on
    the static rows with gravity removed, so what they leave is the scale factor they do not model.
    """
    segments = detect_static_segments(time_s, accel_g, temperature_c)
    report = cluster_orientations(segments) if segments else None
    if report is None or len(report.orientations) < 2:
        return None
    fit = fit_offset_scale(segments, report, degree=1)
    keep = np.zeros(len(time_s), bool)
    gravity = np.zeros((len(time_s), 3))
    for o in report.orientations:
        for j in o.segments:
            keep[segments[j].start:segments[j].stop] = True
            gravity[segments[j].start:segments[j].stop] = o.nominal_g
    summary = {
        "kind": report.kind, "found": list(report.found), "missing": list(report.missing),
        "static_segments": len(segments), "reference_c": fit.reference_c,
        "tcso_ppm_per_c": {a: {"value": float(fit.scale_ppm[i, 1]), "ci95": list(map(float, fit.scale_ci95_ppm[i, 1]))}
                           for i, a in enumerate(AXES)},
        "tcoff_mg_per_c": {a: {"value": float(fit.offset_mg[i, 1]), "ci95": list(map(float, fit.offset_ci95_mg[i, 1]))}
                           for i, a in enumerate(AXES)},
        "zero_g_offset_mg": {a: float(fit.offset_mg[i, 0]) for i, a in enumerate(AXES)},
        "residual_rms_mg": dict(zip(AXES, map(float, fit.residual_rms_mg))), "notes": list(fit.notes),
    }
    return summary, keep, gravity[keep]


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


def _validation_json(v: ValidationResult) -> dict:
    tests = {}
    for s in v.scores:
        key = f"{s.fold}: {s.test}"
        tests.setdefault(key, {"samples": s.n, "extrapolated_fraction": s.extrapolated_fraction, "rms_mg": {}})
        tests[key]["rms_mg"][s.method] = dict(zip(AXES, s.rms_mg))
    return {"noise_floor_mg": dict(zip(AXES, v.noise_floor_mg)),
            "heldout_rms_mg": {m: dict(zip(AXES, map(float, v.rms_mg(m)))) for m in v.methods},
            "best_overall": dict(zip(AXES, v.best_method)), "tests": tests, "notes": list(v.notes)}


def method_json(name: str, est) -> dict:
    """A fitted method as data: firmware calibrations in their own schema; the twin's lags and coefficients."""
    if hasattr(est, "cal_"):
        return {"kind": "firmware", "level_g": list(map(float, est.level_g_)), "firmware": cal_to_dict(est.cal_),
                "equation": est.equation()}
    doc = {"kind": type(est).__name__, "reference_c": est.reference_c, "coef_mg": est.coef_mg_.tolist(),
           "equation": est.equation()}
    if isinstance(est, LagAwareCompensator):
        doc.update(tau_die_s=est.tau_die_s_.tolist(), tau_rate_s=[None if not np.isfinite(t) else float(t)
                                                                   for t in est.tau_rate_s_],
                   rate_mg_per_c=est.rate_mg_per_c_.tolist(), tau_die_ci95_s=est.tau_die_ci95_s_.tolist(),
                   shared=bool(est.shared_))
    return doc


def calibration_json(imus: list[ImuCalibration], inputs: list[dict], version: str) -> dict:
    """The versioned calibration document (``-o CAL.json``)."""
    return {
        "schema": SCHEMA, "schema_version": SCHEMA_VERSION, "software_version": version,
        "created_utc": _dt.datetime.now(_dt.timezone.utc).isoformat(timespec="seconds"),
        "inputs": inputs,
        "imus": [{
            "instance": c.instance, "device_id": c.device_id, "sources": list(c.sources), "samples": c.samples,
            "temperature_span_c": list(c.temperature_span_c), "sample_rate_hz": c.sample_rate_hz,
            "protocol": c.protocol, "validation": _validation_json(c.validation),
            "recommended": c.recommended(),
            **({"orientations": c.orientations} if c.orientations else {}),
            "methods": {name: method_json(name, est) for name, est in c.fitted.items()},
        } for c in imus],
    }
