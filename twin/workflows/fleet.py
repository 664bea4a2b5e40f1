"""``twin fleet`` and ``twin fleet-simulate`` as functions: options in, the typed result out.

:func:`run_fleet` analyses every unit not yet in the output folder's ledger and writes the
population view (``table.csv``, ``population.json``, ``summary.html``); :func:`run_fleet_simulation`
writes a simulated fleet's logs, its truth apart, and the spec that analyses them blind.

Both take two optional callbacks from their caller: ``progress(done, total)``, called once the
total is known (``done`` = 0) and after every unit, and ``check_paths(inputs, outputs)``, the
caller's guard against writing over an input, called once the inputs are known and before any
unit runs (the CLI adds its ``--json`` target to ``outputs`` there).
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

from pydantic import Field

from twin.errors import TwinError
from twin.fleet.result import FleetResult, SimulatedFleet
from twin.workflows.options import Options

Progress = Callable[[int, int], None]
CheckPaths = Callable[[list, list], None]


class FleetOptions(Options):
    """What ``twin fleet`` is asked to do.

    Attributes
    ----------
    spec : str or Path
        Fleet YAML, or a glob or folder of unit logs (then ``scenario`` gives the twin).
    output : Path
        Output folder (``units.jsonl``, ``units/<id>/``, the table, population and summary).
    workers : int
        Units analysed in parallel.
    executor : str
        ``local`` (a process pool) or ``dask``; anything else is refused by :func:`run_fleet`
        before the spec is read.
    scheduler : str, optional
        Address of a running Dask scheduler (default: a local cluster of ``workers``).
    scenario : Path, optional
        The twin's scenario (overrides the spec's).
    command : str, optional
        ``compare`` or ``calibrate`` (overrides the spec's).
    """

    spec: str | Path
    output: Path
    workers: int = Field(1, ge=1)
    executor: str = "local"
    scheduler: str | None = None
    scenario: Path | None = None
    command: str | None = None


class SimulateFleetOptions(Options):
    """What ``twin fleet-simulate`` is asked to do.

    Attributes
    ----------
    fleet_scenario : Path
        Fleet scenario YAML (base scenario, units, seed, hidden effects with prevalences).
    output : Path
        Folder for ``logs/``, ``truth.json`` and ``fleet.yaml``.
    workers : int
        Units simulated in parallel.
    """

    fleet_scenario: Path
    output: Path
    workers: int = Field(1, ge=1)


def _counter(progress: Progress | None, total: int) -> Callable[..., None]:
    """A per-unit tick that reports (units done, ``total``) to ``progress``; reports (0, total) now."""
    if progress is None:
        return lambda *_: None
    progress(0, total)
    done = 0

    def tick(*_) -> None:
        nonlocal done
        done += 1
        progress(done, total)

    return tick


def run_fleet(opts: FleetOptions, progress: Progress | None = None,
              check_paths: CheckPaths | None = None) -> FleetResult:
    """Analyse every unit of a fleet durably, then write its table, population and summary.

    A rerun skips the units the ledger holds; a unit whose logs are bad is a row with its error.

    Parameters
    ----------
    opts : FleetOptions
    progress : callable, optional
        ``progress(units done, units in the fleet)``.
    check_paths : callable, optional
        ``check_paths(inputs, outputs)``: refuses an output that would replace an input.

    Returns
    -------
    FleetResult
    """
    from twin.fleet import runner
    from twin.fleet.ledger import FOLDER_OUTPUTS, LEDGER
    from twin.fleet.population import population, write_population, write_table
    from twin.fleet.spec import load_fleet_spec
    from twin.fleet.summary import write_summary

    if opts.executor not in ("local", "dask"):
        raise TwinError(f"--executor must be 'local' or 'dask', got {opts.executor!r}")
    fs = load_fleet_spec(opts.spec, opts.scenario, opts.command)
    output = opts.output
    inputs = {Path(f).resolve() for u in fs.units for f in u.files}
    if output.resolve() in inputs or any(output.resolve() in p.parents for p in inputs):
        raise TwinError(f"{output}: the output folder holds the fleet's logs; choose another folder")
    if check_paths is not None:
        # the fleet's own files never over an input (a --scenario named out/table.csv was replaced),
        # nor a folder where a file goes (units.jsonl as a folder failed after the first unit)
        check_paths([*inputs, opts.spec, fs.scenario], [output / name for name in (LEDGER, ".lock", *FOLDER_OUTPUTS)])
    run = runner.run_units(fs, output, opts.workers, opts.executor, opts.scheduler,
                           progress=_counter(progress, len(fs.units)))
    pop = population(run.records, fs.outlier_threshold)
    write_table(output, run.records)
    write_population(output, pop)
    write_summary(output, run.records, pop, title=f"twin fleet: {fs.name or fs.source}")
    return FleetResult(
        output=str(output), units=len(fs.units), ran=run.ran, skipped=run.skipped, notes=tuple(run.notes),
        ok=pop.ok, errors=pop.errors, prevalence=pop.prevalence, prevalence_by_family=pop.prevalence_by_family,
        prevalence_primary_family=pop.prevalence_primary_family, none_named=pop.none_named,
        confidence=pop.confidence, parameters=pop.parameters, outlier_threshold=pop.outlier_threshold,
        outliers=pop.outliers, failed=pop.failed)


def run_fleet_simulation(opts: SimulateFleetOptions, progress: Progress | None = None,
                         check_paths: CheckPaths | None = None) -> SimulatedFleet:
    """Simulate a fleet: each unit's log (canonical CSV), the truth apart, and the spec.

    Parameters
    ----------
    opts : SimulateFleetOptions
    progress : callable, optional
        ``progress(units written or found, units in the fleet)``.
    check_paths : callable, optional
        ``check_paths(inputs, outputs)``: refuses an output that would replace an input.

    Returns
    -------
    SimulatedFleet
    """
    from twin.fleet.scenario import load_fleet_scenario
    from twin.fleet.simulate import simulate_fleet

    fs = load_fleet_scenario(opts.fleet_scenario)
    output = opts.output
    written = [output / "fleet.yaml", output / "truth.json"]
    if check_paths is not None:
        # what it writes is checked before any unit runs: never over the fleet scenario or its base
        check_paths([opts.fleet_scenario, fs.base_path], written)
        check_paths([*written, output / "logs"], [])
    logs = (output / "logs").resolve()
    if any(logs in Path(p).resolve().parents for p in (opts.fleet_scenario, fs.base_path)):
        raise TwinError(f"{output}: its logs/ folder holds the fleet scenario or its base; choose another folder")
    return simulate_fleet(opts.fleet_scenario, output, opts.workers, progress=_counter(progress, fs.units))
