"""``twin calibrate --report DIR``: one HTML page per calibration — the held-out table per IMU and
axis beside the noise floor, the recommendation, each method's equation, and residual plots."""

from __future__ import annotations

import html
from pathlib import Path

import numpy as np

from twin.calibration.lag import make_X
from twin.calibration.models import AXES
from twin.calibration.document import AS_APPLIED
from twin.calibration.workflow import ImuCalibration
from twin.io import atomic_write_text
from twin.measurement import ImuLog
from twin.reporting.plots import png_base64
from twin.reporting.study_plots import ResidualByMethodDisplay


def _table(v, unit: str = "mg") -> str:
    head = "<tr><th>fold: test</th><th>method</th>" + "".join(f"<th>{a} [{unit}]</th>" for a in AXES) + \
           "<th>extrapolated</th></tr>"
    rows = "".join(f"<tr><td>{html.escape(s.fold)}: {html.escape(s.test)}</td><td>{s.method}</td>"
                   + "".join(f"<td>{x:.3f}</td>" for x in s.rms_mg) + f"<td>{100 * s.extrapolated_fraction:.0f} %</td></tr>"
                   for s in v.scores)
    floor = "<tr><td colspan=2>noise floor</td>" + "".join(f"<td>{x:.3f}</td>" for x in v.noise_floor_mg) + "<td></td></tr>"
    note = (f"<p>'&lt;method&gt;{AS_APPLIED}': the file written for the method, applied as the vehicle applies it "
            "(float32; PX4 republishes its offset only after the temperature moved more than 1 °C, checked once a "
            "second; ArduPilot re-references at the calibration temperature).</p>")
    return f"<table>{head}{rows}{floor}</table>{note}"


def _ledger(c: ImuCalibration) -> str:
    """Held-out RMS per axis as physics is added (static cubic → the twin's lag and rate term → the
    composed effects), pooled over the folds that both heat and cool, so every row is validated alike."""
    folds = tuple(name for name, both in c.fold_directions if both)
    if not folds:
        return "<p>No fold both heats and cools: the twin's lag and rate term are not validated on this data.</p>"
    order = [m for m in ("px4", "ardupilot", "polynomial", "twin") if m in c.validation.methods]
    order += [m for m in c.validation.methods if m not in order and not m.endswith(AS_APPLIED)]
    rows = "".join(f"<tr><td>{html.escape(m)}</td>" + "".join(f"<td>{x:.3f}</td>" for x in c.validation.rms_mg(
        m, "overall", folds)) + "</tr>" for m in order if any(s.method == m and s.fold in folds for s in c.validation.scores))
    return (f"<h3>Held-out ledger: the error as physics is added</h3><p>Pooled over {html.escape(', '.join(folds))}.</p>"
            "<table><tr><th>model</th>" + "".join(f"<th>{a} [mg]</th>" for a in AXES) + f"</tr>{rows}</table>")


def _quality(c: ImuCalibration) -> str:
    """What was fitted, and what was excluded and why, per log."""
    out = []
    for q in c.quality:
        rows = "".join(f"<tr><td>{'used' if r.used else 'excluded'}</td><td>{html.escape(r.kind)}</td>"
                       f"<td>{r.from_s:.1f}</td><td>{r.to_s:.1f}</td><td>{r.duration_s:.1f}</td>"
                       f"<td>{html.escape(r.orientation)}</td><td>{html.escape(r.reason)}</td></tr>"
                       for r in q.table_rows())
        out.append(f"<p>{html.escape(q.summary())}</p><table><tr><th></th><th>kind</th><th>from [s]</th>"
                   f"<th>to [s]</th><th>duration [s]</th><th>face</th><th>why</th></tr>{rows}</table>")
    return "".join(out)


def write_calibration_report(directory: Path, calibrations: list[ImuCalibration], logs: dict[int, list[ImuLog]]) -> Path:
    """Write ``report.html`` into ``directory``; ``logs``: each IMU instance's logs, as calibrated."""
    parts = []
    for c in calibrations:
        data = logs[c.instance]
        used = np.concatenate([q.usable_static for q in c.quality]) if c.quality else slice(None)  # the rows fitted
        time_s = np.concatenate([log.time_s for log in data])[used]
        temp = np.concatenate([log.temperature_c for log in data])[used]
        accel = np.concatenate([log.accel_g for log in data])[used]
        run = np.concatenate([np.full(len(log), k) for k, log in enumerate(data)])[used] if len(data) > 1 else None
        X = make_X(time_s, temp, run)
        heating = np.gradient(temp) > 0
        parts.append(f"<h2>IMU {c.instance} (device_id {c.device_id}), {c.samples} samples, "
                     f"{c.temperature_span_c[0]:.1f}…{c.temperature_span_c[1]:.1f} °C — {html.escape(c.protocol)}</h2>")
        rec = c.recommended()
        parts.append("<p>Recommended: " + html.escape(", ".join(
            f"{label} {rec.get(k) or 'none (flagged or not fitted)'}" for k, label in
            (("px4", "PX4"), ("ardupilot", "ArduPilot"), ("c", "custom C and twin apply")))) + "; best per axis: "
                     f"{html.escape(', '.join(f'{a} {m}' for a, m in zip(AXES, c.validation.best_method)))}</p>")
        if c.recommendation is not None:
            parts.append(f"<p>Why this default: {html.escape(c.recommendation.reason)}</p>")
            gain = c.recommendation.custom_firmware_gain()
            if gain:
                parts.append(f"<p>{html.escape(gain[0].upper() + gain[1:])}.</p>")
            parts.extend(f"<p>Not the default: {html.escape(v.reason)}</p>" for v in c.recommendation.verdicts
                         if not v.eligible)
        parts.append(_quality(c))
        parts.append(_ledger(c))
        parts.append(_table(c.validation))
        parts.extend(f"<p>{html.escape(n)}</p>" for n in c.validation.notes + c.notes)
        parts.extend(f"<p><b>flagged</b> (not recommended, not exported without --force): {html.escape(r)}</p>"
                     for reasons in (c.flags or {}).values() for r in reasons)
        if c.gyro is not None:
            parts.append(f"<h3>Gyro (device_id {c.gyro.device_id})</h3>" + _table(c.gyro.validation, "mrad/s"))
            parts.extend(f"<p><b>flagged</b>: {html.escape(r)}</p>" for reasons in c.gyro.flags.values() for r in reasons)
        if c.orientations:
            parts.append(f"<p>Orientations: {html.escape(c.orientations['kind'])}, found "
                         f"{' '.join(c.orientations['found'])}; the residual plots are skipped (gravity moves between axes).</p>")
        else:
            residual = {m: (accel - est.predict(X)) * 1e3 for m, est in c.fitted.items()}
            for i, a in enumerate(AXES):
                disp = ResidualByMethodDisplay(a, temp, {m: r[:, i] for m, r in residual.items()}, heating,
                                               c.validation.noise_floor_mg[i])
                parts.append(f"<h3>{html.escape(disp.title)}</h3><img src='data:image/png;base64,{png_base64(disp.plot())}'>")
        parts.extend(f"<h3>{m}</h3><pre>{html.escape(est.equation())}</pre>" for m, est in c.fitted.items()
                     if hasattr(est, "equation"))
    page = ("<!doctype html><html><head><meta charset='utf-8'><title>twin calibrate</title><style>"
            "body{font-family:sans-serif;max-width:1100px;margin:auto} td,th{border:1px solid #ccc;padding:2px 6px;"
            "font-size:13px}</style></head><body><h1>Temperature calibration, validated on held-out data</h1>"
            + "".join(parts) + "</body></html>")
    directory.mkdir(parents=True, exist_ok=True)
    return atomic_write_text(directory / "report.html", page)
