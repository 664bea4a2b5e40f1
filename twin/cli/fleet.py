"""``twin fleet``: compare (and calibrate) over many units' logs, locally or on Dask."""

from __future__ import annotations

import sys
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Annotated, Optional

import typer

from twin.cli.common import JsonOpt, app, check_outputs, emit_json, guard


@contextmanager
def progress_bar(desc: str, unit: str) -> Iterator[Callable[[int, int], None]]:
    """A ``progress(done, total)`` for a workflow: a bar on stderr (on a terminal only), opened at
    the first report, once the workflow has read its input and knows the total.

    Parameters
    ----------
    desc, unit : str
        The bar's label and the name of what it counts.

    Yields
    ------
    callable
        ``progress(done, total)``.
    """
    from tqdm import tqdm

    bars = []

    def report(done: int, total: int) -> None:
        if not bars:
            bars.append(tqdm(total=total, desc=desc, unit=unit, file=sys.stderr, disable=None))
        bars[0].update(done - bars[0].n)

    try:
        yield report
    finally:
        for bar in bars:
            bar.close()


def checked_with_json(json_out: str | None) -> Callable[[list, list], None]:
    """A workflow's ``check_paths``: its outputs and the ``--json`` file checked against its inputs.

    Parameters
    ----------
    json_out : str or None
        The ``--json`` value (``-``: stdout, no file).

    Returns
    -------
    callable
        ``check_paths(inputs, outputs)``.
    """
    target = None if json_out == "-" else json_out
    return lambda inputs, outputs: check_outputs(inputs, [*outputs, target])


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
    skips finished units; a unit whose log is bad is recorded with its error and the others go on.
    \f

    Parameters
    ----------
    spec : str
        Fleet YAML, or a glob / folder of unit logs.
    output : Path
        Output folder (``units.jsonl``, ``table.csv``, ``population.json``, ``summary.html``).
    workers : int
        Parallel units.
    executor : {"local", "dask"}
        Where the units are analysed.
    scheduler : str, optional
        Address of a running Dask scheduler (default: a local cluster of ``workers``).
    scenario : Path, optional
        The twin's scenario (overrides the spec's; required with a glob).
    command : {"compare", "calibrate"}, optional
        Overrides the spec's analysis.
    json_out : str, optional
        ``--json``: where the result goes (``-``: stdout).
    """
    from twin.results import to_json
    from twin.workflows.fleet import FleetOptions, run_fleet

    with guard():
        opts = FleetOptions.build(spec=spec, output=output, workers=workers, executor=executor, scheduler=scheduler,
                                  scenario=scenario, command=command)
        # --json checked with the fleet's own files once the spec is read, before any unit runs
        with progress_bar("units", "unit") as progress:
            result = run_fleet(opts, progress=progress, check_paths=checked_with_json(json_out))
    if json_out != "-":
        for note in result.notes:
            typer.echo(f"note: {note}")
        typer.echo(f"{result.ok}/{result.units} units analysed ({result.errors} failed; {result.ran} ran now, "
                   f"{result.skipped} already done) -> {output}/table.csv, population.json, summary.html")
        for name, v in result.prevalence.items():
            typer.echo(f"  {name}: named in {v.units} units ({100 * v.share:.1f} %)")
        for fam, v in result.prevalence_primary_family.items():
            typer.echo(f"  family {fam} named first: {v.units} units ({100 * v.share:.1f} %)")
        if result.outliers:
            typer.echo(f"  outliers: {len(result.outliers)} (|robust z| > {result.outlier_threshold:g}); see population.json")
        for f in result.failed[:5]:
            typer.echo(f"  failed {f.unit}: {f.error}")
    emit_json(to_json(result), json_out)


@app.command("fleet-simulate")
def fleet_simulate(
    fleet_scenario: Annotated[Path, typer.Argument(help="fleet scenario YAML (base scenario, units, seed, effects with prevalences)")],
    output: Annotated[Path, typer.Option("-o", "--output", help="folder for logs/, truth.json and fleet.yaml")],
    workers: Annotated[int, typer.Option("--workers", min=1, help="parallel simulations")] = 1,
    json_out: JsonOpt = None,
) -> None:
    """Simulate a fleet: each unit's log (canonical CSV) and, apart, the truth; then
    'twin fleet OUT/fleet.yaml -o DIR' analyses it blind.
    \f

    Parameters
    ----------
    fleet_scenario : Path
        Fleet scenario YAML (base scenario, units, seed, effects with prevalences).
    output : Path
        Folder for ``logs/``, ``truth.json`` and ``fleet.yaml``.
    workers : int
        Parallel simulations.
    json_out : str, optional
        ``--json``: where the result goes (``-``: stdout).
    """
    from twin.results import to_json
    from twin.workflows.fleet import SimulateFleetOptions, run_fleet_simulation

    with guard(inputs=[fleet_scenario], outputs=[]):
        opts = SimulateFleetOptions.build(fleet_scenario=fleet_scenario, output=output, workers=workers)
        with progress_bar("units", "unit") as progress:
            result = run_fleet_simulation(opts, progress=progress, check_paths=checked_with_json(json_out))
    if json_out != "-":
        prev = ", ".join(f"{k} {100 * v:.1f} %" for k, v in result.prevalence.items())
        typer.echo(f"{result.units} units ({result.written} written now) -> {output}/logs; truth apart in "
                   f"{result.truth} (true prevalence: {prev})")
        typer.echo(f"analyse: twin fleet {result.spec} -o DIR")
    emit_json(to_json(result), json_out)
