"""Field commands: ``twin calibrate`` (logs → validated compensation), ``twin firmware`` (the file a
flight controller loads) and ``twin apply`` (a new log compensated)."""

from __future__ import annotations

import math
import sys
from pathlib import Path
from typing import Annotated, Optional

import typer

from twin.cli.common import JsonOpt, app, check_outputs, column_map, emit_json, guard, parse_axes
from twin.errors import TwinError

AXES_HELP = "axes to calibrate, comma-separated (default x,y,z)"


def _outputs(output: Path, json_out: str | None) -> list[Path]:
    """The files a command writes, to check against its inputs: ``-o`` and ``--json`` (unless stdout)."""
    return [output] if json_out in (None, "-") else [output, Path(json_out)]


def _distinct(output: Path, json_out: str | None) -> None:
    """``-o`` and ``--json`` must name two files (the second written would replace the first), and
    standard output can carry one document only."""
    if str(output) == "-" and json_out == "-":
        raise TwinError("-o - and --json - both name standard output; it carries one document: give -o a file")
    if json_out not in (None, "-") and Path(json_out).resolve() == Path(output).resolve():
        raise TwinError(f"{json_out}: --json and -o name the same file; choose two paths")


def _rms_rows(v, idx: list[int], unit: str) -> None:
    """The held-out table, a row per method and fold; a firmware method's figure as the vehicle
    applies the written file beside its ideal one."""
    from twin.calibration.document import AS_APPLIED

    fmt = lambda r: " / ".join(f"{r[i]:6.2f}" for i in idx)  # noqa: E731
    ideal = [m for m in v.methods if not m.endswith(AS_APPLIED)]
    for fold in dict.fromkeys(s.fold for s in v.scores):
        typer.echo(f"  {fold}")
        for m in ideal:
            line = f"    {m:<11} {fmt(v.rms_mg(m, fold=fold))}"
            if m + AS_APPLIED in v.methods:
                line += f"   as the vehicle applies the file: {fmt(v.rms_mg(m + AS_APPLIED, fold=fold))}"
            typer.echo(line)


def _print_quality(c) -> None:
    """Which rows the calibration used, and what it excluded and why."""
    for q in c.quality:
        typer.echo(f"  rows used: {q.summary()}")
        excluded = [r for r in q.table_rows() if not r.used]
        for r in excluded[:12]:
            typer.echo(f"    excluded {r.from_s:8.1f}–{r.to_s:8.1f} s  {r.kind:<18} {r.reason}")
        if len(excluded) > 12:
            typer.echo(f"    … {len(excluded) - 12} more excluded stretch(es): see log_quality in the JSON")


def _print_table(c, axes: list[str]) -> None:
    v = c.validation
    idx = [("x", "y", "z").index(a) for a in axes]
    device = "device_id not logged" if c.device_id is None else f"device_id {c.device_id}"
    typer.echo(f"IMU {c.instance} ({device}), {c.samples} samples, "
               f"{c.temperature_span_c[0]:.1f}..{c.temperature_span_c[1]:.1f} °C, protocol: {c.protocol}")
    _print_quality(c)
    typer.echo(f"  held-out RMS [mg] {' / '.join(axes)}   (noise floor "
               f"{' / '.join(f'{v.noise_floor_mg[i]:.2f}' for i in idx)})")
    _rms_rows(v, idx, "mg")
    rec = c.recommended()
    shown = {"px4": "PX4", "ardupilot": "ArduPilot", "c": "custom C"}
    typer.echo("  recommended: " + ", ".join(f"{label} {rec.get(k) or 'none (flagged or not fitted)'}"
                                             for k, label in shown.items())
               + f"; best per axis: {', '.join(f'{a} {v.best_method[i]}' for a, i in zip(axes, idx))}")
    if c.recommendation is not None:
        typer.echo(f"  default of apply and the C export: {c.recommendation.reason}")
        gain = c.recommendation.custom_firmware_gain()
        if gain:
            typer.echo(f"  {gain}")
        for verdict in c.recommendation.verdicts:
            if not verdict.eligible:
                typer.echo(f"    not the default: {verdict.reason}")
    for note in v.notes + c.notes:
        typer.echo(f"  {note}")
    for reason in (r for reasons in (c.flags or {}).values() for r in reasons):
        typer.echo(f"  flagged (not recommended, not exported without --force): {reason}")
    o = c.orientations
    if o:
        typer.echo(f"  orientations: {o['kind']}, found {' '.join(o['found'])}"
                   + (f", missing {' '.join(o['missing'])}" if o["missing"] else "")
                   + "; the methods above were fitted with gravity removed on the static segments")
        for a in axes:
            s, f = o["tcso_ppm_per_c"][a], o["tcoff_mg_per_c"][a]
            tcso = (f"TCSo {s['value']:+.1f} ppm/°C [{s['ci95'][0]:+.1f}, {s['ci95'][1]:+.1f}]"
                    if s["value"] is not None and math.isfinite(s["value"]) else "TCSo not identifiable")
            typer.echo(f"    {a}: {tcso}, "
                       f"TCOff {f['value']:+.4f} mg/°C [{f['ci95'][0]:+.4f}, {f['ci95'][1]:+.4f}], "
                       f"residual {o['residual_rms_mg'][a]:.3f} mg (offset + scale factor, segment means)")
        for reason in o.get("flags", []):
            typer.echo(f"  flagged: {reason}")
    g = c.gyro
    if g is not None:
        gv = g.validation
        typer.echo(f"  gyro ({'device_id not logged' if g.device_id is None else f'device_id {g.device_id}'}): "
                   f"held-out RMS [mrad/s] {' / '.join(axes)}   (noise floor "
                   f"{' / '.join(f'{gv.noise_floor_mg[i]:.3f}' for i in idx)})")
        _rms_rows(gv, idx, "mrad/s")
        rec = g.recommended()
        typer.echo("  gyro recommended: " + ", ".join(f"{label} {rec.get(k) or 'none (flagged or not fitted)'}"
                                                  for k, label in (("px4", "PX4"), ("ardupilot", "ArduPilot"))))
        for reason in (r for reasons in g.flags.values() for r in reasons):
            typer.echo(f"  flagged (not exported without --force): {reason}")


@app.command()
def calibrate(
    logs: Annotated[list[Path], typer.Argument(help="logs of one vehicle or tester: PX4 .ulg, ArduPilot .bin, 3-axis CSV/TSV (several = several runs)")],
    output: Annotated[Path, typer.Option("-o", "--output", help="calibration document to write (JSON)")],
    axes: Annotated[str, typer.Option("--axes", help=AXES_HELP)] = "x,y,z",
    imu: Annotated[str, typer.Option("--imu", help="IMU instance to calibrate, or 'all'")] = "all",
    columns: Annotated[Optional[Path], typer.Option("--columns", help="column-map YAML for delimited logs (keys time, temperature, x, y, z, units)")] = None,
    time_col: Annotated[Optional[str], typer.Option(help="time column of a delimited log")] = None,
    temperature_col: Annotated[Optional[str], typer.Option(help="temperature column")] = None,
    x_col: Annotated[Optional[str], typer.Option(help="x acceleration column")] = None,
    y_col: Annotated[Optional[str], typer.Option(help="y acceleration column")] = None,
    z_col: Annotated[Optional[str], typer.Option(help="z acceleration column")] = None,
    time_unit: Annotated[Optional[str], typer.Option(help="s, ms, us, min, h")] = None,
    output_unit: Annotated[Optional[str], typer.Option(help="g, mg, m/s^2, digits")] = None,
    no_reverse: Annotated[bool, typer.Option("--no-reverse", help="validate heating→cooling only (not also cooling→heating)")] = False,
    device_id: Annotated[Optional[int], typer.Option("--device-id", help="the accelerometer's device id when the log does not record it (a tester's table); PX4 applies TC_An only to the sensor with this id")] = None,
    with_effect: Annotated[Optional[list[str]], typer.Option("--with-effect", help="also fit the twin with this library effect on every axis (repeatable), validated beside the others")] = None,
    effects_from: Annotated[Optional[Path], typer.Option("--effects-from", help="JSON of twin compare --axes …: also fit the twin with the effects it named, per IMU and axis")] = None,
    plugin: Annotated[Optional[list[str]], typer.Option("--plugin", help="effect module (.py path or module name) to load for --with-effect; runs its code")] = None,
    part: Annotated[str, typer.Option("--part", help="part set whose datasheet TCOff/TCSo bound a plausible fit (twin parts)")] = "IIS328DQ",
    report: Annotated[Optional[Path], typer.Option("--report", help="write report.html (tables, residual plots, equations) into DIR")] = None,
    workers: Annotated[Optional[int], typer.Option("--workers", min=1, help="processes calibrating IMUs side by side (default: one per IMU, at most one per CPU)")] = None,
    json_out: JsonOpt = None,
) -> None:
    """Fit the PX4 and ArduPilot methods, a held-out polynomial and the lag-aware twin per IMU;
    validate each on data it was not fitted on (heating vs cooling, or leave one run out).
    \f

    Parameters
    ----------
    logs : list of Path
        Logs of one vehicle or tester (PX4 ``.ulg``, ArduPilot ``.bin``, 3-axis CSV/TSV); one run each.
    output : Path
        The calibration document to write (JSON; ``-``: stdout).
    axes : str
        Axes to calibrate, comma-separated.
    imu : str
        IMU instance to calibrate, or ``all``.
    columns : Path, optional
        Column-map YAML for delimited logs.
    time_col, temperature_col, x_col, y_col, z_col : str, optional
        Columns of a delimited log.
    time_unit, output_unit : str, optional
        Units of the time (s, ms, us, min, h) and acceleration (g, mg, m/s^2, digits) columns.
    no_reverse : bool
        Validate heating→cooling only.
    device_id : int, optional
        The accelerometer's device id when the log does not record it.
    with_effect : list of str, optional
        Library effects the twin also fits on every axis.
    effects_from : Path, optional
        JSON of ``twin compare --axes``: the effects it named, per IMU and axis.
    plugin : list of str, optional
        Effect modules (``.py`` path or module name) to load for ``with_effect``; runs their code.
    part : str
        Part set whose datasheet TCOff [mg/°C] and TCSo [ppm/°C] bound a plausible fit.
    report : Path, optional
        Folder for ``report.html``.
    workers : int, optional
        Processes calibrating IMUs side by side.
    json_out : str, optional
        ``--json``: where the result goes (``-``: stdout).
    """
    from twin.workflows.calibrate import CalibrateOptions, run_calibrate

    extra_inputs = ([columns] if columns else []) + ([effects_from] if effects_from else []) + \
        [Path(p) for p in plugin or [] if p.endswith(".py")]
    with guard(inputs=logs + extra_inputs, outputs=_outputs(output, json_out)):
        _distinct(output, json_out)
        chosen = parse_axes(axes)
        if report is not None and report.exists() and not report.is_dir():
            raise TwinError(f"{report}: exists and is not a folder; --report expects a folder to write into")
        if report is not None:  # checked before the calibration is written, not after
            if report.resolve() in {p.resolve() for p in _outputs(output, json_out)}:
                raise TwinError(f"{report}: --report names a file another output writes; expected a folder of its own")
            check_outputs(logs, [report / "report.html"])
        cmap = column_map(columns, time=time_col, temperature=temperature_col, x=x_col, y=y_col, z=z_col,
                          time_unit=time_unit, output_unit=output_unit)
        run = run_calibrate(CalibrateOptions.build(
            logs=logs, columns=cmap, imu=imu, reverse=not no_reverse, device_id=device_id,
            with_effects=with_effect or [], effects_from=effects_from, plugins=plugin or [], part=part,
            workers=workers))
        results, skipped, doc = run.calibrations, run.skipped, run.document.to_json()
        emit_json(doc, str(output))
        if report is not None:
            run.write_report(report)
    if json_out != "-" and str(output) != "-":  # standard output carries the document alone
        for c in results:
            _print_table(c, chosen)
        for instance, reason in sorted(skipped.items()):
            typer.echo(f"IMU {instance}: not calibrated: {reason}")
        if report is not None:
            typer.echo(f"report: {report / 'report.html'}")
        typer.echo(f"wrote {output}; firmware files: twin firmware {output} --format px4|ardupilot|json|c -o FILE")
    with guard():
        emit_json(doc, json_out)


@app.command()
def firmware(
    calibration: Annotated[Path, typer.Argument(help="calibration document from twin calibrate")],
    fmt: Annotated[str, typer.Option("--format", help="px4 (.params for QGroundControl), ardupilot (.parm), json, c (header)")],
    output: Annotated[Path, typer.Option("-o", "--output", help="file to write")],
    method: Annotated[Optional[str], typer.Option("--method", help="method to export (default: the recommended one for the format)")] = None,
    imu: Annotated[Optional[int], typer.Option("--imu", help="IMU instance (json and c write one)")] = None,
    sample_rate_hz: Annotated[Optional[float], typer.Option("--sample-rate-hz", help="rate the firmware runs the lag filters at (c) [Hz]")] = None,
    device_id: Annotated[Optional[int], typer.Option("--device-id", help="the sensor's device id, when the calibration has none (px4: TC_An_ID)")] = None,
    gyro_device_id: Annotated[Optional[int], typer.Option("--gyro-device-id", help="the gyro's device id, when the calibration has none (px4: TC_Gn_ID)")] = None,
    force: Annotated[bool, typer.Option("--force", help="export a method the calibration flagged as implausible")] = False,
    json_out: JsonOpt = None,
) -> None:
    """Write the compensation in the exact format a flight controller or custom firmware loads.
    \f

    Parameters
    ----------
    calibration : Path
        Calibration document from ``twin calibrate``.
    fmt : {"px4", "ardupilot", "json", "c"}
        ``--format``.
    output : Path
        The file to write.
    method : str, optional
        Method to export (default: the format's recommended one).
    imu : int, optional
        IMU instance (json and c write one).
    sample_rate_hz : float, optional
        Rate the firmware runs the lag filters at (c) [Hz].
    device_id, gyro_device_id : int, optional
        The accelerometer's and gyro's device ids when the calibration has none (px4).
    force : bool
        Export a method the calibration flagged as implausible.
    json_out : str, optional
        ``--json``: where the result goes (``-``: stdout).
    """
    from twin.calibration.deploy import export_calibration, read_calibration
    from twin.calibration.field_result import FirmwareResult

    with guard(inputs=[calibration], outputs=_outputs(output, json_out)):
        _distinct(output, json_out)
        if sample_rate_hz is not None and not 1e-3 <= sample_rate_hz < 1e6:
            raise TwinError(f"--sample-rate-hz must be in [0.001, 1e6) Hz, got {sample_rate_hz}")
        doc = read_calibration(calibration)
        written = export_calibration(doc, fmt, output, method=method, instance=imu, sample_rate_hz=sample_rate_hz,
                                     device_id=device_id, gyro_device_id=gyro_device_id, force=force)
    result = FirmwareResult(output=str(output), format=fmt, method=written.methods[0] if len(set(written.methods)) == 1
                            else tuple(written.methods), imu=imu, lines=written.lines, notes=tuple(written.notes))
    if json_out != "-":
        checked = ", read back and checked as the ground station loads it" if fmt in ("px4", "ardupilot") else ""
        typer.echo(f"wrote {output} ({fmt}, {written.lines} lines{checked})")
        for note in written.notes:
            typer.echo(f"  {note}")
    with guard():
        emit_json(result.to_json(), json_out)


@app.command()
def apply(
    calibration: Annotated[Path, typer.Argument(help="calibration document from twin calibrate")],
    log: Annotated[Path, typer.Argument(help="a new log of the same IMU")],
    output: Annotated[Path, typer.Option("-o", "--output", help="compensated CSV to write")],
    method: Annotated[Optional[str], typer.Option("--method", help="method to apply (default: the best deployable)")] = None,
    imu: Annotated[Optional[int], typer.Option("--imu", help="IMU instance of the log (default: the calibrated one)")] = None,
    applied_g: Annotated[Optional[str], typer.Option("--applied-g", help="true acceleration per axis 'gx,gy,gz' [g] for a residual summary")] = None,
    columns: Annotated[Optional[Path], typer.Option("--columns", help="column-map YAML for delimited logs")] = None,
    force: Annotated[bool, typer.Option("--force", help="apply a method the calibration flagged as implausible")] = False,
    json_out: JsonOpt = None,
) -> None:
    """Compensate a new log with a calibration: time, temperature, raw and compensated x, y, z.
    \f

    Parameters
    ----------
    calibration : Path
        Calibration document from ``twin calibrate``.
    log : Path
        A new log of the same IMU.
    output : Path
        The compensated CSV to write (accelerations in g, time in s, temperature in °C).
    method : str, optional
        Method to apply (default: the best deployable).
    imu : int, optional
        IMU instance of the log (default: the calibrated one).
    applied_g : str, optional
        True acceleration per axis ``gx,gy,gz`` [g], for a residual summary [mg].
    columns : Path, optional
        Column-map YAML for delimited logs.
    force : bool
        Apply a method the calibration flagged as implausible.
    json_out : str, optional
        ``--json``: where the result goes (``-``: stdout).
    """
    import dataclasses

    import numpy as np

    from twin.calibration.deploy import correction_g, imu_entry, method_entry, read_calibration
    from twin.calibration.field_result import ApplyResult
    from twin.diagnosis.axes import APPLIED_TOLERANCE_G
    from twin.io import atomic_write_text
    from twin.measurement import ColumnMap, read_imu_logs
    from twin.results import PerAxis

    with guard(inputs=[calibration, log] + ([columns] if columns else []), outputs=_outputs(output, json_out)):
        _distinct(output, json_out)
        doc = read_calibration(calibration)
        logs = read_imu_logs(log, ColumnMap.from_yaml(columns) if columns else None)
        target = imu if imu is not None else (doc["imus"][0]["instance"] if len(doc["imus"]) == 1 else None)
        imu_log = next((x for x in logs if target is None or x.instance == target), None)
        if imu_log is None:
            raise TwinError(f"{log}: no IMU instance {target}; the log holds {[x.instance for x in logs]}")
        entry = imu_entry(doc, imu_log.instance, imu_log.device_id, str(calibration))
        name, data = method_entry(entry, method, "c", force=force)
        corrected = imu_log.accel_g - correction_g(data, imu_log.time_s, imu_log.temperature_c)
        span = entry["temperature_span_c"]
        outside = float(np.mean((imu_log.temperature_c < span[0]) | (imu_log.temperature_c > span[1])))
        result = ApplyResult(output=str(output), method=name, instance=imu_log.instance, rows=len(imu_log),
                             extrapolated_fraction=outside)
        if applied_g is not None:
            try:
                truth = [float(v) for v in applied_g.split(",")]
            except ValueError:
                truth = []
            if len(truth) != 3 or not np.all(np.isfinite(truth)):
                raise TwinError(f"--applied-g expects 'gx,gy,gz' in g, got {applied_g!r}")
            offset = np.median(corrected - np.asarray(truth), axis=0)
            bad = [(a, t, t + o) for a, t, o in zip("xyz", truth, offset) if abs(o) > APPLIED_TOLERANCE_G]
            if bad:  # the summary is about the given g: one the log contradicts would summarise nothing
                a, t, read = bad[0]
                raise TwinError(f"{log}: --applied-g gives {a} = {t:+g} g, but the compensated log reads {read:+.2f} g "
                                f"there (median; tolerance {APPLIED_TOLERANCE_G:g} g); give the orientation it was in")
            res = corrected - np.asarray(truth) - offset
            raw = imu_log.accel_g - np.median(imu_log.accel_g, axis=0)
            result = dataclasses.replace(result, residual_rms_mg=PerAxis.of(map(float, np.sqrt(np.mean(res ** 2, axis=0)) * 1e3)),
                                         raw_rms_mg=PerAxis.of(map(float, np.sqrt(np.mean(raw ** 2, axis=0)) * 1e3)))
        header = "time_s,temperature_c," + ",".join(f"{a}_raw_g,{a}_compensated_g" for a in "xyz")
        table = np.column_stack([imu_log.time_s, imu_log.temperature_c] +
                                [c for i in range(3) for c in (imu_log.accel_g[:, i], corrected[:, i])])
        atomic_write_text(output, header + "\n" + "\n".join(",".join(f"{v:.9g}" for v in row) for row in table) + "\n")
    if json_out != "-":
        typer.echo(f"wrote {output}: {len(imu_log)} rows compensated with {name}"
                   + (f"; {100 * outside:.0f} % of the log outside the calibrated range (extrapolated)" if outside else ""))
        if result.residual_rms_mg is not None and result.raw_rms_mg is not None:
            raw_rms, res_rms = result.raw_rms_mg, result.residual_rms_mg
            typer.echo("  RMS about the applied g [mg] x / y / z: raw "
                       + " / ".join(f"{v:.2f}" for v in (raw_rms.x, raw_rms.y, raw_rms.z)) + ", compensated "
                       + " / ".join(f"{v:.2f}" for v in (res_rms.x, res_rms.y, res_rms.z)))
    with guard():
        emit_json(result.to_json(), json_out)
    sys.stdout.flush()
