"""The ``twin`` command line.

Conventions for every subcommand: ``--json PATH`` writes the machine-readable result (``-`` for
stdout); bad input exits with status 2 and one line naming what and where, never a traceback.
"""

from __future__ import annotations

import json
import sys
from pathlib import Path
from typing import Annotated, Optional

import typer

from twin.errors import TwinError

app = typer.Typer(
    name="twin",
    help="Digital twin of the temperature drift error (TDE) of MEMS accelerometers.",
    add_completion=False,
    no_args_is_help=True,
    pretty_exceptions_enable=False,
)

JsonOpt = Annotated[Optional[str], typer.Option("--json", help="write the result as JSON to PATH ('-' for stdout)")]


def _fail(message: str) -> None:
    typer.echo(f"twin: error: {message}", err=True)
    raise typer.Exit(2)


def _emit_json(result: dict, dest: str | None) -> None:
    """Write ``result`` to ``dest`` atomically ('-' = stdout)."""
    if dest is None:
        return
    text = json.dumps(result, indent=2, default=float) + "\n"
    if dest == "-":
        sys.stdout.write(text)
        return
    from twin.io import atomic_write_text

    atomic_write_text(Path(dest), text)


def _version(value: bool) -> None:
    if value:
        from twin import __version__

        typer.echo(f"twin {__version__}")
        raise typer.Exit()


@app.callback()
def _root(
    version: Annotated[bool, typer.Option("--version", callback=_version, is_eager=True, help="print the version")] = False,
) -> None:
    """Digital twin of the temperature drift error (TDE) of MEMS accelerometers."""


@app.command()
def run(
    scenario: Annotated[Path, typer.Argument(help="scenario YAML")],
    output: Annotated[Optional[Path], typer.Option("-o", "--output", help="HDF5 file to write")] = None,
    seed: Annotated[Optional[int], typer.Option("--seed", min=0, help="override the scenario's seed")] = None,
    quiet: Annotated[bool, typer.Option("--quiet", "-q", help="no progress bar")] = False,
    json_out: JsonOpt = None,
) -> None:
    """Simulate a chamber test and write the dataset (HDF5) with its ground truth."""
    from tqdm import tqdm

    from twin.model.dataset import write_hdf5
    from twin.model.scenario import load_scenario
    from twin.model.simulate import STAGES, simulate, summary

    try:
        loaded = load_scenario(scenario)
        out = output or (Path(loaded.scenario.output.path) if loaded.scenario.output.path else scenario.with_suffix(".h5"))
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
        _fail(str(exc))
    except OSError as exc:
        _fail(f"cannot write {out}: {exc.strerror or exc}")
    result = {"output": str(out), **summary(ds)}
    if not quiet and json_out != "-":
        typer.echo(
            f"wrote {out}: {result['samples']} samples, {result['duration_h']:.2f} h, die "
            f"{result['die_range_c'][0]:.1f}..{result['die_range_c'][1]:.1f} °C, drift "
            f"{result['drift_range_mg'][0]:.2f}..{result['drift_range_mg'][1]:.2f} mg, white noise "
            f"{result['white_noise_sigma_mg']:.3f} mg"
        )
    _emit_json(result, json_out)


@app.command()
def schema(
    output: Annotated[Optional[Path], typer.Option("-o", "--output", help="write the schema here")] = None,
    json_out: JsonOpt = None,
) -> None:
    """Print the JSON Schema of scenario files (for editors)."""
    from twin.model.scenario import json_schema

    s = json_schema()
    if output is not None:
        from twin.io import atomic_write_text

        atomic_write_text(output, json.dumps(s, indent=2) + "\n")
    elif json_out is None:
        typer.echo(json.dumps(s, indent=2))
    _emit_json(s, json_out)


@app.command("test-design")
def test_design(
    lsb_mg: Annotated[float, typer.Option(min=0, help="sensitivity, 1 LSB [mg]")] = 0.98,
    tcoff_mg_per_c: Annotated[float, typer.Option(min=0, help="|TCOff| [mg/°C]")] = 0.8,
    tcso_pct_per_c: Annotated[float, typer.Option(min=0, help="TCSo as printed in eq. (33) [%/°C]")] = 0.02,
    chamber_length_m: Annotated[float, typer.Option(min=0, help="chamber length L [m]")] = 0.6,
    json_out: JsonOpt = None,
) -> None:
    """The paper's test-design numbers (eqs. 31-35) beside physically consistent time scales."""
    from twin.reporting.paper import design_report

    rows = design_report(lsb_mg, tcoff_mg_per_c, tcso_pct_per_c, chamber_length_m)
    if json_out != "-":
        for row in rows["items"]:
            typer.echo(f"{row['name']:<44} {row['value']:>12.6g} {row['unit']:<8} {row['note']}")
    _emit_json(rows, json_out)


@app.command()
def paper(json_out: JsonOpt = None) -> None:
    """Each derived number of the paper next to what the code computes, with a verdict."""
    from twin.reporting.paper import paper_report

    report = paper_report()
    if json_out != "-":
        for it in report["items"]:
            printed = "-" if it["paper"] is None else f"{it['paper']:.6g}" if isinstance(it["paper"], float) else str(it["paper"])
            computed = f"{it['computed']:.6g}" if isinstance(it["computed"], float) else str(it["computed"])
            typer.echo(f"{it['item']:<34} paper {printed:>10}  code {computed:>12} {it['unit']:<8} {it['verdict']}")
        typer.echo(f"{report['reproduced']} reproduced, {report['differs']} differ, {report['computed']} computed (not in the paper)")
    _emit_json(report, json_out)


@app.command()
def comb(
    scenario: Annotated[Path, typer.Argument(help="scenario YAML (its device.geometry)")],
    acceleration_g: Annotated[float, typer.Option("--acceleration-g", help="input acceleration [g]")] = 1.0,
    t_low_c: Annotated[float, typer.Option(help="sweep start [°C]")] = -20.0,
    t_high_c: Annotated[float, typer.Option(help="sweep end [°C]")] = 50.0,
    json_out: JsonOpt = None,
) -> None:
    """Comb thermal drift under each reading (P, S, H, HE): offset and scale-factor parts."""
    from twin.reporting.comb import comb_report
    from twin.model.scenario import load_scenario

    try:
        loaded = load_scenario(scenario)
        report = comb_report(loaded.geometry(), acceleration_g, t_low_c, t_high_c)
    except (TwinError, ValueError) as exc:
        _fail(str(exc))
    if json_out != "-":
        typer.echo(f"comb cell: C2 = {report['C2_fF']:.3f} fF, C1 = {report['C1_fF']:.3f} fF, "
                   f"signal {report['signal_fF_per_g']:.4f} fF/g, du(1 g) = {report['du_1g_nm']:.1f} nm")
        for r in report["readings"]:
            typer.echo(f"  {r['reading']:<3} slope {r['slope_mg_per_c']:+.5f} mg/°C at {acceleration_g:g} g, "
                       f"ends {r['drift_low_mg']:+.4f} / {r['drift_high_mg']:+.4f} mg, max offset {r['max_offset_mg']:.2g} mg  "
                       f"({r['meaning']})")
        typer.echo(f"  for scale: datasheet TCOff 0.8 mg/°C, TCSo 0.01 %/°C = {0.1 * acceleration_g:g} mg/°C at this input")
    _emit_json(report, json_out)


@app.command()
def render(
    scenario: Annotated[Path, typer.Argument(help="scenario YAML (its device.geometry)")],
    output: Annotated[Path, typer.Option("-o", "--output", help="PNG (one temperature) or GIF/MP4 (--sweep)")],
    temperature: Annotated[float, typer.Option("--temperature", help="temperature [°C]")] = 50.0,
    sweep: Annotated[Optional[str], typer.Option("--sweep", help="START:STOP:STEP in °C, e.g. -20:50:5")] = None,
    exaggeration: Annotated[float, typer.Option("--exaggeration", min=0, help="displacement scale factor")] = 2000.0,
    acceleration_g: Annotated[float, typer.Option("--acceleration-g", help="input acceleration [g]")] = 0.0,
    reading: Annotated[str, typer.Option("--reading", help="thermal reading: P, S, H or HE")] = "S",
    json_out: JsonOpt = None,
) -> None:
    """Off-screen image of the comb cell deformed at a temperature, or a sweep as GIF/MP4."""
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
        from twin.reporting import render as rd

        temps = rd.parse_sweep(sweep) if sweep is not None else None
    except (TwinError, ValueError) as exc:
        _fail(str(exc))
    from tqdm import tqdm

    geometry = loaded.geometry()
    if temps is None:
        rd.render_png(geometry, temperature, output, exaggeration=exaggeration, acceleration_g=acceleration_g, reading=reading)
        result = {"output": str(output), "temperatures_c": [temperature], "frames": 1}
    else:
        with tqdm(total=len(temps), desc="render", unit="frame", leave=False, file=sys.stderr, disable=None) as bar:
            rd.render_sweep(geometry, temps, output, exaggeration=exaggeration, acceleration_g=acceleration_g,
                            reading=reading, progress=lambda t: bar.update(1))
        result = {"output": str(output), "temperatures_c": [float(t) for t in temps], "frames": len(temps)}
    result.update(exaggeration=exaggeration, reading=reading, acceleration_g=acceleration_g)
    if json_out != "-":
        typer.echo(f"wrote {output} ({result['frames']} frame{'s' if result['frames'] > 1 else ''})")
    _emit_json(result, json_out)


@app.command()
def effects(
    scenario: Annotated[Optional[Path], typer.Argument(help="scenario whose twin.plugins to load first")] = None,
    plugin: Annotated[Optional[list[str]], typer.Option("--plugin", help="effect module (.py path or module name) to load; runs its code")] = None,
    json_out: JsonOpt = None,
) -> None:
    """List the registered effects: names, families, parameters with units, bounds and sources."""
    from twin.effects import REGISTRY, load_plugin

    try:
        if scenario is not None:
            from twin.model.scenario import load_scenario

            load_scenario(scenario)
        for spec in plugin or []:
            load_plugin(spec)
    except TwinError as exc:
        _fail(str(exc))
    table = [REGISTRY[name].describe() for name in sorted(REGISTRY, key=lambda n: (REGISTRY[n].family, n))]
    if json_out != "-":
        for e in table:
            params = ", ".join(f"{p['name']} [{p['unit']}] {p['default']:g} in [{p['bounds'][0]:g}, {p['bounds'][1]:g}]"
                               f"{' (' + p['role'] + ')' if p['role'] != 'amplitude' else '' if p['free'] else ' (not fitted by default)'}"
                               for p in e["parameters"])
            typer.echo(f"{e['name']:<20} {e['family']:<13} {params or '-'}")
    _emit_json({"effects": table}, json_out)


@app.command()
def export(
    dataset: Annotated[Path, typer.Argument(help="HDF5 dataset from twin run")],
    output: Annotated[Path, typer.Option("-o", "--output", help="canonical CSV to write")],
    json_out: JsonOpt = None,
) -> None:
    """Write a dataset's logged columns as canonical CSV (time_s, temperature_c, output_g, applied_g,
    run, power_on) - the measurement a lab would have, without the truth."""
    from twin.measurement import read_dataset_blind, write_canonical_csv

    try:
        m = read_dataset_blind(dataset)
        write_canonical_csv(output, m.time_s, m.temperature_c, m.output_g, m.applied_g, m.run_index, m.power_on)
    except TwinError as exc:
        _fail(str(exc))
    result = {"output": str(output), "rows": len(m), "runs": m.runs}
    if json_out != "-":
        typer.echo(f"wrote {output}: {len(m)} rows, {m.runs} run(s)")
    _emit_json(result, json_out)


@app.command()
def compare(
    scenario: Annotated[Path, typer.Argument(help="scenario YAML: its twin, device.sensor and test_plan")],
    measurements: Annotated[list[Path], typer.Argument(help="measurement file(s): canonical CSV, any log with a column map, or a twin HDF5 (read blind); several files = several runs")],
    with_effect: Annotated[Optional[list[str]], typer.Option("--with-effect", help="add this effect to the twin (repeatable)")] = None,
    report: Annotated[Optional[Path], typer.Option("--report", help="write report.html and the ledger into DIR")] = None,
    applied_g: Annotated[str, typer.Option("--applied-g", help="acceleration along the axis when not logged [g], or 'unknown'")] = "1",
    columns: Annotated[Optional[Path], typer.Option("--columns", help="column-map YAML for real logs")] = None,
    time_col: Annotated[Optional[str], typer.Option(help="time column (name or 0-based index)")] = None,
    temperature_col: Annotated[Optional[str], typer.Option(help="temperature column")] = None,
    output_col: Annotated[Optional[str], typer.Option(help="acceleration column")] = None,
    time_unit: Annotated[Optional[str], typer.Option(help="s, ms, us, min, h")] = None,
    temperature_unit: Annotated[Optional[str], typer.Option(help="C or K")] = None,
    output_unit: Annotated[Optional[str], typer.Option(help="g, mg, m/s^2, digits")] = None,
    output_scale: Annotated[Optional[float], typer.Option(help="multiply the output after unit conversion")] = None,
    skip_lines: Annotated[Optional[int], typer.Option(min=0, help="banner lines to skip")] = None,
    delimiter: Annotated[Optional[str], typer.Option(help="column delimiter (default: sniffed)")] = None,
    no_header: Annotated[bool, typer.Option("--no-header", help="the file has no header line (columns by index)")] = False,
    sample_rate_hz: Annotated[Optional[float], typer.Option(min=0, help="sample rate for logs without a time column [Hz]")] = None,
    skip_bad_rows: Annotated[bool, typer.Option("--skip-bad-rows", help="skip corrupted rows and report how many")] = False,
    average_s: Annotated[float, typer.Option(min=0.1, help="screening block average [s]")] = 10.0,
    json_out: JsonOpt = None,
) -> None:
    """Compare the twin with a measurement: calibrate, show where it fails, name the missing effect."""
    from twin.diagnosis.compare import run_compare
    from twin.measurement import ColumnMap

    try:
        cmap = ColumnMap.from_yaml(columns) if columns else ColumnMap()
        overrides = {"time": time_col, "temperature": temperature_col, "output": output_col, "time_unit": time_unit,
                     "temperature_unit": temperature_unit, "output_unit": output_unit, "output_scale": output_scale,
                     "skip_lines": skip_lines, "delimiter": delimiter}
        for key, value in overrides.items():
            if value is not None:
                setattr(cmap, key, value)
        if no_header:
            cmap.header = False
        if sample_rate_hz is not None:
            cmap.sample_rate_hz, cmap.time = sample_rate_hz, None
        if applied_g != "unknown":
            try:
                applied = float(applied_g)
            except ValueError:
                raise TwinError(f"--applied-g expects a number in g or 'unknown', got {applied_g!r}") from None
        else:
            applied = "unknown"
        result, _ = run_compare(scenario, measurements, cmap, with_effect or [], applied, skip_bad_rows, average_s,
                                report, json_out)
    except TwinError as exc:
        _fail(str(exc))
    if json_out != "-":
        typer.echo(result["finding"])
        typer.echo(f"residual RMS {result['rms_residual_g'] * 1e3:.3f} mg, noise floor {result['noise_floor_g'] * 1e3:.3f} mg, "
                   f"missing effect: {result['missing_effect_detected']} ({result['confidence']})")
        for c in result["candidates"][:5]:
            typer.echo(f"  {c['effect']:<20} {c['family']:<13} {'significant' if c['significant'] else '-':<12} "
                       f"ΔBIC {c['delta_bic']:9.1f}  gain {100 * c['heldout_gain']:5.1f} %  RMS after {c['rms_residual_g'] * 1e3:.3f} mg")
        if report:
            typer.echo(f"report: {report / 'report.html'}")
    _emit_json(result, json_out)


@app.command()
def benchmark(
    scenario: Annotated[Path, typer.Argument(help="scenario YAML: the device and test whose drift is compensated")],
    seeds: Annotated[int, typer.Option("--seeds", min=1, help="independent test runs (Tests 1..N)")] = 3,
    quick: Annotated[bool, typer.Option("--quick", help="1 Hz data, 20 generations, population 20: minutes, not tens")] = False,
    report: Annotated[Optional[Path], typer.Option("--report", help="write plots and report.html into DIR")] = None,
    json_out: JsonOpt = None,
) -> None:
    """The paper's compensation benchmark (conventional, Model 1, GA-BPNN, PSO-GA-BPNN, polynomial,
    our dT/dt extension, the calibrated physics twin) on data whose truth is known."""
    from tqdm import tqdm

    from twin.compensation.benchmark import optimizer_benchmark, run_benchmark
    from twin.model.scenario import load_scenario

    try:
        loaded = load_scenario(scenario)
    except TwinError as exc:
        _fail(str(exc))
    with tqdm(total=3 * seeds + 1, desc="benchmark", leave=False, file=sys.stderr, disable=None) as bar:
        def tick(msg: str) -> None:
            bar.set_description(msg)
            bar.update(1)

        result = run_benchmark(loaded, seeds=seeds, quick=quick, progress=tick)
        bar.set_description("optimisers on eq. (45)")
        result["optimizers"] = optimizer_benchmark(20)
    if report is not None:
        from twin.compensation.report import write_benchmark_report

        write_benchmark_report(report, result)
    if json_out != "-":
        typer.echo(f"Table 1: MSE of the compensated output [g²] on Tests 1..{seeds} (noise floor {result['noise_floor_mse']:.3e})")
        for row in result["table1"]:
            q = "" if "Q_percent" not in row else "  Q " + " ".join(f"{v:5.2f}%" for v in row["Q_percent"])
            typer.echo(f"  {row['model']:<22}" + " ".join(f"{v:.3e}" for v in row["mse"]) +
                       f"  ×floor {row['ratio_mean']:.3f}{q}")
        for v in result["verdicts"]:
            typer.echo(f"  - {v}")
        if report is not None:
            typer.echo(f"report: {report / 'report.html'}")
    _emit_json(result, json_out)


@app.command()
def doe(
    study: Annotated[Path, typer.Argument(help="study YAML")],
    output: Annotated[Path, typer.Option("-o", "--output", help="output folder (runs.jsonl, table, plots)")],
    workers: Annotated[int, typer.Option("--workers", min=1, help="parallel runs")] = 1,
    executor: Annotated[str, typer.Option("--executor", help="local or dask")] = "local",
    scheduler: Annotated[Optional[str], typer.Option("--scheduler", help="dask scheduler address (default: a local cluster)")] = None,
    json_out: JsonOpt = None,
) -> None:
    """Run a design-of-experiment study; resumes where it stopped (finished runs are kept)."""
    from tqdm import tqdm

    from twin.studies.doe import load_study, plan, run_study, write_outputs

    if executor not in ("local", "dask"):
        _fail(f"--executor must be 'local' or 'dask', got {executor!r}")
    try:
        st, base, _ = load_study(study)
    except TwinError as exc:
        _fail(str(exc))
    total = len(plan(st, base))
    with tqdm(total=total, desc="runs", unit="run", file=sys.stderr, disable=None) as bar:
        runs = run_study(st, base, output, workers, executor, scheduler, progress=lambda r: bar.update(1))
    analysis = write_outputs(st, runs, output)
    result = {"output": str(output), "runs": len(runs), "planned": total, "failed": analysis["failed"],
              "main_effects": analysis["main_effects"], "interactions": analysis["interactions"],
              "sobol": analysis["sobol"]}
    if json_out != "-":
        typer.echo(f"{len(runs)}/{total} runs ({analysis['failed']} failed) -> {output}/table.csv, analysis.json, plots")
        for f, per in analysis["main_effects"].items():
            typer.echo(f"  {f}: " + ", ".join(f"{r} effect {v['effect']:.3g}" for r, v in per.items()))
    _emit_json(result, json_out)


def main() -> None:
    """Console entry point: usage errors and our errors exit 2 with one line."""
    try:
        app(standalone_mode=True)
    except KeyboardInterrupt:
        typer.echo("twin: interrupted", err=True)
        sys.exit(130)


if __name__ == "__main__":  # pragma: no cover
    main()
