"""``twin calibrate --report DIR``: one HTML page per calibration — the held-out table per IMU and
axis beside the noise floor, the recommendation, each method's equation, and residual plots."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from twin.arrays import temperature_rate_c_per_s
from twin.calibration.lag import make_X
from twin.calibration.models import AXES
from twin.calibration.document import AS_APPLIED
from twin.calibration.workflow import ImuCalibration
from twin.measurement import ImuLog
from twin.reporting.page import Page
from twin.reporting.plots import png_base64
from twin.reporting.study_plots import ResidualByMethodDisplay


AS_APPLIED_NOTE = (f"'<method>{AS_APPLIED}': the file written for the method, applied as the vehicle applies it "
                   "(float32; PX4 republishes its offset only after the temperature moved more than 1 °C, checked "
                   "once a second; ArduPilot re-references at the calibration temperature).")


def _validation(page: Page, v, unit: str = "mg") -> None:
    """The held-out table: one row per fold, test and method (each fold and test named once), the noise floor last."""
    first = {k: i for i, k in reversed(list(enumerate((s.fold, s.test) for s in v.scores)))}  # first appearance
    folds = list(dict.fromkeys(s.fold for s in v.scores))
    rows = [[s.fold, s.test, s.method, *(f"{x:.3f}" for x in s.rms_mg), f"{100 * s.extrapolated_fraction:.0f} %"]
            for s in sorted(v.scores, key=lambda s: (folds.index(s.fold), first[s.fold, s.test]))]
    rows.append(["noise floor", "", "", *(f"{x:.3f}" for x in v.noise_floor_mg), ""])
    page.table(rows, ["fold", "test", "method", *(f"{a} [{unit}]" for a in AXES), "extrapolated"], merge=2)
    page.text(AS_APPLIED_NOTE)


def _ledger(page: Page, c: ImuCalibration) -> None:
    """Held-out RMS per axis as physics is added (static cubic → the twin's lag and rate term → the
    composed effects), pooled over the folds that both heat and cool, so every row is validated alike."""
    folds = tuple(name for name, both in c.fold_directions if both)
    page.heading("Held-out ledger: the error as physics is added", 3)
    if not folds:
        page.text("No fold both heats and cools: the twin's lag and rate term are not validated on this data.")
        return
    order = [m for m in ("px4", "ardupilot", "polynomial", "twin") if m in c.validation.methods]
    order += [m for m in c.validation.methods if m not in order and not m.endswith(AS_APPLIED)]
    page.text(f"Pooled over {', '.join(folds)}.")
    page.table([[m, *(f"{x:.3f}" for x in c.validation.rms_mg(m, "overall", folds))] for m in order
                if any(s.method == m and s.fold in folds for s in c.validation.scores)],
               ["model", *(f"{a} [mg]" for a in AXES)])


def _quality(page: Page, c: ImuCalibration) -> None:
    """What was fitted, and what was excluded and why, per log."""
    for q in c.quality:
        page.text(q.summary())
        page.table([["used" if r.used else "excluded", r.kind, f"{r.from_s:.1f}", f"{r.to_s:.1f}", f"{r.duration_s:.1f}",
                     r.orientation, r.reason] for r in q.table_rows()],
                   ["", "kind", "from [s]", "to [s]", "duration [s]", "face", "why"])


def _summary(c: ImuCalibration) -> list[str]:
    """The IMU's verdict in plain sentences: what each firmware gets, and why this default."""
    rec = c.recommended()
    device = "device id not logged" if c.device_id is None else f"device id {c.device_id}"
    out = [f"IMU {c.instance} ({device}): {c.samples} samples, {c.temperature_span_c[0]:.1f} to "
           f"{c.temperature_span_c[1]:.1f} °C, validated by {c.protocol}.",
           "Recommended: " + "; ".join(f"{label}: {rec.get(k) or 'none (flagged or not fitted)'}" for k, label in
                                       (("px4", "PX4"), ("ardupilot", "ArduPilot"), ("c", "custom C and twin apply")))
           + ". Best per axis: " + ", ".join(f"{a} {m}" for a, m in zip(AXES, c.validation.best_method)) + "."]
    if c.recommendation is not None:
        out.append(f"Why this default: {c.recommendation.reason}.")
        gain = c.recommendation.custom_firmware_gain()
        if gain:
            out.append(gain[0].upper() + gain[1:] + ".")
    return out


def write_calibration_report(directory: Path, calibrations: list[ImuCalibration], logs: dict[int, list[ImuLog]]) -> Path:
    """Write ``report.html`` into ``directory``.

    Parameters
    ----------
    directory : Path
    calibrations : list of ImuCalibration
    logs : dict of int to list of ImuLog
        Each IMU instance's logs, as calibrated.

    Returns
    -------
    Path
    """
    page = Page("Temperature calibration, validated on held-out data",
                [" ".join(_summary(c)) for c in calibrations])  # a paragraph per IMU
    for c in calibrations:
        data = logs[c.instance]
        used = np.concatenate([q.usable_static for q in c.quality]) if c.quality else slice(None)  # the rows fitted
        time_s = np.concatenate([log.time_s for log in data])[used]
        temp = np.concatenate([log.temperature_c for log in data])[used]
        accel = np.concatenate([log.accel_g for log in data])[used]
        run = np.concatenate([np.full(len(log), k) for k, log in enumerate(data)])[used] if len(data) > 1 else None
        X = make_X(time_s, temp, run)
        heating = temperature_rate_c_per_s(1.0, temp) > 0  # the sign only: rows taken as evenly spaced
        device = "device id not logged" if c.device_id is None else f"device id {c.device_id}"
        page.heading(f"IMU {c.instance} ({device})")
        if c.recommendation is not None:
            for v in c.recommendation.verdicts:
                if not v.eligible:
                    page.text(f"Not the default: {v.reason}")
        page.heading("Rows used and excluded", 3)
        _quality(page, c)
        _ledger(page, c)
        page.heading("Held-out RMS by fold", 3)
        _validation(page, c.validation)
        page.text(*c.validation.notes, *c.notes)
        for reasons in (c.flags or {}).values():
            for r in reasons:
                page.text(f"Flagged (not recommended, not exported without --force): {r}")
        if c.gyro is not None:
            gyro_device = "device id not logged" if c.gyro.device_id is None else f"device id {c.gyro.device_id}"
            page.heading(f"Gyro ({gyro_device})", 3)
            _validation(page, c.gyro.validation, "mrad/s")
            for reasons in c.gyro.flags.values():
                for r in reasons:
                    page.text(f"Flagged: {r}")
        if c.orientations:
            page.text(f"Orientations: {c.orientations['kind']}, found {' '.join(c.orientations['found'])}; the residual "
                      "plots are skipped (gravity moves between axes).")
        else:
            page.heading("Residual by method", 3)
            residual = {m: (accel - est.predict(X)) * 1e3 for m, est in c.fitted.items()}
            for i, a in enumerate(AXES):
                disp = ResidualByMethodDisplay(a, temp, {m: r[:, i] for m, r in residual.items()}, heating,
                                               c.validation.noise_floor_mg[i])
                page.figure(png_base64(disp.plot()), disp.title)
        page.heading("Fitted equations", 3)
        for m, est in c.fitted.items():
            if hasattr(est, "equation"):
                page.heading(m, 4).code(est.equation())
    return page.write(directory / "report.html")
