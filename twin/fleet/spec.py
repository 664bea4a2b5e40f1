"""The fleet file: which analysis, which twin, and the units (one glob, a folder, or a mapping of
unit ids to files); several files of one unit are runs of that unit."""

from __future__ import annotations

import glob as globlib
import math
from dataclasses import dataclass, field
from pathlib import Path

from twin.errors import TwinError
from twin.text import did_you_mean, load_yaml_mapping

COMMANDS = ("compare", "calibrate")
TOP_KEYS = ("name", "description", "command", "scenario", "units", "columns", "options", "outlier_threshold")
OPTIONS = {
    "compare": {"with_effects": list, "average_s": (int, float), "applied_g": (int, float, str),
                "skip_bad_rows": bool, "report": bool, "refit": bool},
    "calibrate": {"imu": (int, str), "skip_bad_rows": bool, "reverse": bool},
}
DEFAULTS = {"with_effects": [], "average_s": 10.0, "applied_g": 1.0, "skip_bad_rows": False, "report": False,
            "refit": False, "imu": "all", "reverse": True}


class FleetError(TwinError):
    """A fleet file, its units or its output folder is not usable."""


def check_unit_id(uid, where: str) -> str:
    """``uid`` as a string, or :class:`FleetError` when it could name a path outside ``units/``.

    Parameters
    ----------
    uid : object
        The unit id as written (a YAML key may be a number).
    where : str
        The file and line, for the message.

    Returns
    -------
    str
        The id: 1–128 characters, no ``/``, ``\\`` or NUL, no leading ``.``.
    """
    text = str(uid)
    # the id names the unit's folder units/<id>: one plain path component, never '..' or hidden
    if isinstance(uid, bool) or uid is None or not 0 < len(text) <= 128 or text.startswith(".") \
            or any(c in text for c in "/\\\0"):
        raise FleetError(f"{where}: unit id {uid!r}: expected a name of 1-128 characters without '/', '\\' or a "
                         "leading '.' (it names the unit's folder)")
    return text


@dataclass
class Unit:
    """One unit: its id and its log files (several files are several runs).

    Attributes
    ----------
    id : str
        The unit's id (names its folder ``units/<id>``).
    files : list of str
        Its log files, sorted.
    """

    id: str
    files: list[str]


@dataclass
class FleetSpec:
    """A resolved fleet: the analysis, its twin scenario (compare), the units and their options.

    Attributes
    ----------
    units : list of Unit
        Sorted by id.
    command : {"compare", "calibrate"}
        The analysis run on every unit.
    scenario : str or None
        The twin's scenario file, absolute (compare); None for calibrate.
    columns : dict
        Column-map keys (:class:`twin.measurement.ColumnMap`) for delimited logs.
    options : dict
        The command's options given in the file (:data:`OPTIONS`; the rest take :data:`DEFAULTS`).
    name : str
        The fleet's name.
    source : str
        The fleet file, or the glob / folder given.
    outlier_threshold : float
        |robust z| above which a unit's value is an outlier [1].
    """

    units: list[Unit]
    command: str = "compare"
    scenario: str | None = None
    columns: dict = field(default_factory=dict)
    options: dict = field(default_factory=dict)
    name: str = ""
    source: str = "<glob>"
    outlier_threshold: float = 3.5

    def settings(self) -> dict:
        """What a worker needs besides the unit (plain data, picklable).

        Returns
        -------
        dict
            ``command``, ``scenario``, ``columns`` and ``options`` (defaults filled in).
        """
        return {"command": self.command, "scenario": self.scenario, "columns": dict(self.columns),
                "options": {**{k: DEFAULTS[k] for k in OPTIONS[self.command]}, **self.options}}


def _unit_files(folder: Path) -> list[str]:
    """The log files of a unit's folder, sorted (hidden files skipped)."""
    return [str(p) for p in sorted(folder.iterdir()) if p.is_file() and not p.name.startswith(".")]


def discover_units(pattern, base: Path, where: str) -> list[Unit]:
    """Units from a glob or folder (each file is a unit named by its stem, each folder a unit named
    by its name) or from a mapping id → glob or list of files.

    Parameters
    ----------
    pattern : str or dict
        A glob or folder, or unit id → glob or list of files.
    base : Path
        The folder relative paths are taken from (the fleet file's).
    where : str
        The file and line, for the messages.

    Returns
    -------
    list of Unit
        Sorted by id.

    Raises
    ------
    FleetError
        Nothing matches, a mapped unit names a folder, two units share an id, or a name is not
        valid UTF-8.
    """
    units: list[Unit] = []
    if isinstance(pattern, dict):
        for uid, files in pattern.items():
            pats = [files] if isinstance(files, str) else files
            if not isinstance(pats, list) or not all(isinstance(p, str) for p in pats):
                raise FleetError(f"{where}: units.{uid}: expected a glob or a list of files")
            found = sorted({m for p in pats for m in globlib.glob(str(base / p))})
            if not found:
                raise FleetError(f"{where}: units.{uid}: no file matches {', '.join(pats)}")
            folders = [m for m in found if Path(m).is_dir()]
            if folders:
                raise FleetError(f"{where}: units.{uid}: {folders[0]} is a folder; expected log files")
            units.append(Unit(check_unit_id(uid, where), found))
    elif isinstance(pattern, str):
        target = base / pattern
        matches = [target / p.name for p in sorted(target.iterdir())] if target.is_dir() else \
            [Path(m) for m in sorted(globlib.glob(str(target)))]
        for m in matches:
            if m.name.startswith("."):
                continue
            if m.is_dir():
                files = _unit_files(m)
                if files:
                    units.append(Unit(m.name, files))
            else:
                units.append(Unit(m.stem, [str(m)]))
        if not units:
            raise FleetError(f"{where}: units: nothing matches {pattern!r} (relative to {base})")
    else:
        raise FleetError(f"{where}: units: expected a glob, a folder or a mapping of unit ids to files")
    seen: dict[str, Unit] = {}
    for u in units:
        if u.id in seen:
            raise FleetError(f"{where}: two units are named {u.id!r} ({seen[u.id].files[0]} and {u.files[0]}); "
                             "give them a mapping of unit ids to files")
        seen[u.id] = u
    for u in units:  # a name the fleet's UTF-8 table, JSON and HTML cannot hold fails after every unit ran
        for name in (u.id, *map(str, u.files)):
            try:
                name.encode("utf-8")
            except UnicodeEncodeError:
                raw = name.encode("utf-8", "surrogateescape").decode("ascii", "backslashreplace")
                raise FleetError(f"{where}: unit file or id '{raw}' is not valid UTF-8; rename it (the fleet's "
                                 "table, JSON and report are UTF-8)") from None
    return sorted(units, key=lambda u: u.id)


def load_fleet_spec(spec: str | Path, scenario: str | Path | None = None, command: str | None = None) -> FleetSpec:
    """A fleet YAML, or a glob/folder of units (then ``scenario`` gives the twin).

    Parameters
    ----------
    spec : str or Path
        A fleet YAML, or a glob / folder of unit logs.
    scenario : str or Path, optional
        The twin's scenario (overrides the file's; required for compare with a glob).
    command : {"compare", "calibrate"}, optional
        Overrides the file's command (default: compare).

    Returns
    -------
    FleetSpec
        The resolved fleet (scenario path made absolute).

    Raises
    ------
    FleetError
        One line naming the file and key: unknown keys (with "did you mean"), a command other than
        compare or calibrate, no units, a compare without a scenario.
    """
    path = Path(spec)
    if path.suffix in (".yaml", ".yml") and not path.is_file() and not any(c in str(spec) for c in "*?["):
        raise FleetError(f"{path}: fleet file not found")
    if path.is_file() and path.suffix in (".yaml", ".yml"):
        from twin.io import read_text

        text = read_text(path, "fleet file", FleetError)
        data, lines = load_yaml_mapping(text, str(path), "a fleet file is a YAML mapping")
        where = lambda key: f"{path}:{lines.get((key,), 1)}"  # noqa: E731
        for key in data:
            if key not in TOP_KEYS:
                raise FleetError(f"{where(key)}: unknown key {key!r}{did_you_mean(key, TOP_KEYS, label='valid keys')}")
        base = path.parent
        cmd = command or data.get("command", "compare")
        if scenario is None and not isinstance(data.get("scenario", ""), (str, type(None))):
            raise FleetError(f"{where('scenario')}: scenario: expected the path of the twin's scenario file, "
                             f"got {data['scenario']!r}")
        scn = scenario if scenario is not None else (str(base / data["scenario"]) if data.get("scenario") else None)
        if "units" not in data:
            raise FleetError(f"{path}: missing key 'units' (a glob, a folder, or unit id → files)")
        units = discover_units(data["units"], base, where("units"))
        columns, options = data.get("columns") or {}, data.get("options") or {}
        name, source = str(data.get("name", path.stem)), str(path)
        threshold = data.get("outlier_threshold", 3.5)
        if isinstance(threshold, bool) or not isinstance(threshold, (int, float)) or not 0 < threshold < math.inf:
            raise FleetError(f"{where('outlier_threshold')}: outlier_threshold: got {threshold!r}, expected a finite "
                             "number > 0 (a robust z, e.g. 3.5)")
    else:
        where = lambda key: str(spec)  # noqa: E731
        cmd, scn, columns, options, name, source, threshold = command or "compare", scenario, {}, {}, "", str(spec), 3.5
        units = discover_units(str(spec), Path("."), str(spec))
    if cmd not in COMMANDS:
        raise FleetError(f"{where('command')}: command must be compare or calibrate, got {cmd!r}")
    if not isinstance(columns, dict):
        raise FleetError(f"{where('columns')}: columns is a mapping of column-map keys (time, temperature, output, ...)")
    _check_columns(columns, where("columns"))
    if not isinstance(options, dict):
        raise FleetError(f"{where('options')}: options is a mapping")
    for key, value in options.items():
        if key not in OPTIONS[cmd]:
            raise FleetError(f"{where('options')}: unknown {cmd} option {key!r}"
                             f"{did_you_mean(key, OPTIONS[cmd], label='valid options')}")
        if isinstance(value, bool) and OPTIONS[cmd][key] is not bool or not isinstance(value, OPTIONS[cmd][key]):
            raise FleetError(f"{where('options')}: options.{key}: wrong type {type(value).__name__}")
    _check_option_values(options, where("options"))
    if cmd == "compare":
        if scn is None:
            raise FleetError(f"{where('scenario')}: compare needs the twin's scenario (key 'scenario' or --scenario)")
        if not Path(scn).is_file():
            raise FleetError(f"{where('scenario')}: scenario file {scn} not found")
        scn = str(Path(scn).resolve())
        _check_twin(scn, options.get("with_effects", []), where("options"))
    return FleetSpec(units, cmd, scn, columns, options, name, source, float(threshold))


def _check_columns(columns: dict, where: str) -> None:
    from twin.measurement import ColumnMap

    known = set(ColumnMap.__dataclass_fields__)
    for key in columns:
        if key not in known:
            raise FleetError(f"{where}: unknown column-map key {key!r}{did_you_mean(key, known, label='valid keys')}")
    try:  # every value checked once here, not failed identically by every unit
        ColumnMap(**columns).validate(f"{where}: columns")
    except TwinError as exc:
        raise FleetError(str(exc)) from None


def _check_option_values(options: dict, where: str) -> None:
    """The ranges of the options' values (their types are checked against :data:`OPTIONS`)."""
    average = options.get("average_s", 10.0)
    if not 0.1 <= average <= 1e7:
        raise FleetError(f"{where}: options.average_s: got {average!r}, expected a block average in 0.1..1e7 s")
    applied = options.get("applied_g", 1.0)
    if isinstance(applied, str) and applied != "unknown" or not isinstance(applied, str) and not math.isfinite(applied):
        raise FleetError(f"{where}: options.applied_g: got {applied!r}, expected a finite number in g or 'unknown'")
    if not all(isinstance(e, str) for e in options.get("with_effects", [])):
        raise FleetError(f"{where}: options.with_effects: expected a list of effect names, got {options['with_effects']!r}")
    imu = options.get("imu", "all")
    if isinstance(imu, str) and imu != "all" or isinstance(imu, int) and not 0 <= imu < 256:
        raise FleetError(f"{where}: options.imu: got {imu!r}, expected 'all' or an IMU instance 0..255")


def _check_twin(scenario: str, with_effects: list, where: str) -> None:
    """The twin's scenario loads (its plugins too) and every added effect exists: one line now,
    instead of the same error recorded by every unit."""
    from twin.effects import REGISTRY
    from twin.model.scenario import load_scenario

    load_scenario(Path(scenario))
    for name in with_effects:
        if name not in REGISTRY:
            raise FleetError(f"{where}: options.with_effects: unknown effect {name!r}"
                             f"{did_you_mean(name, REGISTRY, label='registered effects')}")
