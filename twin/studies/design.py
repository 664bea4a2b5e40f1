"""Design points of a study, and the resolved scenario of every run (seeded from the study seed
and the run's index, so the executor does not change the results)."""

from __future__ import annotations

import copy
import hashlib
import itertools
from typing import TYPE_CHECKING

import numpy as np
import yaml

if TYPE_CHECKING:
    from twin.studies.spec import Study


def set_path(data: dict, dotted: str, value) -> None:
    """Set ``a.b.c`` (list indices as numbers) in a nested scenario dict, creating mappings.

    Parameters
    ----------
    data : dict
        Scenario data, changed in place.
    dotted : str
        The path, e.g. ``device.effects.package_fem.mould_cte_ppm_per_k``.
    value : object
        The value set, in the unit of the scenario key it sets.
    """
    keys = dotted.split(".")
    node = data
    for k in keys[:-1]:
        if isinstance(node, list):
            node = node[int(k)]
        else:
            if not isinstance(node.get(k), (dict, list)):
                node[k] = {}
            node = node[k]
    if isinstance(node, list):
        node[int(keys[-1])] = value
    else:
        node[keys[-1]] = value


def scenario_error(base: dict, assignments: dict) -> str | None:
    """Why ``base`` with ``assignments`` (dotted path → value, :func:`set_path`) is not a valid
    scenario (the message after its location), or ``None`` when it is valid.

    Parameters
    ----------
    base : dict
        Scenario data (not changed).
    assignments : dict
        Dotted path → value, each in its scenario key's unit.

    Returns
    -------
    str or None
        The validation message, or None for a valid scenario.
    """
    from twin.errors import TwinError
    from twin.model.scenario import parse_scenario

    data = copy.deepcopy(base)
    for path, value in assignments.items():
        set_path(data, path, value)
    try:
        parse_scenario(yaml.safe_dump(data, sort_keys=False), "<scenario>")
    except TwinError as exc:
        text = str(exc)
        return text.split(": ", 1)[-1] if text.startswith("<scenario>") else text
    return None


def design_points(study: Study) -> list[dict]:
    """Factor settings of every design point (replicates not included).

    A full factorial crosses the levels (ranged factors: ``design.levels`` evenly spaced values);
    the other designs draw points in the unit cube with ``scipy.stats.qmc`` (Latin hypercube,
    scrambled Sobol; Saltelli: the blocks A, B and A_B^i, A with column i from B, so N (d + 2)
    points) and scale them to each factor's range (log scale when ``log``) or levels.

    Parameters
    ----------
    study : Study

    Returns
    -------
    list of dict
        Per point, factor → value (in the unit of the scenario key it sets), in design order.

    References
    ----------
    McKay, Beckman & Conover (1979), Technometrics 21, 239–245: the Latin hypercube. Saltelli et
    al. (2010), Comput. Phys. Commun. 181, 259–270: the A, B, A_B^i design.
    """
    names = list(study.factors)
    specs = [study.factors[n] for n in names]
    d = len(names)

    def scale(u, spec):
        if spec.levels is not None:
            return spec.levels[min(int(u * len(spec.levels)), len(spec.levels) - 1)]
        lo, hi = spec.range
        return float(np.exp(np.log(lo) + u * (np.log(hi) - np.log(lo)))) if spec.log else float(lo + u * (hi - lo))

    t = study.design.type
    if t == "full_factorial":
        axes = []
        for spec in specs:
            if spec.levels is not None:
                axes.append(list(spec.levels))
            else:
                axes.append([scale(u, spec) for u in np.linspace(0, 1, study.design.levels)])
        return [dict(zip(names, combo)) for combo in itertools.product(*axes)]
    from scipy.stats import qmc

    if t == "latin_hypercube":
        U = qmc.LatinHypercube(d=d, seed=study.seed).random(study.design.points)
    elif t == "sobol":
        U = qmc.Sobol(d=d, scramble=True, seed=study.seed).random(study.design.points)
    else:  # Saltelli: A, B and the d matrices AB_i (A with column i from B): N (d + 2) runs
        AB = qmc.Sobol(d=2 * d, scramble=True, seed=study.seed).random(study.design.points)
        A, B = AB[:, :d], AB[:, d:]
        blocks = [A, B] + [np.where(np.arange(d) == i, B, A) for i in range(d)]
        U = np.vstack(blocks)
    return [{n: scale(u, s) for n, u, s in zip(names, row, specs)} for row in U]


def resolve(study: Study, base: dict, point: dict, index: int, replicate: int) -> tuple[str, dict]:
    """The run's scenario YAML and its key (hash of the resolved scenario and replicate).

    Parameters
    ----------
    study : Study
    base : dict
        The base scenario's data (not changed).
    point : dict
        Factor → value of the design point.
    index, replicate : int
        The point's index in the design and the replicate (0-based); with the study seed they
        seed the run.

    Returns
    -------
    key : str
        16 hex digits of the SHA-256 of the resolved scenario and the replicate.
    job : dict
        ``yaml``, ``index``, ``replicate``, ``point`` and ``seed`` of the run.
    """
    data = copy.deepcopy(base)
    for path, value in point.items():
        set_path(data, path, value)
    if study.logger_rate_hz:
        data.setdefault("test_plan", {})["logger_rate_hz"] = study.logger_rate_hz
    seed = int(np.random.SeedSequence([study.seed, index, replicate]).generate_state(1)[0])
    data["seed"] = seed
    text = yaml.safe_dump(data, sort_keys=True)
    key = hashlib.sha256(f"{text}\nreplicate={replicate}".encode()).hexdigest()[:16]
    return key, {"yaml": text, "index": index, "replicate": replicate, "point": point, "seed": seed}


def plan(study: Study, base: dict) -> list[dict]:
    """Every run of the study (design points × replicates) in design order.

    Parameters
    ----------
    study : Study
    base : dict
        The base scenario's data.

    Returns
    -------
    list of dict
        Per run, its ``key`` and job (:func:`resolve`).
    """
    jobs = []
    for i, point in enumerate(design_points(study)):
        for rep in range(study.replicates):
            key, job = resolve(study, base, point, i, rep)
            jobs.append({"key": key, **job})
    return jobs
