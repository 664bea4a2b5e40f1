"""A simulated fleet for testing: N units drawn from a fleet scenario, each unit's canonical CSV
written, and the truth kept apart in ``truth.json`` (the fleet's analysis never reads it).

A fleet scenario names a base scenario (the twin and the test every unit goes through), the unit
count, a seed, per-unit spreads (``vary``) and hidden effects, each with a prevalence and the
scenario values it sets (``set``) or draws (``draw``). Unit i draws from the seed sequence
(seed, i) only, so a unit is the same whatever the order, the worker or the other units.
"""

from __future__ import annotations

import json
import os
import re
from pathlib import Path

import yaml

from twin.fleet.result import Population, Prevalence, SimulatedFleet
from twin.fleet.scenario import FleetScenario, draw_unit, family_of, load_fleet_scenario, unit_scenario
from twin.fleet.spec import FleetError
from twin.io import atomic_write_text

def check_every_unit(fs: FleetScenario, source: str) -> None:
    """Draw and validate every unit's scenario before anything is written: an ordinary draw that
    gives one unit an invalid value (a normal's tail below a bound) stops the fleet here, not
    after earlier units' logs were written.

    Parameters
    ----------
    fs : FleetScenario
    source : str
    """

    from twin.errors import TwinError

    for i in range(fs.units):
        try:
            unit_scenario(fs, i)
        except TwinError as exc:  # the line of a generated YAML says nothing: the unit and its key do
            detail = re.sub(rf"^<fleet unit {re.escape(fs.unit_id(i))}>(:\d+)?: ", "", str(exc))
            raise FleetError(f"{source}: unit {fs.unit_id(i)} as drawn: {detail}") from None


def simulate_unit(fs: FleetScenario, i: int, path: str) -> str:
    """Simulate unit ``i`` and write its logged columns (no truth) as canonical CSV at ``path``.

    Parameters
    ----------
    fs : FleetScenario
    i : int
    path : str

    Returns
    -------
    str
        ``path``.
    """
    from twin.measurement import from_dataset, write_canonical_csv
    from twin.model.simulate import simulate

    m = from_dataset(simulate(unit_scenario(fs, i)))
    write_canonical_csv(path, m.time_s, m.temperature_c, m.output_g, m.applied_g, m.run_index, m.power_on)
    return path


def truth_document(fs: FleetScenario) -> dict:
    """Every unit's hidden effects and drawn values, and the true prevalence of each effect.

    Parameters
    ----------
    fs : FleetScenario

    Returns
    -------
    dict
        ``truth.json``: ``fleet``, ``seed``, ``units`` (:func:`draw_unit`), ``prevalence`` [1], ``families``.
    """
    units = [draw_unit(fs, i)[1] for i in range(fs.units)]
    prev = {name: sum(name in t["effects"] for t in units) / fs.units for name in fs.effects}
    return {"fleet": fs.name, "seed": fs.seed, "units": units, "prevalence": prev,
            "families": {name: family_of(name, e) for name, e in fs.effects.items()}}


def simulate_fleet(fleet_scenario: str | Path, out_dir: str | Path, workers: int = 1, progress=None) -> SimulatedFleet:
    """Write ``out_dir/logs/<unit>.csv`` for every unit (skipping those already written: atomic
    writes), ``out_dir/truth.json`` and ``out_dir/fleet.yaml`` (the spec that analyses the logs).

    Parameters
    ----------
    fleet_scenario : str or Path
        The fleet scenario YAML.
    out_dir : str or Path
        The output folder.
    workers : int
        Parallel simulations.
    progress : callable, optional
        Called once per unit (written or found written).

    Returns
    -------
    SimulatedFleet
    """
    from twin.fleet.ledger import remove_temporaries
    from twin.fleet.runner import die_with_parent

    fs = load_fleet_scenario(fleet_scenario)
    out = Path(out_dir)
    if out.exists() and not out.is_dir():
        raise FleetError(f"{out}: the output must be a folder, and this is a file")
    check_every_unit(fs, str(fleet_scenario))
    logs = out / "logs"
    logs.mkdir(parents=True, exist_ok=True)
    remove_temporaries(out)
    truth = truth_document(fs)
    atomic_write_text(out / "truth.json", json.dumps(truth, indent=1) + "\n")
    spec = {"name": fs.name, "command": "compare", "scenario": os.path.relpath(fs.base_path, out.resolve()),
            "units": "logs/*.csv"}
    atomic_write_text(out / "fleet.yaml", "# written by twin fleet-simulate; truth.json is never read by twin fleet\n"
                      + yaml.safe_dump(spec, sort_keys=False))
    tick = progress or (lambda: None)
    todo = []
    for i in range(fs.units):
        if (logs / f"{fs.unit_id(i)}.csv").is_file():
            tick()
        else:
            todo.append(i)
    if workers > 1 and len(todo) > 1:
        from concurrent.futures import ProcessPoolExecutor, as_completed

        with ProcessPoolExecutor(workers, initializer=die_with_parent) as ex:
            for f in as_completed([ex.submit(simulate_unit, fs, i, str(logs / f"{fs.unit_id(i)}.csv")) for i in todo]):
                f.result()
                tick()
    else:
        for i in todo:
            simulate_unit(fs, i, str(logs / f"{fs.unit_id(i)}.csv"))
            tick()
    return SimulatedFleet(output=str(out), units=fs.units, written=len(todo), spec=str(out / "fleet.yaml"),
                          truth=str(out / "truth.json"), prevalence=truth["prevalence"])


def score_against_truth(pop: Population, truth: dict) -> dict:
    """Estimated prevalence against the truth of the same units, in percentage points, three ways:
    the share of units whose finding names the effect itself (``error_pp``), names any effect of
    its family (``family_error_pp``), or names one of its family first (``primary_error_pp``).

    Parameters
    ----------
    pop : Population
        The fleet's population view.
    truth : dict
        ``truth.json`` of the simulated fleet.

    Returns
    -------
    dict
        Effect → true and estimated shares [%] and their differences [percentage points].
    """
    out = {}
    for name, true_share in truth["prevalence"].items():
        fam = truth["families"][name]
        est = _share(pop.prevalence, name)
        est_fam = _share(pop.prevalence_by_family, fam)
        est_first = _share(pop.prevalence_primary_family, fam)
        out[name] = {"true_percent": 100 * true_share, "family": fam,
                     "estimated_percent": 100 * est, "error_pp": 100 * (est - true_share),
                     "estimated_family_percent": 100 * est_fam, "family_error_pp": 100 * (est_fam - true_share),
                     "estimated_primary_percent": 100 * est_first, "primary_error_pp": 100 * (est_first - true_share)}
    return out


def _share(counted: dict[str, Prevalence], name: str) -> float:
    """The share of units [1] naming ``name``; 0 when none does."""
    return counted[name].share if name in counted else 0.0
