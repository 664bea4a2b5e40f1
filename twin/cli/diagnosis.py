"""``twin compare``: calibrate the twin to a measurement, show where it fails, name the missing effect."""

from __future__ import annotations

import sys
from pathlib import Path
from typing import Annotated, Optional

import typer

from twin.cli.common import JsonOpt, app, column_map, emit_json, guard, parse_axes
from twin.errors import TwinError


def _json_apart_from_report(json_out: str | None, report: Path | None) -> None:
    """--json never names a file the report (or the ledger beside the JSON) writes: the second write
    would replace the first, and the run would still exit 0."""
    if json_out in (None, "-"):
        return
    from twin.finding.discovery import PLUGIN_NAME
    from twin.finding.ledger import LEDGER

    target = Path(json_out).resolve()
    owned = {"report.html", LEDGER, PLUGIN_NAME}
    in_report = report is not None and (target.parent == report.resolve() or (
        target.parent.parent == report.resolve() and target.parent.name.startswith("imu")))
    if target.name == LEDGER or (in_report and target.name in owned):
        raise TwinError(f"{json_out}: --json names a file the {'report' if in_report else 'ledger'} writes "
                        f"({target.name}); choose another name")


@app.command()
def compare(
    scenario: Annotated[Path, typer.Argument(help="scenario YAML: its twin, device.sensor and test_plan")],
    measurements: Annotated[list[Path], typer.Argument(help="measurement file(s): canonical CSV, any log with a column map, or a twin HDF5 (read blind); several files = several runs")],
    with_effect: Annotated[Optional[list[str]], typer.Option("--with-effect", help="add this effect to the twin (repeatable)")] = None,
    report: Annotated[Optional[Path], typer.Option("--report", help="write report.html and the ledger into DIR")] = None,
    applied_g: Annotated[Optional[str], typer.Option("--applied-g", help="acceleration along the axis when not logged [g], or 'unknown' (default: 1; with --axes: from the face of each static stretch); refused when the static rows read more than 0.1 g otherwise")] = None,
    axes: Annotated[Optional[str], typer.Option("--axes", help="compare these axes of a 3-axis log, e.g. x,y,z (per axis and per IMU)")] = None,
    imu: Annotated[str, typer.Option("--imu", help="with --axes: IMU instance, or 'all'")] = "all",
    x_col: Annotated[Optional[str], typer.Option(help="x acceleration column of a delimited 3-axis log")] = None,
    y_col: Annotated[Optional[str], typer.Option(help="y acceleration column")] = None,
    z_col: Annotated[Optional[str], typer.Option(help="z acceleration column")] = None,
    columns: Annotated[Optional[Path], typer.Option("--columns", help="column-map YAML for real logs")] = None,
    time_col: Annotated[Optional[str], typer.Option(help="time column (name or 0-based index)")] = None,
    temperature_col: Annotated[Optional[str], typer.Option(help="temperature column")] = None,
    output_col: Annotated[Optional[str], typer.Option(help="acceleration column")] = None,
    time_unit: Annotated[Optional[str], typer.Option(help="s, ms, us, min, h")] = None,
    temperature_unit: Annotated[Optional[str], typer.Option(help="C, K or F")] = None,
    output_unit: Annotated[Optional[str], typer.Option(help="g, mg, m/s^2, digits")] = None,
    output_scale: Annotated[Optional[float], typer.Option(help="multiply the output after unit conversion")] = None,
    skip_lines: Annotated[Optional[int], typer.Option(min=0, help="banner lines to skip")] = None,
    delimiter: Annotated[Optional[str], typer.Option(help="column delimiter (default: sniffed)")] = None,
    no_header: Annotated[bool, typer.Option("--no-header", help="the file has no header line (columns by index)")] = False,
    sample_rate_hz: Annotated[Optional[float], typer.Option(help="sample rate for logs without a time column [Hz]")] = None,
    skip_bad_rows: Annotated[bool, typer.Option("--skip-bad-rows", help="skip corrupted rows and report how many")] = False,
    average_s: Annotated[float, typer.Option(min=0.1, max=1e7, help="screening block average [s]")] = 10.0,
    discover: Annotated[bool, typer.Option("--discover", help="when the library leaves structure, search a dictionary of terms for the missing one and write it as a plugin")] = False,
    discover_plugin: Annotated[Optional[Path], typer.Option("--discover-plugin", help="with --discover: write the discovered effect here (default: REPORT/discovered_effect.py)")] = None,
    plugin: Annotated[Optional[list[str]], typer.Option("--plugin", help="effect module (.py path or module name) to load and add to the twin; runs its code")] = None,
    json_out: JsonOpt = None,
) -> None:
    """Compare the twin with a measurement: calibrate, show where it fails, name the missing effect.
    \f

    Parameters
    ----------
    scenario : Path
        Scenario YAML: its twin, ``device.sensor`` and ``test_plan``.
    measurements : list of Path
        Measurement files (canonical CSV, a log with a column map, a twin HDF5 read blind); one
        run each.
    with_effect : list of str, optional
        Effects added to the twin.
    report : Path, optional
        Folder for ``report.html`` and the ledger.
    applied_g : str, optional
        Acceleration along the axis when not logged [g], or ``unknown``.
    axes : str, optional
        Axes of a 3-axis log to compare, e.g. ``x,y,z``.
    imu : str
        With ``axes``: the IMU instance, or ``all``.
    x_col, y_col, z_col, time_col, temperature_col, output_col : str, optional
        Columns (name or 0-based index) of a delimited log.
    columns : Path, optional
        Column-map YAML.
    time_unit, temperature_unit, output_unit : str, optional
        Units of the columns (s, ms, us, min, h; C, K, F; g, mg, m/s^2, digits).
    output_scale : float, optional
        Factor on the output after unit conversion [1].
    skip_lines : int, optional
        Banner lines to skip.
    delimiter : str, optional
        Column delimiter (default: sniffed).
    no_header : bool
        The file has no header line.
    sample_rate_hz : float, optional
        Sample rate of a log without a time column [Hz].
    skip_bad_rows : bool
        Skip corrupted rows and report how many.
    average_s : float
        Screening block average [s].
    discover : bool
        Search a dictionary of terms for the missing effect and write it as a plugin.
    discover_plugin : Path, optional
        Where the discovered effect is written (default: ``REPORT/discovered_effect.py``).
    plugin : list of str, optional
        Effect modules (``.py`` path or module name) to load and add to the twin; runs their code.
    json_out : str, optional
        ``--json``: where the result goes (``-``: stdout).
    """
    from twin.workflows.compare import CompareOptions, run_compare

    inputs = [scenario, *measurements] + ([columns] if columns else []) + [Path(p) for p in plugin or [] if p.endswith(".py")]
    with guard(inputs=inputs, outputs=[None if json_out == "-" else json_out, discover_plugin]):
        _json_apart_from_report(json_out, report)
        cmap = column_map(columns, time=time_col, temperature=temperature_col, output=output_col, time_unit=time_unit,
                          temperature_unit=temperature_unit, output_unit=output_unit, output_scale=output_scale,
                          skip_lines=skip_lines, delimiter=delimiter,
                          **({"x": x_col, "y": y_col, "z": z_col} if axes else {}))
        if no_header:
            cmap.header = False
        if sample_rate_hz is not None:
            cmap.sample_rate_hz, cmap.time = sample_rate_hz, None
        opts = CompareOptions.build(
            scenario=scenario, measurements=measurements, columns=cmap, with_effects=with_effect or [],
            plugins=plugin or [], applied_g=_applied(applied_g), axes=parse_axes(axes) if axes else None, imu=imu,
            skip_bad_rows=skip_bad_rows, average_s=average_s, discover=discover, discover_plugin=discover_plugin,
            report=report, ledger_dir=Path(json_out).parent if json_out not in (None, "-") else None)
        from tqdm import tqdm

        from twin.diagnosis.screen import screening_progress

        # a bar on a terminal only, after 2 s of screening (long logs), never with --json -
        with tqdm(desc="screening", unit="fit", file=sys.stderr, leave=False, delay=2.0,
                  disable=True if json_out == "-" else None) as bar, screening_progress(bar.update):
            result = run_compare(opts)
    if json_out != "-":
        _echo_result(result, report)
    emit_json(result.to_json(), json_out)


def _echo_result(result, report: Path | None) -> None:
    """The finding and the figures a person reads first (all of it is in the JSON)."""
    typer.echo(result.finding)
    if hasattr(result, "imus"):
        for imu_result in result.imus:
            _echo_quality(imu_result.log_quality)
            for axis, r in imu_result.axes.items():
                g = _orientation_text(imu_result.orientation_applied_g[axis], imu_result.orientation_per_stretch[axis])
                typer.echo(f"  IMU {imu_result.instance} {axis} ({g}): residual {r.rms_residual_g * 1e3:.3f} mg, "
                           f"floor {r.noise_floor_g * 1e3:.3f} mg, named: {', '.join(r.selected) or '-'} "
                           f"({r.confidence})")
        return
    named = ", ".join(result.selected) or "none"
    typer.echo(f"residual RMS {result.rms_residual_g * 1e3:.3f} mg, noise floor {result.noise_floor_g * 1e3:.3f} mg, "
               f"named missing: {named} ({result.confidence})")
    for c in result.candidates[:5]:
        typer.echo(f"  {c.effect:<20} {c.family:<13} {'significant' if c.significant else '-':<12} "
                   f"ΔBIC {c.delta_bic:9.1f}  gain {100 * c.heldout_gain:5.1f} %  RMS after {c.rms_residual_g * 1e3:.3f} mg")
    if report:
        typer.echo(f"report: {report / 'report.html'}")


def _echo_quality(qualities, most: int = 8) -> None:
    """What each log lost before the comparison, and why (all of it is in the JSON)."""
    for q in qualities:
        dropped = [r for r in q.stretches if not r.used]
        lost = sum(r.duration_s for r in dropped)
        typer.echo(f"  {q.where}: {q.static_s:.0f} s static, {lost:.0f} s excluded before the comparison")
        for r in dropped[:most]:
            typer.echo(f"    {r.kind:<18} {r.from_s:9.1f}–{r.to_s:9.1f} s  {r.reason}")
        if len(dropped) > most:
            typer.echo(f"    … {len(dropped) - most} more excluded stretches in the JSON (log_quality)")


def _orientation_text(applied, stretches) -> str:
    """The g applied on an axis: one value, unknown, or the seconds of static rows at each value."""
    if applied != "per stretch":
        return applied if applied == "unknown" else f"{applied:g} g"
    seconds: dict[float, float] = {}
    for s in stretches:
        if s.applied_g is not None:
            seconds[s.applied_g] = seconds.get(s.applied_g, 0.0) + s.to_s - s.from_s
    return "per static stretch: " + ", ".join(f"{g:+g} g on {sec:.0f} s" for g, sec in seconds.items())


def _applied(text: str | None) -> float | str | None:
    """--applied-g as g, 'unknown', or None (not given)."""
    if text is None or text == "unknown":
        return text
    try:
        return float(text)
    except ValueError:
        raise TwinError(f"--applied-g expects a number in g or 'unknown', got {text!r}") from None
