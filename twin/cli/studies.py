"""Study commands: the compensation benchmark and design-of-experiment studies."""

from __future__ import annotations

import sys
from pathlib import Path
from typing import Annotated, Optional

import typer

from twin.cli.common import JsonOpt, app, emit_json, fail
from twin.errors import TwinError


@app.command()
def benchmark(
    scenario: Annotated[Path, typer.Argument(help="scenario YAML: the device and test whose drift is compensated")],
    seeds: Annotated[int, typer.Option("--seeds", min=1, help="independent test runs (Tests 1..N)")] = 3,
    quick: Annotated[bool, typer.Option("--quick", help="1 Hz data, 20 generations, population 20: minutes, not tens")] = False,
    report: Annotated[Optional[Path], typer.Option("--report", help="write plots and report.html into DIR")] = None,
    plugin: Annotated[Optional[list[str]], typer.Option("--plugin", help="compensator module (.py path or module name) to load and benchmark too; runs its code")] = None,
    json_out: JsonOpt = None,
) -> None:
    """The paper's compensation benchmark (conventional, Model 1, GA-BPNN, PSO-GA-BPNN, polynomial,
    our dT/dt extension, any --plugin compensators, the calibrated physics twin) on data whose truth is known.
    \f

    Parameters
    ----------
    scenario : Path
        Scenario YAML: the device and test whose drift is compensated.
    seeds : int
        Independent test runs (Tests 1..N).
    quick : bool
        1 Hz data, 20 generations, population 20.
    report : Path, optional
        Folder for the plots and ``report.html``.
    plugin : list of str, optional
        Compensator modules (``.py`` path or module name) to load and benchmark too; runs their code.
    json_out : str, optional
        ``--json``: where the result goes (``-``: stdout).

    References
    ----------
    Qi et al. (2022), Micromachines 13, 2156: Tables 1 and 2, eqs. (45) and (47).
    """
    from dataclasses import replace

    from tqdm import tqdm

    from twin.compensation.benchmark import optimizer_benchmark, run_benchmark
    from twin.compensation.registry import load_plugin
    from twin.model.scenario import load_scenario

    try:
        loaded = load_scenario(scenario)
        for spec in plugin or []:
            load_plugin(spec)
        with tqdm(total=3 * seeds + 1, desc="benchmark", leave=False, file=sys.stderr, disable=None) as bar:
            def tick(msg: str) -> None:
                bar.set_description(msg)
                bar.update(1)

            result = run_benchmark(loaded, seeds=seeds, quick=quick, progress=tick)
            bar.set_description("optimisers on eq. (45)")
            result = replace(result, optimizers=optimizer_benchmark(20))
        if report is not None:
            from twin.compensation.report import write_benchmark_report

            write_benchmark_report(report, result)
    except TwinError as exc:
        fail(str(exc))
    except OSError as exc:
        fail(f"{exc.filename or report}: {exc.strerror or exc}")
    if json_out != "-":
        typer.echo(f"Table 1: MSE of the compensated output [g²] on Tests 1..{seeds} (noise floor {result.noise_floor_mse:.3e})")
        for row in result.table1:
            q = "" if row.Q_percent is None else "  Q " + " ".join(f"{v:5.2f}%" for v in row.Q_percent)
            typer.echo(f"  {row.model:<22}" + " ".join(f"{v:.3e}" for v in row.mse) +
                       f"  ×floor {row.ratio_mean:.3f}{q}")
        for v in result.verdicts:
            typer.echo(f"  - {v}")
        if report is not None:
            typer.echo(f"report: {report / 'report.html'}")
    emit_json(result.to_json(), json_out)


@app.command()
def doe(
    study: Annotated[Path, typer.Argument(help="study YAML")],
    output: Annotated[Path, typer.Option("-o", "--output", help="output folder (runs.jsonl, table, plots)")],
    workers: Annotated[int, typer.Option("--workers", min=1, max=256, help="parallel runs")] = 1,
    executor: Annotated[str, typer.Option("--executor", help="local or dask")] = "local",
    scheduler: Annotated[Optional[str], typer.Option("--scheduler", help="dask scheduler address (default: a local cluster)")] = None,
    json_out: JsonOpt = None,
) -> None:
    """Run a design-of-experiment study; resumes where it stopped (finished runs are kept).
    \f

    Parameters
    ----------
    study : Path
        Study YAML.
    output : Path
        Output folder (``runs.jsonl``, the table, ``analysis.json``, plots).
    workers : int
        Parallel runs.
    executor : {"local", "dask"}
        Where the runs are computed.
    scheduler : str, optional
        Address of a running Dask scheduler (default: a local cluster).
    json_out : str, optional
        ``--json``: where the result goes (``-``: stdout).
    """
    from twin.cli.fleet import checked_with_json, progress_bar
    from twin.results import to_json
    from twin.workflows.study import StudyOptions, run_study

    try:
        opts = StudyOptions.build(study=study, output=output, workers=workers, executor=executor, scheduler=scheduler)
        with progress_bar("runs", "run") as progress:
            result = run_study(opts, progress=progress, check_paths=checked_with_json(json_out))
    except TwinError as exc:
        fail(str(exc))
    except OSError as exc:
        fail(f"{exc.filename or output}: {exc.strerror or exc}")
    if json_out != "-":
        typer.echo(f"{result.runs}/{result.planned} runs ({result.failed} failed) -> {output}/table.csv, analysis.json, plots")
        for f, per in result.main_effects.items():
            typer.echo(f"  {f}: " + ", ".join(f"{r} effect {v.effect:.3g}" for r, v in per.items()))
    emit_json(to_json(result), json_out)
