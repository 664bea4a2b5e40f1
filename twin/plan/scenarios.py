"""Scenario files of a planned test: the twin as calibrated, plus one hypothesis, under a candidate
program (docs/plan.md §2).

The planned test keeps the user's sensor (with the noise density the log showed) and the twin's
model; the chamber is the lumped air → board → die chain with the thermometer on the board, so a die
lag is a hypothesis like any other: ``thermal_lag`` at τ is a die τ behind the board, the other
hypotheses sit on a die that follows the board within :data:`NO_LAG_S`.
"""

from __future__ import annotations

import copy

import yaml

from sim.sensor import logger_white_sigma_g
from twin.effects import get_effect
from twin.model.scenario import LoadedScenario, parse_scenario
from twin.plan.hypotheses import NONE, WALK, Hypothesis

#: die time constant behind the board when no lag is hypothesised [s]: short against any ramp
NO_LAG_S = 1.0


def twin_values(finding: dict) -> dict[str, dict[str, float]]:
    """The twin's calibrated values from a compare finding: effect → parameter → value (fixed and
    held parameters included, as the finding reports them).

    Parameters
    ----------
    finding : dict
        A ``twin compare --json`` result of one axis.

    Returns
    -------
    dict
    """
    return {e: {p: float(est["value"]) for p, est in params.items()}
            for e, params in (finding.get("parameters") or {}).items()}


def noise_density_ug(loaded: LoadedScenario, finding: dict | None) -> float:
    """The sensor's white-noise density [µg/√Hz] scaled to the floor the log showed.

    Parameters
    ----------
    loaded : LoadedScenario
        The user's scenario (its sensor).
    finding : dict, optional
        The compare result (``noise_floor_g``, ``sample_rate_hz``); None keeps the sensor's density.

    Returns
    -------
    float
    """
    sensor = loaded.sensor()
    if not finding or not finding.get("noise_floor_g") or not finding.get("sample_rate_hz"):
        return float(sensor.noise_density_ug_per_sqrt_hz)
    model = logger_white_sigma_g(sensor, float(finding["sample_rate_hz"]))
    return float(sensor.noise_density_ug_per_sqrt_hz * float(finding["noise_floor_g"]) / model)


def base_scenario(loaded: LoadedScenario, finding: dict | None, name: str = "plan") -> dict:
    """The planned test's scenario without a program: the user's sensor, the twin's model and its
    calibrated values as the device, the lumped chain with the thermometer on the board.

    Parameters
    ----------
    loaded : LoadedScenario
    finding : dict, optional
    name : str

    Returns
    -------
    dict
        ``program`` and ``test_plan`` are filled by :func:`with_program`.
    """
    scn = loaded.scenario
    sensor = scn.device.sensor.model_dump(exclude_none=True, exclude_defaults=True, mode="json")
    sensor["noise_density_ug_per_sqrt_hz"] = noise_density_ug(loaded, finding)
    thermo = scn.chamber.thermometer
    twin_effects = list(scn.twin.effects)
    values = twin_values(finding) if finding else {}
    device = {e: _settable(e, values.get(e, {})) for e in twin_effects if get_effect(e).slot != "temperature"}
    board_tau = scn.chamber.lumped.board_tau_s if scn.chamber.lumped is not None else 300.0
    return {
        "name": name, "seed": int(scn.seed),
        "chamber": {"model": "lumped", "lumped": {"board_tau_s": float(board_tau), "die_tau_s": NO_LAG_S},
                    "thermometer": {"attached_to": "board", "tau_s": float(thermo.tau_s),
                                    "noise_c": float(thermo.noise_c), "resolution_c": float(thermo.resolution_c)}},
        "device": {"sensor": sensor, "effects": device},
        "twin": {"effects": twin_effects},
    }


def _settable(effect: str, values: dict[str, float]) -> dict[str, float]:
    """The values of ``effect`` a device accepts (its parameters, within their bounds)."""
    out = {}
    for p in get_effect(effect).parameters:
        if p.name in values:
            lo, hi = p.bounds
            out[p.name] = float(min(max(values[p.name], lo), hi))
    return out


def with_program(base: dict, program: dict, test_plan: dict) -> dict:
    """``base`` with a program and a test plan.

    Parameters
    ----------
    base : dict
        From :func:`base_scenario`.
    program, test_plan : dict
        Scenario sections.

    Returns
    -------
    dict
        A new scenario dict.
    """
    out = copy.deepcopy(base)
    out["program"] = copy.deepcopy(program)
    out["test_plan"] = copy.deepcopy(test_plan)
    return out


def with_hypothesis(scenario: dict, hyp: Hypothesis, values: dict[str, float] | None = None) -> dict:
    """``scenario`` with ``hyp`` in the device (a die lag through the thermal chain, a wandering bias
    in the sensor).

    Parameters
    ----------
    scenario : dict
    hyp : Hypothesis
    values : dict, optional
        The hypothesis' values for this simulation (default: its estimate).

    Returns
    -------
    dict
        A new scenario dict.
    """
    out = copy.deepcopy(scenario)
    if hyp.effect == NONE:
        return out
    values = hyp.values if values is None else values
    if hyp.effect == WALK:  # the sensor's bias instability, overridden
        out["device"]["sensor"].update({k: float(v) for k, v in values.items()})
        return out
    if get_effect(hyp.effect).slot == "temperature":
        out["chamber"]["lumped"]["die_tau_s"] = float(values.get("tau_s", get_effect(hyp.effect).parameters[0].default))
    else:
        out["device"]["effects"][hyp.effect] = _settable(hyp.effect, values)
    return out


def load(scenario: dict, path: str = "<plan>") -> LoadedScenario:
    """Parse a scenario dict as a file would be.

    Parameters
    ----------
    scenario : dict
    path : str
        Named in errors.

    Returns
    -------
    LoadedScenario
    """
    return parse_scenario(yaml.safe_dump(scenario, sort_keys=False), path)
