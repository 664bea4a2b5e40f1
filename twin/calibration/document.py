"""The calibration document ``twin calibrate`` writes (``-o CAL.json``): versioned, strict JSON
holding every fitted method as data, the validation tables, the log-quality tables and the
inputs' provenance, so that ``twin apply`` and ``twin firmware`` need nothing else.

:func:`calibration_document` builds it once, as the typed records of
:mod:`twin.calibration.result`; ``.to_json()`` writes it.
"""

from __future__ import annotations

import datetime as _dt
import hashlib
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from twin.calibration.composed import ComposedCompensator
from twin.calibration.lagaware import LagAwareCompensator
from twin.calibration.method_records import (
    ComposedAxis,
    ComposedMethod,
    EffectValues,
    FirmwareMethod,
    LagAwareMethod,
    MethodRecord,
    PolynomialMethod,
)
from twin.calibration.models import AXES, TemperaturePolynomial
from twin.calibration.result import (
    CalibrationDocument,
    GyroRecord,
    HeldoutScores,
    ImuRecord,
    InputFile,
    OrientationRecord,
    RecommendationRecord,
    RecommendedGyroMethods,
    RecommendedMethods,
    SkippedImu,
    Tempco,
    ValidationTable,
    VerdictRecord,
)
from twin.calibration.validate import ValidationResult
from twin.firmware.json_record import cal_record
from twin.results import PerAxis, to_json

if TYPE_CHECKING:
    from twin.calibration.recommend import Recommendation
    from twin.calibration.gyro import GyroCalibration
    from twin.calibration.workflow import ImuCalibration

SCHEMA = "tde-twin calibration"
SCHEMA_VERSION = 1
AS_APPLIED = "_as_applied"  # suffix of a firmware method scored as the vehicle applies its file
AS_APPLIED_NOTE = (f"'<method>{AS_APPLIED}': the file written for the method, applied as the vehicle does "
                   "(float32; PX4 republishes its offset only after the temperature moved > 1 °C, checked "
                   "once a second; ArduPilot re-references at the calibration temperature)")


def file_provenance(paths) -> tuple[InputFile, ...]:
    """Path, size and SHA-256 of each input file.

    Parameters
    ----------
    paths : iterable of str or Path

    Returns
    -------
    tuple of InputFile
    """
    out = []
    for p in map(Path, paths):
        h = hashlib.sha256()
        with p.open("rb") as f:
            for chunk in iter(lambda: f.read(1 << 20), b""):
                h.update(chunk)
        out.append(InputFile(str(p), p.stat().st_size, h.hexdigest()))
    return tuple(out)


def validation_table(v: ValidationResult, gyro: bool = False) -> ValidationTable:
    """The validation table: the accelerometer's figures in mg, the gyro's (``gyro``) in mrad/s.

    Parameters
    ----------
    v : ValidationResult
        Its ``_mg`` figures are thousandths of the sensor's unit (g, or rad/s for the gyro).
    gyro : bool
        Name the figures ``_mrad_s``.

    Returns
    -------
    ValidationTable
    """
    rows: dict[str, tuple[int, float, dict[str, PerAxis[float]]]] = {}
    for s in v.scores:  # the first score of a test gives its rows; each method adds its RMS
        rows.setdefault(f"{s.fold}: {s.test}", (s.n, s.extrapolated_fraction, {}))[2][s.method] = PerAxis.of(s.rms_mg)
    floor = PerAxis.of(v.noise_floor_mg)
    heldout = {m: PerAxis.of(map(float, v.rms_mg(m))) for m in v.methods}
    common = dict(best_overall=PerAxis.of(v.best_method), notes=tuple(v.notes), as_applied=AS_APPLIED_NOTE)
    if gyro:
        tests = {key: HeldoutScores(n, frac, rms_mrad_s=rms) for key, (n, frac, rms) in rows.items()}
        return ValidationTable(noise_floor_mrad_s=floor, heldout_rms_mrad_s=heldout, tests=tests, **common)
    tests = {key: HeldoutScores(n, frac, rms_mg=rms) for key, (n, frac, rms) in rows.items()}
    return ValidationTable(noise_floor_mg=floor, heldout_rms_mg=heldout, tests=tests, **common)


def firmware_method(est) -> FirmwareMethod:
    """A fitted PX4 or ArduPilot method (accelerometer or gyro): its firmware calibration and level.

    Parameters
    ----------
    est : Px4Method, ArduPilotMethod, Px4GyroMethod or ArduPilotGyroMethod
        Fitted.

    Returns
    -------
    FirmwareMethod
        ``level_g`` [g] for the accelerometer, ``level_rad_s`` [rad/s] for the gyro.
    """
    level = tuple(float(v) for v in est.level_g_)
    accel = est.sensor == "accel"
    return FirmwareMethod(kind="firmware", level_g=level if accel else None, level_rad_s=None if accel else level,
                          firmware=cal_record(est.cal_), equation=est.equation())


def method_record(name: str, est) -> MethodRecord:
    """A fitted method as data: firmware calibrations in their own schema; the twin's lags and coefficients.

    Parameters
    ----------
    name : str
        The method's name, for the message.
    est : estimator
        A fitted firmware method, TemperaturePolynomial, LagAwareCompensator or ComposedCompensator.

    Returns
    -------
    FirmwareMethod, PolynomialMethod, LagAwareMethod or ComposedMethod

    Raises
    ------
    TypeError
        For an estimator the document has no record for.
    """
    if hasattr(est, "cal_"):
        return firmware_method(est)
    coef_mg = tuple(tuple(row) for row in est.coef_mg_.tolist())
    if isinstance(est, ComposedCompensator):
        axes = tuple(ComposedAxis(e["axis"], tuple(e["coef_mg"]), e["applied_g"], e["train_rms_mg"],
                                  tuple(EffectValues(x["name"], dict(x["values"])) for x in e["effects"]))
                     for e in est.axes_)
        return ComposedMethod("ComposedCompensator", est.reference_c, coef_mg, est.equation(), axes)
    if isinstance(est, LagAwareCompensator):
        # an axis without a rate term has τ_rate NaN: written as null
        return LagAwareMethod("LagAwareCompensator", est.reference_c, coef_mg, est.equation(),
                              tuple(est.tau_die_s_.tolist()),
                              tuple(float(t) if np.isfinite(t) else None for t in est.tau_rate_s_),
                              tuple(est.rate_mg_per_c_.tolist()),
                              tuple(tuple(ci) for ci in est.tau_die_ci95_s_.tolist()), bool(est.shared_))
    if isinstance(est, TemperaturePolynomial):
        return PolynomialMethod(type(est).__name__, est.reference_c, coef_mg, est.equation())
    raise TypeError(f"method {name!r}: a calibration document holds no {type(est).__name__}")


def method_json(name: str, est) -> dict:
    """:func:`method_record` as the document's JSON (what the plausibility checks and exporters read).

    Parameters
    ----------
    name : str
    est : estimator
        Fitted.

    Returns
    -------
    dict
        Strict JSON data (a NaN is None).
    """
    return to_json(method_record(name, est))


def _recommendation(r: Recommendation) -> RecommendationRecord:
    verdicts = {v.method: VerdictRecord(v.folds, v.eligible, v.reason, PerAxis.of(v.rms_mg) if v.rms_mg else None,
                                        v.worst_ratio) for v in r.verdicts}
    return RecommendationRecord(r.method, r.reason, r.custom_firmware_gain(), verdicts)


def _gyro(g: GyroCalibration) -> GyroRecord:
    return GyroRecord(g.device_id, "rad/s", validation_table(g.validation, gyro=True),
                      RecommendedGyroMethods(**g.recommended()), {n: tuple(f) for n, f in g.flags.items() if f},
                      {name: firmware_method(est) for name, est in g.fitted.items()})


def _orientations(o: dict) -> OrientationRecord:
    def tempco(key: str) -> PerAxis[Tempco]:
        return PerAxis.of(Tempco(o[key][a]["value"], tuple(o[key][a]["ci95"])) for a in AXES)

    return OrientationRecord(o["kind"], tuple(o["found"]), tuple(o["missing"]), o["static_segments"], o["reference_c"],
                             tempco("tcso_ppm_per_c"), tempco("tcoff_mg_per_c"),
                             PerAxis.of(o["zero_g_offset_mg"][a] for a in AXES),
                             PerAxis.of(o["residual_rms_mg"][a] for a in AXES), tuple(o["notes"]), tuple(o["flags"]))


def _imu(c: ImuCalibration) -> ImuRecord:
    return ImuRecord(
        instance=c.instance, device_id=c.device_id, sources=tuple(c.sources), samples=c.samples,
        temperature_span_c=tuple(c.temperature_span_c), sample_rate_hz=c.sample_rate_hz, protocol=c.protocol,
        validation=validation_table(c.validation), recommended=RecommendedMethods(**c.recommended()),
        recommendation=_recommendation(c.recommendation) if c.recommendation is not None else None,
        flags={name: tuple(f) for name, f in (c.flags or {}).items() if f}, notes=tuple(c.notes),
        board_orientation=c.board_orientation, log_quality=tuple(q.record() for q in c.quality),
        orientations=_orientations(c.orientations) if c.orientations else None,
        gyro=_gyro(c.gyro) if c.gyro is not None else None,
        methods={name: method_record(name, est) for name, est in c.fitted.items()})


def calibration_document(imus: list[ImuCalibration], inputs: tuple[InputFile, ...], version: str,
                         skipped: dict[int, str] | None = None) -> CalibrationDocument:
    """The versioned calibration document (``-o CAL.json``).

    Parameters
    ----------
    imus : list of ImuCalibration
    inputs : tuple of InputFile
        :func:`file_provenance` of the logs.
    version : str
        The software's.
    skipped : dict of int to str, optional
        Instance → why it was not calibrated.

    Returns
    -------
    CalibrationDocument
    """
    return CalibrationDocument(
        SCHEMA, SCHEMA_VERSION, version, _dt.datetime.now(_dt.timezone.utc).isoformat(timespec="seconds"),
        tuple(inputs), tuple(SkippedImu(k, r) for k, r in sorted((skipped or {}).items())),
        tuple(_imu(c) for c in imus))
