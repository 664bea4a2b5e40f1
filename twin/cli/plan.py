"""``twin plan``: design the chamber test that separates the rivals a finding left open."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated, Optional

import typer

from twin.cli.common import JsonOpt, app, emit_json, guard
from twin.errors import TwinError


def _limits(path: Path | None):
    """The chamber limits from a YAML file (defaults without one)."""
    from pydantic import ValidationError

    from twin.io import read_text
    from twin.model.yaml_loader import validation_message
    from twin.plan.programs import ChamberLimits
    from twin.text import load_yaml_mapping

    if path is None:
        return ChamberLimits()
    data, lines = load_yaml_mapping(read_text(path, "chamber limits YAML", TwinError), str(path), "chamber limits")
    try:
        return ChamberLimits(**data)
    except ValidationError as exc:
        raise TwinError(validation_message(exc, ChamberLimits, str(path), lines)) from None


def _finding(path: Path, axis: str | None, imu: int | None) -> dict:
    """One axis' compare result from a ``twin compare --json`` file (plain or ``--axes``)."""
    from twin.io import read_json

    data = read_json(path, "compare JSON", TwinError)
    if not isinstance(data, dict):
        raise TwinError(f"{path}: expected the JSON object of twin compare --json")
    if "imus" not in data:
        if "candidates" not in data:
            raise TwinError(f"{path}: no 'candidates' key; expected the JSON of twin compare --json")
        return data
    imus = data["imus"]
    pick = next((i for i in imus if imu is None or i.get("instance") == imu), None)
    if pick is None:
        raise TwinError(f"{path}: no IMU {imu}; it holds " + ", ".join(str(i.get("instance")) for i in imus))
    axes = pick["axes"]
    if axis is None:  # the first axis whose finding stays uncertain, else the first
        axis = next((a for a, r in axes.items() if r.get("confidence") == "uncertain"), next(iter(axes)))
    if axis not in axes:
        raise TwinError(f"{path}: --axis {axis}: the finding holds axes {', '.join(axes)}")
    return axes[axis]


@app.command("plan")
def plan_command(
    inputs: Annotated[list[Path], typer.Argument(metavar="INPUTS", help="FINDING.json SCENARIO (a twin compare --json result and the twin's scenario), or SCENARIO LOG (compare runs first), or SCENARIO with --rivals")],
    output: Annotated[Path, typer.Option("-o", "--output", help="the planned test's scenario YAML")],
    budget_h: Annotated[float, typer.Option("--budget-h", min=0.5, max=2000.0, help="chamber hours the test may take, every run included")] = 12.0,
    chamber: Annotated[Optional[Path], typer.Option("--chamber", help="chamber limits YAML (min_c, max_c, max_ramp_c_per_h, orientations, max_power_ons)")] = None,
    rivals: Annotated[Optional[str], typer.Option("--rivals", help="effects to separate instead of the finding's, comma-separated (none and bias_random_walk allowed)")] = None,
    axis: Annotated[Optional[str], typer.Option("--axis", help="axis of a --axes finding (default: the first uncertain one)")] = None,
    imu: Annotated[Optional[int], typer.Option("--imu", help="IMU instance of a --axes finding (default: the first)")] = None,
    check_seeds: Annotated[int, typer.Option("--check-seeds", min=0, max=10_000, help="simulated tests per rival in the check (0: no check)")] = 20,
    check_baseline: Annotated[bool, typer.Option("--check-baseline", help="check the scenario's protocol repeated as well")] = False,
    draws: Annotated[int, typer.Option("--draws", min=1, max=100, help="parameter draws per rival in the expected separation")] = 3,
    finalists: Annotated[int, typer.Option("--finalists", min=0, max=1000, help="best candidates raced by simulation through the blind diagnosis, each at every logger rate (0: none: the best by expected separation)")] = 6,
    seed: Annotated[int, typer.Option("--seed", min=0, help="seed of the simulations and draws")] = 0,
    workers: Annotated[int, typer.Option("--workers", min=1, max=256, help="parallel processes")] = 1,
    executor: Annotated[str, typer.Option("--executor", help="local or dask")] = "local",
    scheduler: Annotated[Optional[str], typer.Option("--scheduler", help="address of a running dask scheduler (default: a local cluster of --workers)")] = None,
    json_out: JsonOpt = None,
) -> None:
    """Design the test that separates the rivals a finding left open: the chamber program, orientations
    and power cycles within the budget that maximise the expected ΔBIC of the true rival over the best
    fit of the others, checked by simulating it with each rival as the truth and diagnosing blind.
    \f

    Parameters
    ----------
    inputs : list of Path
        ``FINDING.json SCENARIO``, ``SCENARIO LOG`` or ``SCENARIO`` (with ``--rivals``).
    output : Path
        The planned test's scenario YAML (program table and predicted separation as comments).
    budget_h : float
        Chamber hours [h].
    chamber : Path, optional
        Chamber limits YAML.
    rivals : str, optional
        Comma-separated effects to separate.
    axis, imu : optional
        The axis and IMU of a ``--axes`` finding.
    check_seeds : int
        Simulated tests per rival (0: no check).
    check_baseline : bool
        Check the scenario's protocol repeated too.
    draws : int
        Parameter draws per rival.
    finalists : int
        Best candidates raced by simulation through the blind diagnosis, each at every logger rate.
    seed : int
    workers : int
    executor : {"local", "dask"}
    scheduler : str, optional
    json_out : str, optional
        ``--json``: where the result goes (``-``: stdout).
    """
    from twin.cli.fleet import progress_bar
    from twin.io import atomic_write_text
    from twin.model.scenario import load_scenario
    from twin.plan.design import PlanSettings, plan_test, scenario_yaml

    if executor not in ("local", "dask"):
        from twin.cli.common import fail

        fail(f"--executor {executor}: expected local or dask")
    target = None if json_out == "-" else json_out
    with guard(inputs=inputs, outputs=[output, target]):
        scenario_path, finding = _scenario_and_finding(inputs, axis, imu)
        loaded = load_scenario(scenario_path)
        names = tuple(r.strip() for r in rivals.split(",") if r.strip()) if rivals else ()
        settings = PlanSettings(budget_h=budget_h, limits=_limits(chamber), rivals=names, draws=draws, finalists=finalists,
                                check_seeds=check_seeds, check_baseline=check_baseline, seed=seed, workers=workers,
                                executor=executor, scheduler=scheduler)
        with progress_bar("plan", "test") as progress:
            result, scenario = plan_test(loaded, finding, settings, progress=progress)
        from dataclasses import replace

        result = replace(result, scenario=str(output))
        atomic_write_text(output, scenario_yaml(result, scenario))
    if json_out != "-":
        _print(result, output)
    emit_json(result.to_json(), json_out)


def _scenario_and_finding(inputs: list[Path], axis: str | None, imu: int | None) -> tuple[Path, dict | None]:
    """(scenario, finding) from the positional inputs; a log is compared first."""
    yamls = [p for p in inputs if p.suffix.lower() in (".yaml", ".yml")]
    jsons = [p for p in inputs if p.suffix.lower() == ".json"]
    if len(yamls) != 1:
        raise TwinError("expected one scenario YAML among the inputs (FINDING.json SCENARIO, SCENARIO LOG or "
                        f"SCENARIO --rivals A,B); got {len(yamls)}")
    rest = [p for p in inputs if p not in yamls and p not in jsons]
    if jsons and rest or len(jsons) > 1:
        raise TwinError("give one finding JSON or measurement logs, not both")
    if jsons:
        return yamls[0], _finding(jsons[0], axis, imu)
    if not rest:
        return yamls[0], None
    from twin.workflows.compare import CompareOptions, run_compare

    result = run_compare(CompareOptions.build(scenario=yamls[0], measurements=rest))
    return yamls[0], result.to_json()


def _print(result, output: Path) -> None:
    p = result.plan
    typer.echo(f"plan: {p.description} ({p.chamber_hours:.3g} h) -> {output}")
    typer.echo("rivals: " + ", ".join(f"{r.effect} ({r.source})" for r in result.rivals)
               + (f"; set aside (no test in the budget makes them visible): {', '.join(result.set_aside)}"
                  if result.set_aside else ""))
    for q in p.pairs:
        typer.echo(f"  {q.truth} true, over {q.rival}: expected ΔBIC {q.expected_delta_bic:.3g}")
    for b in result.baselines:
        typer.echo(f"  baseline {b.name}: {b.description}, {b.chamber_hours:.3g} h, worst ΔBIC {b.worst_expected_delta_bic:.3g}")
    for label, check in (("plan", result.check), ("protocol repeated", result.baseline_check)):
        for c in check or ():
            pred = "" if c.predicted is None else f", predicted {100 * c.predicted:.0f} %"
            typer.echo(f"  check ({label}): {c.truth} true -> named first in {c.named_first}/{c.seeds} "
                       f"({100 * c.rate:.0f} %, 95 % CI {100 * c.ci95[0]:.0f}-{100 * c.ci95[1]:.0f} %{pred})")
    typer.echo(result.why)
