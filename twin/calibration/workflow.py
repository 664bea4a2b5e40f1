"""``twin calibrate``: logs of one or several IMUs → methods fitted side by side → held-out
validation → the compensation each firmware can run, in one versioned JSON document.

The document keeps every fitted method (so ``twin apply`` and the exporters need nothing else),
the validation table, and provenance (input hashes, software version, validation figures).
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import partial
from pathlib import Path

import numpy as np
from sklearn.base import clone

from twin.calibration.branches import protocol_as_used
from twin.calibration.composed import ComposedCompensator, composed_notes
from twin.calibration.correction import correction_g
from twin.calibration.document import method_json
from twin.calibration.gyro import GyroCalibration, as_applied, calibrate_gyro
from twin.calibration.instances import (
    ARDUPILOT_INSTANCES, CalibrationInputError, check_calibration_instance, check_device_id,
)
from twin.calibration.lag import make_X
from twin.calibration.lagaware import LagAwareCompensator
from twin.calibration.methods import (
    ArduPilotMethod,
    Px4Method,
)
from twin.calibration.models import TemperaturePolynomial
from twin.calibration.orientation import orientation_calibration
from twin.calibration.plausibility import (
    PlausibilityLimits,
    limits_for_part,
    method_flags,
    rate_bound_notes,
    tcso_flags,
)
from twin.calibration.parallel import each_imu
from twin.calibration.progress import FitProgress
from twin.calibration.recommend import Recommendation, recommend
from twin.calibration.runtime import calibration_runtime
from twin.calibration.validate import ValidationResult, validate
from twin.errors import TwinError
from twin.firmware import CalibrationRangeError
from twin.measurement import ImuLog, usable_for_calibration
from twin.measurement.imu import MIN_SAMPLES, MIN_TEMPERATURE_RANGE_C
from twin.measurement.log_quality import LogQuality, LogQualityError, QualitySettings
from twin.measurement.quality import assess_log

# what custom C (and twin apply by default) can run; PX4 and ArduPilot run only their own polynomial
C_CANDIDATES = ("twin", "polynomial", "px4", "ardupilot")
MULTI_POSITION_FACES = 3  # this many faces in one log make a six-position or tumble test
MIN_MEDIAN_NORM_G = 0.25  # below this median |a| the log holds no gravity: not raw accelerometer readings
COMPARED = "compared"  # the method composing, per axis, the effects twin compare named
MIN_STATIC_S = 60.0  # a calibration needs at least a minute of still rows (and MIN_TEMPERATURE_RANGE_C of span)


@dataclass(frozen=True, eq=False)
class ImuCalibration:
    """One IMU: its data summary, the validation table, and every method fitted on all of its data.

    Attributes
    ----------
    instance, device_id : int, int or None
        The IMU instance and its accelerometer's device id.
    sources : tuple of str
        The logs.
    samples : int
        Rows fitted.
    temperature_span_c : tuple of float
        Their temperature span [°C].
    sample_rate_hz : float
        [Hz].
    protocol : str
        The held-out protocol (see :mod:`twin.calibration.branches`).
    validation : ValidationResult
    fitted : dict of str to estimator
        Method name → estimator fitted on every usable row.
    orientations : dict, optional
        With several orientations: which, and offset and scale factor against temperature.
    flags : dict of str to list of str, optional
        Method name → why it is implausible (absent or empty: plausible).
    notes : tuple of str
    gyro : GyroCalibration, optional
        When the logs hold this IMU's gyro.
    quality : tuple of LogQuality
        Per log: which rows were still and used, what was excluded and why.
    board_orientation : int, optional
        ArduPilot ``AHRS_ORIENTATION`` of the logs (IMU messages rotated by it).
    recommendation : Recommendation, optional
        The default of ``twin apply`` and the C export, and why.
    fold_directions : tuple of (str, bool)
        Per fold: whether its training rows both heat and cool.
    """

    instance: int
    device_id: int | None
    sources: tuple[str, ...]
    samples: int
    temperature_span_c: tuple[float, float]
    sample_rate_hz: float
    protocol: str
    validation: ValidationResult
    fitted: dict
    orientations: dict | None = None
    flags: dict | None = None
    notes: tuple[str, ...] = ()
    gyro: GyroCalibration | None = None
    quality: tuple[LogQuality, ...] = ()
    board_orientation: int | None = None
    recommendation: Recommendation | None = None
    fold_directions: tuple[tuple[str, bool], ...] = ()

    def heldout_rms_mg(self, method: str) -> np.ndarray:
        """Held-out RMS [mg] per axis of ``method``, pooled over folds and test branches.

        Parameters
        ----------
        method : str

        Returns
        -------
        ndarray
            (3,) [mg].
        """
        return self.validation.rms_mg(method)

    def recommended(self) -> dict[str, str | None]:
        """Per target firmware: PX4 and ArduPilot their own method unless flagged; custom C (and
        ``twin apply``) the method :func:`twin.calibration.recommend.recommend` chose.

        Returns
        -------
        dict of str to str or None
        """
        flags = self.flags or {}
        out = {t: (t if t in self.fitted and not flags.get(t) else None) for t in ("px4", "ardupilot")}
        out["c"] = self.recommendation.method if self.recommendation else None
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
    median_c = float(np.median(t))
    if median_c > 150 or t.min() < -80 or t.max() > 200:  # every reader, not only tables: a die is in -80..200 °C
        raise CalibrationInputError(f"{where}: temperature {t.min():.4g}..{t.max():.4g} (median {median_c:.4g}) is "
                                    "not an IMU's in °C (a median above 150 looks like kelvin); expected -80..200 °C")
    norm_g = float(np.median(np.linalg.norm(log.accel_g, axis=1)))
    if norm_g < MIN_MEDIAN_NORM_G:  # at rest or in flight an accelerometer reads gravity
        raise CalibrationInputError(f"{where}: acceleration median |a| {norm_g:.3g} g; expected about 1 g (gravity): "
                                    "a log with gravity removed, or an accelerometer that reads nothing")
    if len(log) < MIN_SAMPLES:  # too short to assess; otherwise the span is checked on the still rows
        raise CalibrationInputError(usable_for_calibration(log)[1])


def one_attitude_per_face(quality: LogQuality) -> LogQuality:
    """The attitudes a calibration may fit together: one, unless the log is a multi-position test.

    An offset fit cannot tell a change of attitude from drift: a vehicle put down 2° differently,
    or upside down after a crash at a few degrees off the face, reads tens of mg more on a cross
    axis. So the still rows of one attitude are fitted — the one spanning the most temperature
    (then the longest) — and the others are excluded with the reason; a log holding
    :data:`MULTI_POSITION_FACES` faces or more is a six-position or tumble test, fitted with one
    attitude or more per face (orientation calibration: a fixture revisits its faces) and no tilted one.

    Parameters
    ----------
    quality : LogQuality

    Returns
    -------
    LogQuality
        With the other attitudes' stretches excluded, and why.
    """
    groups = quality.attitudes()
    if len(groups) <= 1:
        return quality
    extent = lambda k: (max(st.temperature_max_c for st in groups[k]) - min(st.temperature_min_c for st in groups[k]),  # noqa: E731
                        sum(st.duration_s for st in groups[k]))
    faces = {v[0].label for v in groups.values()} - {"tilted"}
    if len(faces) >= MULTI_POSITION_FACES:  # a fixture revisits its faces at each plateau: all of them count
        keep = {k for k, v in groups.items() if v[0].label != "tilted"}
        return quality.keeping_attitudes(keep, "a multi-position test is fitted on its faces, never a tilted attitude")
    [main] = keep = {max(groups, key=extent)}
    first = groups[main][0]
    return quality.keeping_attitudes(keep, f"still, but the fitted rows are attitude {main} ({first.label}, from "
                                           f"{first.t0_s:.0f} s) and an offset fit cannot tell a change of attitude "
                                           "from drift")


def still_rows(qualities: tuple[LogQuality, ...], min_static_s: float = MIN_STATIC_S,
               min_span_c: float = MIN_TEMPERATURE_RANGE_C) -> np.ndarray:
    """The rows (all logs concatenated) a calibration may fit: the usable static stretches.

    Parameters
    ----------
    qualities : tuple of LogQuality
        One per log.
    min_static_s : float
        Least still time [s].
    min_span_c : float
        Least temperature span of those rows [°C].

    Returns
    -------
    ndarray of bool
        Per row of the concatenated logs.

    Raises
    ------
    CalibrationInputError
        With the numbers, when those rows last less than ``min_static_s`` or span less than
        ``min_span_c`` °C (e.g. "flight.bin IMU1: 1490 s static, 30.0–35.9 °C after excluding
        195 s of motion, 2 s of gaps: < 10 °C").
    """
    try:
        if len(qualities) == 1:
            qualities[0].require_calibratable(min_static_s, min_span_c)
        else:  # several runs: their still rows together
            lo = min((q.static_min_c for q in qualities if q.static_min_c is not None), default=None)
            hi = max((q.static_max_c for q in qualities if q.static_max_c is not None), default=None)
            static_s = sum(q.static_s for q in qualities)
            short = [f"< {min_static_s:g} s static"] if static_s < min_static_s else []
            short += [f"< {min_span_c:g} °C"] if lo is None or hi - lo < min_span_c else []
            if short:
                raise LogQualityError("; ".join(q.summary() for q in qualities) + ": " + ", ".join(short))
    except LogQualityError as exc:
        raise CalibrationInputError(str(exc)) from None
    return np.concatenate([q.usable_static for q in qualities])


def methods_for(instance: int, device_id: int | None, extra: dict | None = None) -> dict:
    """The methods compared: PX4, ArduPilot (when the firmware has the instance), held-out
    polynomial, lag-aware twin, plus ``extra``.

    Parameters
    ----------
    instance : int
    device_id : int or None
    extra : dict of str to estimator, optional

    Returns
    -------
    dict of str to estimator
        Unfitted.
    """
    models = {"px4": Px4Method(instance=instance, device_id=int(device_id or 0))}
    if instance in ARDUPILOT_INSTANCES:
        models["ardupilot"] = ArduPilotMethod(instance=instance + 1)
    models.update(polynomial=TemperaturePolynomial(), twin=LagAwareCompensator())
    models.update(extra or {})
    return models


def calibrate_imu(logs: list[ImuLog], extra_methods: dict | None = None, reverse: bool = True,
                  device_id: int | None = None, limits: PlausibilityLimits | None = None,
                  settings: QualitySettings | None = None, progress: FitProgress | None = None) -> ImuCalibration:
    """Validate and fit every method on one IMU's logs (several logs = several runs), on their
    usable static rows only (the log-quality stage, :func:`twin.measurement.quality.assess_log`).

    Parameters
    ----------
    device_id : int, optional
        The accelerometer's device id when the logs do not record it (a tester's table); a log that
        records another id is an error.
    limits : PlausibilityLimits, optional
        What a plausible fit may hold (default: :func:`limits_for_part`).
    settings : QualitySettings, optional
        What counts as still, a gap, a fault (default: :class:`QualitySettings`).
    progress : FitProgress, optional
        Told of every stage and fit (default: none drawn).

    Returns
    -------
    ImuCalibration

    Raises
    ------
    CalibrationInputError
        When a log is unusable (the message says why).
    """
    for log in logs:
        _check_log(log)
    first = logs[0]
    where = f"{first.source} instance {first.instance}"
    check_calibration_instance(first.instance, where)
    logged = {log.device_id for log in logs if log.device_id}
    if len(logged) > 1:
        raise CalibrationInputError(f"{where}: the logs record device ids {sorted(logged)}; expected one IMU")
    given = check_device_id(device_id, "--device-id")
    if given is not None and logged and given not in logged:
        raise CalibrationInputError(f"{where}: the log records device_id {logged.pop()}, but --device-id is {given}")
    device = given if given is not None else check_device_id(next(iter(logged), None), where)
    progress = progress or FitProgress("", enabled=False)
    qualities = tuple(one_attitude_per_face(assess_log(log, settings)) for log in logs)
    keep = still_rows(qualities)
    progress.step("log quality")
    joined = (lambda name: getattr(logs[0], name) if len(logs) == 1  # one log: its arrays, not copies
              else np.concatenate([getattr(log, name) for log in logs]))
    time_s, temperature_c, accel_g = joined("time_s"), joined("temperature_c"), joined("accel_g")
    orientations, gravity_g = None, None
    if len(logs) == 1:  # several orientations in one log: calibrate offset(T) AND scale factor(T)
        found = orientation_calibration(time_s, temperature_c, accel_g, qualities[0])
        if found is not None:
            orientations, keep, gravity_g = found
    rows = slice(None) if keep.all() else np.flatnonzero(keep)  # still, and (several orientations) on a known face
    time_s, temperature_c, accel_g = time_s[rows], temperature_c[rows], accel_g[rows]
    if gravity_g is not None:
        accel_g = accel_g - gravity_g[rows]
    run_or_none = np.repeat(np.arange(len(logs)), [len(log) for log in logs])[rows] if len(logs) > 1 else None
    models = methods_for(first.instance, device, extra_methods)
    protocol = protocol_as_used(time_s, temperature_c, run=run_or_none, reverse=reverse)
    validated = {**models, **as_applied(models)}
    progress.expect(2 + len(protocol.folds) * len(validated) + len(models))
    progress.step("protocol")
    validation = validate(validated, time_s, temperature_c, accel_g, protocol, run=run_or_none, on_fit=progress.step)
    X = make_X(time_s, temperature_c, run_or_none)
    fitted, unfit = {}, {}
    for name, est in models.items():
        try:
            fitted[name] = clone(est).fit(X, accel_g)
        except CalibrationRangeError as exc:  # ArduPilot's 10 °C after its filter: the others still stand
            unfit[name] = str(exc)
        progress.step(f"{name} on all rows")
    gyro, gyro_rad_s, gyro_note = None, None, ()
    if any(log.has_gyro for log in logs):
        gyro_rad_s = np.concatenate([log.gyro_rad_s for log in logs])[rows] if all(log.has_gyro for log in logs) else None
        missing = -1 if gyro_rad_s is None else int(np.sum(~np.isfinite(gyro_rad_s).all(axis=1)))
        ids = {log.gyro_device_id for log in logs if log.gyro_device_id}
        why = ("not every log has it" if missing < 0 else f"{missing} of the fitted rows have no gyro sample" if missing
               else f"the logs record gyro device ids {sorted(ids)}" if len(ids) > 1 else None)
        if why:  # a gyro file fitted on part of the rows, or on two gyros, would not be what was validated
            gyro_note = (f"IMU instance {first.instance}: gyro left out ({why}): no gyro calibration is written",)
        else:
            gyro = calibrate_gyro(first, X, gyro_rad_s, protocol, run_or_none)
    rate = float(1.0 / np.median(np.diff(first.time_s)))
    span = (float(temperature_c.min()), float(temperature_c.max()))
    limits = limits or limits_for_part()
    flags = {name: method_flags(name, method_json(name, est), correction_g, span, limits)
             for name, est in fitted.items()}
    for name in fitted:  # a method no fold could fit is not validated, so never recommended
        if name not in validation.methods:
            flags[name].append(f"{name}: not validated: no fold's training rows could fit it (see the notes)")
    rotation = next((log.board_orientation for log in logs if log.board_orientation), None)
    if rotation and "ardupilot" in flags:  # fitted in the vehicle's axes; the firmware corrects in the sensor's
        frame = (f"ardupilot: the log's AHRS_ORIENTATION is {rotation}, so its IMU axes are the vehicle's while "
                 "INS_TCALn corrects in the sensor's own axes; calibrate from a log with AHRS_ORIENTATION 0")
        flags["ardupilot"].append(frame)
        if gyro is not None and "ardupilot" in gyro.flags:
            gyro.flags["ardupilot"].append(frame)
    if orientations:
        orientations["flags"] = tcso_flags(orientations, limits)
    # the default is one the C header can run: a composed twin with an effect of time alone (aging) is not
    candidates = [m for m in dict.fromkeys(C_CANDIDATES + tuple(extra_methods or ()))
                  if m in fitted and not flags.get(m) and not (isinstance(models[m], ComposedCompensator)
                                                                and fitted[m].without_c_form())]
    rate_dependent = {m for m in candidates if getattr(models[m], "rate_dependent", False)}
    # a validated, plausible composed twin holding an effect of time alone that no firmware runs (aging)
    undeployable = {m: est.drifts_in_time() for m, est in fitted.items() if isinstance(est, ComposedCompensator)
                    and est.drifts_in_time() and m in validation.methods and not flags.get(m)}
    recommendation = recommend(validation, protocol, candidates, rate_dependent, undeployable=undeployable)
    read = tuple(dict.fromkeys(n for log in logs for n in log.notes))  # what the readers dropped or noticed
    read += tuple(f"IMU instance {first.instance}: {name} not fitted: {why}" for name, why in unfit.items())
    read += tuple(n for name, est in fitted.items() for n in rate_bound_notes(name, method_json(name, est), limits))
    read += composed_notes(validation, fitted)
    notes = read + gyro_note + (() if "ardupilot" in models else (f"IMU instance {first.instance}: ArduPilot has INS_TCAL1..3 "
                                                           "for instances 0..2 only; no ArduPilot method",))
    return ImuCalibration(first.instance, device, tuple(log.source for log in logs), int(time_s.size), span, rate,
                          protocol.name, validation, fitted, orientations, flags, notes, gyro, qualities, rotation,
                          recommendation, tuple((f.name, f.both_directions) for f in protocol.folds))


def calibrate_imus(per_instance: dict[int, list[ImuLog]], workers: int | None = None,
                   **options) -> tuple[list[ImuCalibration], dict[int, str]]:
    """:func:`calibrate_imu` for each instance; an instance whose logs cannot be calibrated is
    skipped with the reason when others can (a flight controller's second IMU on a cooler part
    of the board often spans too little), and its error is raised when it is the only one.

    ``compared`` (instance → axis → effect names, as ``twin compare`` named them) adds a method
    :data:`COMPARED` composing those effects per axis, validated beside the others.

    Parameters
    ----------
    per_instance : dict of int to list of ImuLog
    workers : int, optional
        Processes calibrating IMUs side by side (:func:`twin.calibration.parallel.each_imu`;
        default: one per IMU, at most one per usable CPU).
    **options
        Passed to :func:`calibrate_imu` (``compared`` taken per instance).

    Returns
    -------
    (calibrations, skipped) : list of ImuCalibration, dict instance → reason
    """
    done, skipped = [], {}
    compared = options.pop("compared", None) or {}
    with calibration_runtime():  # BLAS on one thread, freed arrays reused (twin.calibration.runtime)
        for instance, outcome in each_imu(partial(_calibrate_one, per_instance, options, compared),
                                          sorted(per_instance), workers):
            if not isinstance(outcome, TwinError):
                done.append(outcome)
            elif len(per_instance) == 1:  # the only IMU: its refusal is the command's error
                raise outcome
            else:  # any refusal of this IMU's logs; the others are still calibrated
                logs = per_instance[instance]
                name = Path(logs[0].source).name
                skipped[instance] = (str(outcome) if name and name in str(outcome)
                                     else f"{name} instance {instance}: {outcome}")
    if not done:
        raise CalibrationInputError("no IMU can be calibrated: " + "; ".join(skipped.values()))
    return done, skipped


def _calibrate_one(per_instance, options, compared, instance: int, position: int = 0):
    """One IMU of :func:`calibrate_imus`: its calibration, or the :class:`TwinError` refusing it."""
    extra = dict(options.get("extra_methods") or {})
    if instance in compared:
        extra[COMPARED] = ComposedCompensator(compared[instance])
    try:
        with FitProgress(f"IMU {instance}", position=position) as progress:  # drawn on a terminal only
            return calibrate_imu(per_instance[instance], **{**options, "extra_methods": extra, "progress": progress})
    except TwinError as exc:
        return exc
