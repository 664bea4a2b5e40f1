"""``twin fleet``: compare (and calibrate) over many units' logs, locally or on Dask."""

from __future__ import annotations

import sys
from pathlib import Path
from typing import Annotated, Optional

import typer

from twin.cli.common import JsonOpt, app, check_outputs, emit_json, guard


@app.command()
def fleet(
    spec: Annotated[str, typer.Argument(help="fleet YAML (scenario, units, columns, options), or a glob / folder of unit logs")],
    output: Annotated[Path, typer.Option("-o", "--output", help="output folder (units.jsonl, table.csv, population.json, summary.html)")],
    workers: Annotated[int, typer.Option("--workers", min=1, help="parallel units")] = 1,
    executor: Annotated[str, typer.Option("--executor", help="local or dask")] = "local",
    scheduler: Annotated[Optional[str], typer.Option("--scheduler", help="address of a running dask scheduler (default: a local cluster of --workers)")] = None,
    scenario: Annotated[Optional[Path], typer.Option("--scenario", help="the twin's scenario (overrides the spec's; required with a glob)")] = None,
    command: Annotated[Optional[str], typer.Option("--command", help="compare or calibrate (overrides the spec's)")] = None,
    json_out: JsonOpt = None,
) -> None:
    """Analyse every unit of a fleet, durably: one line per finished unit in units.jsonl, a rerun
    skips finished units; a unit whose log is bad is recorded with its error and the others go on."""
    from tqdm import tqdm

    from twin.fleet.ledger import FOLDER_OUTPUTS
    from twin.fleet.population import population, write_population, write_table
    from twin.fleet.runner import run_fleet
    from twin.fleet.spec import load_fleet_spec
    from twin.fleet.summary import write_summary

    with guard():
        if executor not in ("local", "dask"):
            raise_twin(f"--executor must be 'local' or 'dask', got {executor!r}")
        fs = load_fleet_spec(spec, scenario, command)
        inputs = {Path(f).resolve() for u in fs.units for f in u.files}
        if output.resolve() in inputs or any(output.resolve() in p.parents for p in inputs):
            raise_twin(f"{output}: the output folder holds the fleet's logs; choose another folder")
        # --json checked now, not after every unit ran: never over an input or the fleet's own files
        own = [output / name for name in ("units.jsonl", ".lock", *FOLDER_OUTPUTS)]
        # and the fleet's own files never over an input (a --scenario named out/table.csv was replaced), nor a
        # folder where a file goes (units.jsonl as a folder failed after the first unit)
        check_outputs([*inputs, spec, fs.scenario], [*own, None if json_out == "-" else json_out])
        with tqdm(total=len(fs.units), desc="units", unit="unit", file=sys.stderr, disable=None) as bar:
            run = run_fleet(fs, output, workers, executor, scheduler, progress=lambda r: bar.update(1))
        pop = population(run.records, fs.outlier_threshold)
        write_table(output, run.records)
        write_population(output, pop)
        write_summary(output, run.records, pop, title=f"twin fleet: {fs.name or fs.source}")
    result = {"output": str(output), "units": len(fs.units), "ran": run.ran, "skipped": run.skipped,
              "notes": run.notes, **{k: pop[k] for k in ("ok", "errors", "prevalence", "prevalence_by_family",
                                                          "prevalence_primary_family", "none_named", "confidence", "parameters", "outliers", "failed")}}
    if json_out != "-":
        for note in run.notes:
            typer.echo(f"note: {note}")
        typer.echo(f"{pop['ok']}/{len(fs.units)} units analysed ({pop['errors']} failed; {run.ran} ran now, "
                   f"{run.skipped} already done) -> {output}/table.csv, population.json, summary.html")
        for name, v in pop["prevalence"].items():
            typer.echo(f"  {name}: named in {v['units']} units ({100 * v['share']:.1f} %)")
        for fam, v in pop["prevalence_primary_family"].items():
            typer.echo(f"  family {fam} named first: {v['units']} units ({100 * v['share']:.1f} %)")
        if pop["outliers"]:
            typer.echo(f"  outliers: {len(pop['outliers'])} (|robust z| > {fs.outlier_threshold:g}); see population.json")
        for f in pop["failed"][:5]:
            typer.echo(f"  failed {f['unit']}: {f['error']}")
    emit_json(result, json_out)


def raise_twin(message: str) -> None:
    from twin.errors import TwinError

    raise TwinError(message)


@app.command("fleet-simulate")
def fleet_simulate(
    fleet_scenario: Annotated[Path, typer.Argument(help="fleet scenario YAML (base scenario, units, seed, effects with prevalences)")],
    output: Annotated[Path, typer.Option("-o", "--output", help="folder for logs/, truth.json and fleet.yaml")],
    workers: Annotated[int, typer.Option("--workers", min=1, help="parallel simulations")] = 1,
    json_out: JsonOpt = None,
) -> None:
    """Simulate a fleet: each unit's log (canonical CSV) and, apart, the truth; then
    'twin fleet OUT/fleet.yaml -o DIR' analyses it blind."""
    from tqdm import tqdm

    from twin.fleet.simulate import load_fleet_scenario, simulate_fleet

    with guard(inputs=[fleet_scenario], outputs=[]):
        fs = load_fleet_scenario(fleet_scenario)
        n = fs.units
        written = [output / "fleet.yaml", output / "truth.json"]
        # what it writes is checked before any unit runs: never over the fleet scenario or its base
        check_outputs([fleet_scenario, fs.base_path], written + [None if json_out == "-" else json_out])
        check_outputs([*written, output / "logs"], [None if json_out == "-" else json_out])
        logs = (output / "logs").resolve()
        if any(logs in Path(p).resolve().parents for p in (fleet_scenario, fs.base_path)):
            raise_twin(f"{output}: its logs/ folder holds the fleet scenario or its base; choose another folder")
        with tqdm(total=n, desc="units", unit="unit", file=sys.stderr, disable=None) as bar:
            result = simulate_fleet(fleet_scenario, output, workers, progress=lambda: bar.update(1))
    if json_out != "-":
        prev = ", ".join(f"{k} {100 * v:.1f} %" for k, v in result["prevalence"].items())
        typer.echo(f"{result['units']} units ({result['written']} written now) -> {output}/logs; truth apart in "
                   f"{result['truth']} (true prevalence: {prev})")
        typer.echo(f"analyse: twin fleet {result['spec']} -o DIR")
    emit_json(result, json_out)
