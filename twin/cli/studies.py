"""Study commands: the compensation benchmark and design-of-experiment studies."""

from __future__ import annotations

import sys
from pathlib import Path
from typing import Annotated, Optional

import typer

from twin.cli.common import JsonOpt, app, check_outputs, emit_json, fail
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
    our dT/dt extension, any --plugin compensators, the calibrated physics twin) on data whose truth is known."""
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
            result["optimizers"] = optimizer_benchmark(20)
        if report is not None:
            from twin.compensation.report import write_benchmark_report

            write_benchmark_report(report, result)
    except TwinError as exc:
        fail(str(exc))
    except OSError as exc:
        fail(f"{exc.filename or report}: {exc.strerror or exc}")
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
    emit_json(result, json_out)


@app.command()
def doe(
    study: Annotated[Path, typer.Argument(help="study YAML")],
    output: Annotated[Path, typer.Option("-o", "--output", help="output folder (runs.jsonl, table, plots)")],
    workers: Annotated[int, typer.Option("--workers", min=1, max=256, help="parallel runs")] = 1,
    executor: Annotated[str, typer.Option("--executor", help="local or dask")] = "local",
    scheduler: Annotated[Optional[str], typer.Option("--scheduler", help="dask scheduler address (default: a local cluster)")] = None,
    json_out: JsonOpt = None,
) -> None:
    """Run a design-of-experiment study; resumes where it stopped (finished runs are kept)."""
    from tqdm import tqdm

    from twin.studies.doe import load_study, plan, run_study, write_outputs

    if executor not in ("local", "dask"):
        fail(f"--executor must be 'local' or 'dask', got {executor!r}")
    try:
        st, base, folder = load_study(study)
        own = [output / n for n in ("runs.jsonl", "table.csv", "table.h5", "analysis.json", "main_effects.png",
                                     "response_surface.png", "sobol.png")]
        check_outputs([study, folder / st.base, *own], [None if json_out == "-" else json_out])
        if output.resolve() in (study.resolve(), (folder / st.base).resolve()):
            raise TwinError(f"-o {output}: the output folder would overwrite an input; choose another path")
        total = len(plan(st, base))
        with tqdm(total=total, desc="runs", unit="run", file=sys.stderr, disable=None) as bar:
            runs = run_study(st, base, output, workers, executor, scheduler, progress=lambda r: bar.update(1))
        failed = [r for r in runs if r["status"] != "ok"]
        if runs and len(failed) == len(runs):  # nothing to analyse: say why instead of an empty "success"
            raise TwinError(f"{study}: all {len(runs)} runs failed (kept in {output / 'runs.jsonl'}); the first: "
                            f"{failed[0].get('error', '?')}")
        analysis = write_outputs(st, runs, output)
    except TwinError as exc:
        fail(str(exc))
    except OSError as exc:
        fail(f"{exc.filename or output}: {exc.strerror or exc}")
    result = {"output": str(output), "runs": len(runs), "planned": total, "failed": analysis["failed"],
              "main_effects": analysis["main_effects"], "interactions": analysis["interactions"],
              "sobol": analysis["sobol"]}
    if json_out != "-":
        typer.echo(f"{len(runs)}/{total} runs ({analysis['failed']} failed) -> {output}/table.csv, analysis.json, plots")
        for f, per in analysis["main_effects"].items():
            typer.echo(f"  {f}: " + ", ".join(f"{r} effect {v['effect']:.3g}" for r, v in per.items()))
    emit_json(result, json_out)
