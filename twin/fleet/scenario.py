"""A fleet scenario: the base scenario, unit count, seed, per-unit spreads and hidden effects,
read and checked (see :mod:`twin.fleet.simulate` for drawing and writing the units).
"""

from __future__ import annotations

import copy
import math
import re
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import yaml

from twin.fleet.spec import FleetError
from twin.io import read_text
from twin.text import did_you_mean, load_yaml_mapping


KEYS = ("name", "description", "base", "units", "seed", "id_prefix", "draw", "logger_rate_hz", "vary", "effects")
EFFECT_KEYS = ("prevalence", "family", "set", "draw")
DISTRIBUTIONS = ("uniform", "loguniform", "normal", "choice")


@dataclass
class FleetScenario:
    """A fleet scenario, resolved: the base scenario's data and the draws of every unit.

    Attributes
    ----------
    base, base_path : dict, str
        The base scenario's data and its file (absolute).
    units, seed : int
        Unit count; with a unit's index, the seed of that unit's draws.
    id_prefix, name : str
        Unit ids are the prefix and the zero-padded index; the fleet's name.
    exclusive : bool
        At most one hidden effect per unit (one uniform draw); False: each drawn independently.
    logger_rate_hz : float or None
        Overrides the base scenario's logger rate [Hz].
    vary, effects : dict
        Scenario path → distribution spec of the per-unit spread (in the key's unit); hidden
        effect → ``prevalence`` [1], optional ``family``, ``set`` and ``draw``.
    """

    base: dict
    base_path: str
    units: int
    seed: int = 0
    id_prefix: str = "unit"
    exclusive: bool = True
    logger_rate_hz: float | None = None
    vary: dict = field(default_factory=dict)
    effects: dict = field(default_factory=dict)
    name: str = ""

    def unit_id(self, i: int) -> str:
        """The id of unit ``i`` (0-based): ``id_prefix`` and ``i`` zero-padded to ≥ 4 digits.

        Parameters
        ----------
        i : int

        Returns
        -------
        str
        """
        return f"{self.id_prefix}{i:0{max(4, len(str(self.units - 1)))}d}"


def _check_distribution(spec, where: str) -> None:
    if isinstance(spec, (int, float)) and not isinstance(spec, bool) and not math.isfinite(spec):
        raise FleetError(f"{where}: got {spec!r}, expected a finite number")
    if isinstance(spec, (int, float, str)) and not isinstance(spec, bool):
        return
    if not (isinstance(spec, dict) and len(spec) == 1 and next(iter(spec)) in DISTRIBUTIONS):
        raise FleetError(f"{where}: expected a number or one of {{{', '.join(DISTRIBUTIONS)}: [...]}}, got {spec!r}")
    kind, args = next(iter(spec.items()))
    if kind != "choice" and not (isinstance(args, list) and len(args) == 2
                                 and all(isinstance(a, (int, float)) and not isinstance(a, bool)
                                         and math.isfinite(a) and abs(a) <= 1e300 for a in args)):
        raise FleetError(f"{where}: {kind} takes two finite numbers, got {args!r}")
    if kind in ("uniform", "loguniform") and not args[0] <= args[1] or kind == "loguniform" and args[0] <= 0:
        raise FleetError(f"{where}: {kind} needs 0 < low <= high (loguniform) or low <= high, got {args}")
    if kind == "normal" and args[1] < 0:
        raise FleetError(f"{where}: normal takes [mean, standard deviation >= 0], got {args}")
    if kind == "choice" and not (isinstance(args, list) and args):
        raise FleetError(f"{where}: choice takes a non-empty list")


def _mapping(data: dict, key: str, where: str) -> dict:
    """``data[key]`` when it is a mapping (or absent: empty); else one line naming the key."""
    value = data.get(key) or {}
    if not isinstance(value, dict):
        raise FleetError(f"{where}: {key}: expected a mapping, got {type(value).__name__}")
    return value


def draw_value(spec, rng: np.random.Generator):
    """One draw of a distribution spec (a constant is itself).

    Parameters
    ----------
    spec : object
        A constant, ``{uniform | loguniform: [lo, hi]}``, ``{normal: [mean, sd]}`` or ``{choice: [...]}``.
    rng : numpy.random.Generator

    Returns
    -------
    object
        The value, in the unit of the key it sets.
    """
    if not isinstance(spec, dict):
        return spec
    kind, args = next(iter(spec.items()))
    if kind == "uniform":
        return float(rng.uniform(*args))
    if kind == "loguniform":
        return float(np.exp(rng.uniform(np.log(args[0]), np.log(args[1]))))
    if kind == "normal":
        return float(rng.normal(*args))
    return args[int(rng.integers(len(args)))]


def load_fleet_scenario(path: str | Path) -> FleetScenario:
    """Read and check a fleet scenario (one-line errors naming the file, line and key).

    Parameters
    ----------
    path : str or Path

    Returns
    -------
    FleetScenario
        Checked: unit 0 and every end of a range or choice give valid scenarios.
    """
    path = Path(path)
    data, lines = load_yaml_mapping(read_text(path, "fleet scenario", FleetError), str(path),
                                    "a fleet scenario is a YAML mapping")
    at = lambda *key: f"{path}:{lines.get(tuple(key), lines.get(key[:1], 1))}"  # noqa: E731
    for key in data:
        if key not in KEYS:
            raise FleetError(f"{at(key)}: unknown key {key!r}{did_you_mean(key, KEYS, label='valid keys')}")
    for key in ("base", "units"):
        if key not in data:
            raise FleetError(f"{path}: missing key {key!r}")
    n = data["units"]
    if not isinstance(n, int) or isinstance(n, bool) or not 1 <= n <= 100_000:
        raise FleetError(f"{at('units')}: units must be an integer in 1..100000, got {n!r}")
    _check_plain(data, at)
    base_path = path.parent / str(data["base"])
    if not isinstance(data["base"], str) or not base_path.is_file():
        raise FleetError(f"{at('base')}: base scenario {base_path} not found")
    from twin.model.scenario import load_scenario

    load_scenario(base_path)  # a broken base is the base's error, named there
    base = yaml.safe_load(base_path.read_text(encoding="utf-8"))
    if data.get("draw", "exclusive") not in ("exclusive", "independent"):
        raise FleetError(f"{at('draw')}: draw must be 'exclusive' (at most one effect per unit) or 'independent'")
    vary = _mapping(data, "vary", at("vary"))
    for k, spec in vary.items():
        _check_distribution(spec, f"{at('vary', k)}: vary.{k}")
    effects = _mapping(data, "effects", at("effects"))
    for name, e in effects.items():
        if not isinstance(e, dict):
            raise FleetError(f"{at('effects', name)}: effects.{name} is a mapping (prevalence, set, draw)")
        for key in ("set", "draw"):
            _mapping(e, key, f"{at('effects', name, key)}: effects.{name}")
        for key in e:
            if key not in EFFECT_KEYS:
                raise FleetError(f"{at('effects', name, key)}: unknown key {key!r} in effects.{name}"
                                 f"{did_you_mean(key, EFFECT_KEYS, label='valid keys')}")
        p = e.get("prevalence")
        if not isinstance(p, (int, float)) or isinstance(p, bool) or not 0 <= p <= 1:
            raise FleetError(f"{at('effects', name)}: effects.{name}.prevalence must be in [0, 1], got {p!r}")
        for k, spec in (e.get("draw") or {}).items():
            _check_distribution(spec, f"{at('effects', name, 'draw', k)}: effects.{name}.draw.{k}")
    exclusive = data.get("draw", "exclusive") == "exclusive"
    if exclusive and sum(e["prevalence"] for e in effects.values()) > 1 + 1e-12:
        raise FleetError(f"{at('effects')}: with draw: exclusive the prevalences must sum to at most 1")
    fs = FleetScenario(base, str(base_path.resolve()), n, data.get("seed", 0), data.get("id_prefix", "unit"),
                       exclusive, data.get("logger_rate_hz"), vary, effects, str(data.get("name", path.stem)))
    unit_scenario(fs, 0)  # every path set or drawn must give a valid scenario: checked on unit 0
    _probe_ends(fs, at)
    return fs


# unit ids name the log files logs/<id>.csv: a plain prefix, never a path
_PREFIX = re.compile(r"[A-Za-z0-9_-][A-Za-z0-9_.-]{0,63}|")


def _check_plain(data: dict, at) -> None:
    """The scalar keys: seed, id_prefix, name, description, logger_rate_hz (types and ranges)."""
    seed = data.get("seed", 0)
    if isinstance(seed, bool) or not isinstance(seed, int) or not 0 <= seed <= 2**63 - 1:
        raise FleetError(f"{at('seed')}: seed: got {seed!r}, expected an integer in 0..2**63-1")
    prefix = data.get("id_prefix", "unit")
    if not isinstance(prefix, str) or not _PREFIX.fullmatch(prefix):
        raise FleetError(f"{at('id_prefix')}: id_prefix: got {prefix!r}, expected up to 64 letters, digits, '_', "
                         "'-' or '.' (not first): it names the unit's log file")
    for key in ("name", "description"):
        if not isinstance(data.get(key, ""), str):
            raise FleetError(f"{at(key)}: {key}: expected text, got {type(data[key]).__name__}")
    rate = data.get("logger_rate_hz")
    if rate is not None and (isinstance(rate, bool) or not isinstance(rate, (int, float)) or not 0 < rate < math.inf):
        raise FleetError(f"{at('logger_rate_hz')}: logger_rate_hz: got {rate!r}, expected a finite rate > 0 [Hz]")


def _probe_ends(fs: FleetScenario, at) -> None:
    """Each end of a uniform / loguniform draw and each choice, put into unit 0, gives a valid
    scenario: a bad value is refused now, not found by whichever unit draws it mid-run."""
    from twin.studies.design import scenario_error

    unit0, _ = draw_unit(fs, 0)
    groups = [(("vary",), {}, fs.vary)] + [(("effects", n, "draw"), e.get("set") or {}, e.get("draw") or {})
                                          for n, e in fs.effects.items()]
    for loc, fixed, draws in groups:
        for key, spec in draws.items():
            kind, args = next(iter(spec.items())) if isinstance(spec, dict) else ("normal", [])
            for value in (args[:100] if kind != "normal" else []):
                detail = scenario_error(unit0, {**fixed, key: value})
                if detail is not None:
                    raise FleetError(f"{at(*loc, key)}: {'.'.join(loc)}.{key}: {kind} value {value!r} gives an "
                                     f"invalid unit: {detail}")


def family_of(name: str, entry: dict) -> str:
    """A hidden effect's family: its entry's ``family``, the registered effect's, or its name.

    Parameters
    ----------
    name : str
        The hidden effect.
    entry : dict
        Its entry in the fleet scenario's ``effects``.

    Returns
    -------
    str
    """
    from twin.effects import REGISTRY

    return entry.get("family") or (REGISTRY[name].family if name in REGISTRY else name)


def draw_unit(fs: FleetScenario, i: int) -> tuple[dict, dict]:
    """(scenario data, truth) of unit ``i``, from the seed sequence (seed, i) alone.

    Parameters
    ----------
    fs : FleetScenario
    i : int

    Returns
    -------
    data, truth : dict
        The unit's scenario data; ``unit``, carried ``effects``, their ``families``, the drawn
        ``parameters`` (in their keys' units) and the scenario ``seed``.
    """
    from twin.studies.design import set_path

    rng = np.random.default_rng(np.random.SeedSequence([fs.seed, i]))
    data = copy.deepcopy(fs.base)
    data["seed"] = int(rng.integers(2**31 - 1))
    if fs.logger_rate_hz is not None:
        set_path(data, "test_plan.logger_rate_hz", float(fs.logger_rate_hz))
    u = float(rng.random())
    carried, edge = [], 0.0
    for name, e in fs.effects.items():  # exclusive: one uniform draw picks at most one effect
        if fs.exclusive:
            if edge <= u < edge + e["prevalence"]:
                carried.append(name)
            edge += e["prevalence"]
        elif rng.random() < e["prevalence"]:
            carried.append(name)
    params = {}
    for key in sorted(fs.vary):
        params[key] = draw_value(fs.vary[key], rng)
        set_path(data, key, params[key])
    for name in fs.effects:
        e = fs.effects[name]
        drawn = {k: draw_value(spec, rng) for k, spec in sorted((e.get("draw") or {}).items())}
        if name in carried:  # drawn for every unit, so one unit's values do not shift the others'
            for k, v in {**(e.get("set") or {}), **drawn}.items():
                set_path(data, k, v)
            params.update(drawn)
    truth = {"unit": fs.unit_id(i), "effects": carried, "families": [family_of(n, fs.effects[n]) for n in carried],
             "parameters": params, "seed": data["seed"]}
    return data, truth


def unit_scenario(fs: FleetScenario, i: int):
    """The validated scenario of unit ``i`` (a bad path or value names the fleet scenario's unit).

    Parameters
    ----------
    fs : FleetScenario
    i : int

    Returns
    -------
    LoadedScenario
    """
    from twin.model.scenario import parse_scenario

    data, _ = draw_unit(fs, i)
    return parse_scenario(yaml.safe_dump(data, sort_keys=False), f"<fleet unit {fs.unit_id(i)}>")
