"""Model commands: simulate a scenario, inspect its parts, effects and comb, render it, export a dataset."""

from __future__ import annotations

import dataclasses
import importlib.util
import json
import math
import sys
from pathlib import Path
from typing import Annotated, Optional

import typer

from twin.cli.common import JsonOpt, app, check_outputs, emit_json, fail, guard
from twin.errors import TwinError
from twin.results import to_json


@app.command()
def run(
    scenario: Annotated[Path, typer.Argument(help="scenario YAML")],
    output: Annotated[Optional[Path], typer.Option("-o", "--output", help="HDF5 file to write")] = None,
    seed: Annotated[Optional[int], typer.Option("--seed", min=0, help="override the scenario's seed")] = None,
    quiet: Annotated[bool, typer.Option("--quiet", "-q", help="no progress bar")] = False,
    json_out: JsonOpt = None,
) -> None:
    """Simulate a chamber test and write the dataset (HDF5) with its ground truth.
    \f

    Parameters
    ----------
    scenario : Path
        Scenario YAML.
    output : Path, optional
        HDF5 file to write (default: the scenario's ``output.path``, else the scenario with ``.h5``).
    seed : int, optional
        Overrides the scenario's seed.
    quiet : bool
        No progress bar, no summary line.
    json_out : str, optional
        ``--json``: where the result goes (``-``: stdout).
    """
    from tqdm import tqdm

    from twin.model.dataset import write_hdf5
    from twin.model.scenario import load_scenario
    from twin.model.simulate import STAGES, simulate, summary

    out = output
    try:
        loaded = load_scenario(scenario)
        out = output or (Path(loaded.scenario.output.path) if loaded.scenario.output.path else scenario.with_suffix(".h5"))
        check_outputs([scenario], [out, None if json_out == "-" else json_out])
        # tqdm disables itself when stderr is not a terminal (logs, CI).
        with tqdm(total=len(STAGES) + 1, desc="simulate", unit="stage", disable=True if quiet else None,
                  leave=False, file=sys.stderr) as bar:
            def tick(stage: str) -> None:
                bar.set_description(stage)
                bar.update(0 if bar.n == 0 and stage == STAGES[0] else 1)

            ds = simulate(loaded, seed=seed, progress=tick)
            bar.set_description("write HDF5")
            bar.update(1)
            write_hdf5(ds, out, compression=loaded.scenario.output.compression)
            bar.update(1)
    except TwinError as exc:
        fail(str(exc))
    except OSError as exc:
        fail(f"cannot write {out}: {exc.strerror or exc}")
    except MemoryError:
        fail(f"{scenario}: out of memory while simulating; shorten the program or lower test_plan.logger_rate_hz")
    result = dataclasses.replace(summary(ds), output=str(out))
    if not quiet and json_out != "-":
        typer.echo(
            f"wrote {out}: {result.samples} samples, {result.duration_h:.2f} h, die "
            f"{result.die_range_c[0]:.1f}..{result.die_range_c[1]:.1f} °C, drift "
            f"{result.drift_range_mg[0]:.2f}..{result.drift_range_mg[1]:.2f} mg, white noise "
            f"{result.white_noise_sigma_mg:.3f} mg"
        )
    emit_json(to_json(result), json_out)


@app.command()
def schema(
    output: Annotated[Optional[Path], typer.Option("-o", "--output", help="write the schema here")] = None,
    result: Annotated[Optional[str], typer.Option("--result", help="instead of scenario files: the schema of a command's --json, by its name (compare, calibration, fleet, run, …; an unknown name lists them all)")] = None,
    json_out: JsonOpt = None,
) -> None:
    """Print the JSON Schema of scenario files (for editors), or with --result of a command's --json output.
    \f

    Parameters
    ----------
    output : Path, optional
        Write the schema here instead of printing it.
    result : str, optional
        The command whose ``--json`` schema is wanted (compare, fleet, fleet-simulate, doe, calibration).
    json_out : str, optional
        ``--json``: where the result goes (``-``: stdout).
    """
    if result is not None:
        from twin.workflows.schemas import result_schema

        with guard():
            s = result_schema(result)
    else:
        from twin.model.scenario import scenario_json_schema

        s = scenario_json_schema()
    if output is not None:
        from twin.io import atomic_write_text

        try:
            check_outputs([], [output])
            atomic_write_text(output, json.dumps(s, indent=2) + "\n")
        except (TwinError, OSError) as exc:
            fail(str(exc) if isinstance(exc, TwinError) else f"cannot write {output}: {exc.strerror or exc}")
    elif json_out is None:
        typer.echo(json.dumps(s, indent=2))
    emit_json(s, json_out)


@app.command("test-design")
def test_design(
    lsb_mg: Annotated[Optional[float], typer.Option(min=0, help="sensitivity, 1 LSB [mg] (default: the IIS328DQ part's at its lowest full scale; twin parts)")] = None,
    tcoff_mg_per_c: Annotated[Optional[float], typer.Option(min=0, help="|TCOff| [mg/°C] (default: the IIS328DQ part's; twin parts)")] = None,
    tcso_pct_per_c: Annotated[float, typer.Option(min=0, help="TCSo as printed in eq. (33) [%/°C]")] = 0.02,
    chamber_length_m: Annotated[float, typer.Option(min=0, help="chamber length L [m]")] = 0.6,
    json_out: JsonOpt = None,
) -> None:
    """The paper's test-design numbers (eqs. 31-35) beside physically consistent time scales.
    \f

    Parameters
    ----------
    lsb_mg : float, optional
        Sensitivity, 1 LSB [mg] (default: the IIS328DQ part's at its lowest full scale).
    tcoff_mg_per_c : float, optional
        |TCOff| [mg/°C] (default: the IIS328DQ part's).
    tcso_pct_per_c : float
        TCSo as printed in eq. (33) [%/°C].
    chamber_length_m : float
        Chamber length L [m].
    json_out : str, optional
        ``--json``: where the result goes (``-``: stdout).

    References
    ----------
    Qi et al. (2022), Micromachines 13, 2156, eqs. (31)–(35).
    """
    from twin.reporting.paper import design_report

    from twin.parts import design_figures
    rows = design_report(*design_figures(lsb_mg, tcoff_mg_per_c), tcso_pct_per_c, chamber_length_m)
    if json_out != "-":
        for row in rows.items:
            typer.echo(f"{row.name:<44} {row.value:>12.6g} {row.unit:<8} {row.note}")
    emit_json(to_json(rows), json_out)


@app.command()
def paper(json_out: JsonOpt = None) -> None:
    """Each derived number of the paper next to what the code computes, with a verdict.
    \f

    Parameters
    ----------
    json_out : str, optional
        ``--json``: where the result goes (``-``: stdout).

    References
    ----------
    Qi et al. (2022), Micromachines 13, 2156.
    """
    from twin.reporting.paper import paper_report

    report = paper_report()
    if json_out != "-":
        for it in report.items:
            printed = "-" if it.paper is None else f"{it.paper:.6g}" if isinstance(it.paper, float) else str(it.paper)
            computed = f"{it.computed:.6g}" if isinstance(it.computed, float) else str(it.computed)
            typer.echo(f"{it.item:<34} paper {printed:>10}  code {computed:>12} {it.unit:<8} {it.verdict}")
        typer.echo(f"{report.reproduced} reproduced, {report.differs} differ, {report.computed} computed (not in the paper)")
    emit_json(to_json(report), json_out)


@app.command()
def comb(
    scenario: Annotated[Path, typer.Argument(help="scenario YAML (its device.geometry)")],
    acceleration_g: Annotated[float, typer.Option("--acceleration-g", help="input acceleration [g]")] = 1.0,
    t_low_c: Annotated[float, typer.Option(help="sweep start [°C]")] = -20.0,
    t_high_c: Annotated[float, typer.Option(help="sweep end [°C]")] = 50.0,
    json_out: JsonOpt = None,
) -> None:
    """Comb thermal drift under each reading (P, S, H, HE): offset and scale-factor parts.
    \f

    Parameters
    ----------
    scenario : Path
        Scenario YAML (its ``device.geometry``).
    acceleration_g : float
        Input acceleration [g].
    t_low_c, t_high_c : float
        Sweep start and end [°C].
    json_out : str, optional
        ``--json``: where the result goes (``-``: stdout).
    """
    from twin.reporting.comb import comb_report
    from twin.model.scenario import load_scenario

    try:
        loaded = load_scenario(scenario)
        from twin.reporting.render import check_temperature_c

        check_temperature_c(t_low_c, "--t-low-c")
        check_temperature_c(t_high_c, "--t-high-c")
        if not (math.isfinite(acceleration_g) and abs(acceleration_g) <= 1000):
            raise ValueError(f"--acceleration-g {acceleration_g:g}: expected a finite value within ±1000 g")
        check_outputs([scenario], [None if json_out == "-" else json_out])
        report = comb_report(loaded.geometry(), acceleration_g, t_low_c, t_high_c)
    except (TwinError, ValueError) as exc:
        fail(str(exc))
    if json_out != "-":
        typer.echo(f"comb cell: C2 = {report.C2_fF:.3f} fF, C1 = {report.C1_fF:.3f} fF, "
                   f"signal {report.signal_fF_per_g:.4f} fF/g, du(1 g) = {report.du_1g_nm:.1f} nm")
        for r in report.readings:
            typer.echo(f"  {r.reading:<3} slope {r.slope_mg_per_c:+.5f} mg/°C at {acceleration_g:g} g, "
                       f"ends {r.drift_low_mg:+.4f} / {r.drift_high_mg:+.4f} mg, max offset {r.max_offset_mg:.2g} mg  "
                       f"({r.meaning})")
        typer.echo(f"  for scale: {loaded.part.tempco_text(acceleration_g)}")
    emit_json(to_json(report), json_out)


@app.command()
def render(
    scenario: Annotated[Path, typer.Argument(help="scenario YAML (its device.geometry)")],
    output: Annotated[Path, typer.Option("-o", "--output", help="PNG (one temperature) or GIF/MP4 (--sweep)")],
    temperature: Annotated[float, typer.Option("--temperature", help="temperature [°C]")] = 50.0,
    sweep: Annotated[Optional[str], typer.Option("--sweep", help="START:STOP:STEP in °C, e.g. -20:50:5")] = None,
    exaggeration: Annotated[Optional[float], typer.Option("--exaggeration", min=0, help="displacement scale factor (default: 2000 for the comb, 50 with --fem)")] = None,
    acceleration_g: Annotated[float, typer.Option("--acceleration-g", help="input acceleration [g]")] = 0.0,
    reading: Annotated[str, typer.Option("--reading", help="thermal reading: P, S, H or HE")] = "S",
    fem: Annotated[bool, typer.Option("--fem", help="draw the solved finite-element package cross-section (package_fem) instead of the comb")] = False,
    json_out: JsonOpt = None,
) -> None:
    """Off-screen image of the comb cell deformed at a temperature, or a sweep as GIF/MP4.
    \f

    Parameters
    ----------
    scenario : Path
        Scenario YAML (its ``device.geometry``).
    output : Path
        PNG (one temperature) or GIF/MP4 (``sweep``).
    temperature : float
        Temperature [°C].
    sweep : str, optional
        ``START:STOP:STEP`` [°C].
    exaggeration : float, optional
        Displacement scale factor [1] (default: 2000 for the comb, 50 with ``fem``).
    acceleration_g : float
        Input acceleration [g].
    reading : {"P", "S", "H", "HE"}
        Thermal reading.
    fem : bool
        Draw the solved finite-element package cross-section instead of the comb.
    json_out : str, optional
        ``--json``: where the result goes (``-``: stdout).
    """
    if exaggeration is None:
        exaggeration = 50.0 if fem else 2000.0
    from sim.microstructure import READINGS
    from twin.model.scenario import load_scenario

    try:
        loaded = load_scenario(scenario)
        if reading not in READINGS:
            raise ValueError(f"--reading must be one of {', '.join(READINGS)}, got {reading!r}")
        suffix = output.suffix.lower()
        if sweep is None and suffix != ".png":
            raise ValueError(f"-o {output}: a single image is written as .png (use --sweep for .gif/.mp4)")
        if sweep is not None and suffix not in (".gif", ".mp4"):
            raise ValueError(f"-o {output}: a sweep is written as .gif or .mp4")
        if suffix == ".mp4" and not any(importlib.util.find_spec(m) for m in ("imageio_ffmpeg", "av")):
            raise ValueError(f"-o {output}: writing MP4 needs imageio-ffmpeg (pip install 'imageio[ffmpeg]'); "
                             "expected a .gif here")
        from twin.reporting import render as rd

        temps = rd.parse_sweep(sweep) if sweep is not None else None
        if temps is None:
            rd.check_temperature_c(temperature)
        for name, v, top in (("--exaggeration", exaggeration, 1e9), ("--acceleration-g", acceleration_g, 1000)):
            if not (math.isfinite(v) and abs(v) <= top):
                raise ValueError(f"{name} {v:g}: expected a finite value within ±{top:g}")
        check_outputs([scenario], [output, None if json_out == "-" else json_out])
    except (TwinError, ValueError) as exc:
        fail(str(exc))
    from tqdm import tqdm

    if fem:
        _render_fem(loaded, output, temperature, temps, exaggeration, json_out)
        return
    geometry = loaded.geometry()
    try:
        if temps is None:
            rd.render_png(geometry, temperature, output, exaggeration=exaggeration, acceleration_g=acceleration_g,
                          reading=reading)
            temps_c = [temperature]
        else:
            with tqdm(total=len(temps), desc="render", unit="frame", leave=False, file=sys.stderr, disable=None) as bar:
                rd.render_sweep(geometry, temps, output, exaggeration=exaggeration, acceleration_g=acceleration_g,
                                reading=reading, progress=lambda t: bar.update(1))
            temps_c = [float(t) for t in temps]
    except OSError as exc:
        fail(f"cannot write {output}: {exc.strerror or exc}")
    from twin.reporting.results import RenderResult

    result = RenderResult(output=str(output), temperatures_c=temps_c, frames=len(temps_c), exaggeration=exaggeration,
                          reading=reading, acceleration_g=acceleration_g)
    if json_out != "-":
        typer.echo(f"wrote {output} ({result.frames} frame{'s' if result.frames > 1 else ''})")
    emit_json(to_json(result), json_out)


def _render_fem(loaded, output: Path, temperature: float, temps, exaggeration: float, json_out) -> None:
    """``twin render --fem``: the scenario's package_fem design, solved, deformed and coloured."""
    from tqdm import tqdm

    from twin.workflows.render import render_package

    try:
        with tqdm(total=len(temps) if temps is not None else 1, desc="render", unit="frame", leave=False,
                  file=sys.stderr, disable=None) as bar:
            result = render_package(loaded, output, temperature_c=temperature, sweep_c=temps,
                                    exaggeration=exaggeration, progress=lambda t: bar.update(1))
    except TwinError as exc:
        fail(str(exc))
    except OSError as exc:
        fail(f"cannot write {output}: {exc.strerror or exc}")
    if json_out != "-":
        typer.echo(f"wrote {output} ({result.frames} frame(s), finite-element field, ×{exaggeration:g})")
    emit_json(to_json(result), json_out)


@app.command()
def effects(
    scenario: Annotated[Optional[Path], typer.Argument(help="scenario whose twin.plugins to load first")] = None,
    plugin: Annotated[Optional[list[str]], typer.Option("--plugin", help="effect module (.py path or module name) to load; runs its code")] = None,
    json_out: JsonOpt = None,
) -> None:
    """List the registered effects: names, families, parameters with units, bounds and sources.
    \f

    Parameters
    ----------
    scenario : Path, optional
        Scenario whose ``twin.plugins`` are loaded first.
    plugin : list of str, optional
        Effect modules (``.py`` path or module name) to load; runs their code.
    json_out : str, optional
        ``--json``: where the result goes (``-``: stdout).
    """
    from twin.effects import REGISTRY, load_plugin
    from twin.effects.records import EffectsListing

    try:
        if scenario is not None:
            from twin.model.scenario import load_scenario

            load_scenario(scenario)
        for spec in plugin or []:
            load_plugin(spec)
    except TwinError as exc:
        fail(str(exc))
    table = [REGISTRY[name].describe() for name in sorted(REGISTRY, key=lambda n: (REGISTRY[n].family, n))]
    if json_out != "-":
        for e in table:
            params = ", ".join(f"{p.name} [{p.unit}] {p.default:g} in [{p.bounds[0]:g}, {p.bounds[1]:g}]"
                               f"{' (' + p.role + ')' if p.role != 'amplitude' else '' if p.free else ' (not fitted by default)'}"
                               for p in e.parameters)
            typer.echo(f"{e.name:<20} {e.family:<13} {params or '-'}")
    emit_json(to_json(EffectsListing(effects=table)), json_out)


@app.command()
def parts(part: Annotated[Optional[list[str]], typer.Argument(help="part names or part YAML files (default: the built-in parts)")] = None, json_out: JsonOpt = None) -> None:
    """List the sensor parts: each datasheet figure with its unit, source and whether it was verified (read in a source).
    \f

    Parameters
    ----------
    part : list of str, optional
        Part names or part YAML files (default: the built-in parts).
    json_out : str, optional
        ``--json``: where the result goes (``-``: stdout).
    """
    from twin.parts import PARTS, load_part, table_lines
    from twin.parts.records import PartsListing

    try:
        check_outputs([p for p in part or [] if Path(p).exists()], [None if json_out == "-" else json_out])
        chosen = [load_part(p) for p in part] if part else list(PARTS.values())
    except TwinError as exc:
        fail(str(exc))
    if json_out != "-":
        typer.echo("\n".join(table_lines(chosen)))
    emit_json(to_json(PartsListing(parts=[p.describe() for p in chosen])), json_out)


@app.command()
def export(
    dataset: Annotated[Path, typer.Argument(help="HDF5 dataset from twin run")],
    output: Annotated[Path, typer.Option("-o", "--output", help="canonical CSV to write")],
    json_out: JsonOpt = None,
) -> None:
    """Write a dataset's logged columns as canonical CSV (time_s, temperature_c, output_g, applied_g,
    run, power_on) - the measurement a lab would have, without the truth.
    \f

    Parameters
    ----------
    dataset : Path
        HDF5 dataset from ``twin run``.
    output : Path
        Canonical CSV to write.
    json_out : str, optional
        ``--json``: where the result goes (``-``: stdout).
    """
    from twin.measurement import read_dataset_blind, write_canonical_csv

    try:
        check_outputs([dataset], [output, None if json_out == "-" else json_out])
        m = read_dataset_blind(dataset)
        write_canonical_csv(output, m.time_s, m.temperature_c, m.output_g, m.applied_g, m.run_index, m.power_on)
    except TwinError as exc:
        fail(str(exc))
    from twin.reporting.results import ExportResult

    result = ExportResult(output=str(output), rows=len(m), runs=m.runs)
    if json_out != "-":
        typer.echo(f"wrote {output}: {len(m)} rows, {m.runs} run(s)")
    emit_json(to_json(result), json_out)
