"""Sensor part sets: every datasheet figure of a part as data, with its unit, source and whether
it was read in the datasheet (the way PyBaMM ships parameter sets and pvlib its
``TEMPERATURE_MODEL_PARAMETERS``).

One YAML file per part in this folder (``iis328dq.yaml``, ``generic.yaml``); a user part is a
YAML file of the same format named in a scenario (``device.sensor.part: my_part.yaml``, relative
to the scenario). A part file::

    name: IIS328DQ
    description: ...
    datasheet: ST DS10757 Rev 4
    figures:
      noise_density_ug_per_sqrt_hz:
        value: 218
        unit: µg/√Hz
        source: datasheet Table 2 p.4
        verified: true          # false: recalled or typical, not read in a source
        note: ...               # optional

The figures a part may hold are :data:`FIGURES`; tables are keyed by the scenario's choice
(``sensitivity_mg_per_digit`` by ``full_scale_g``, ``lowpass_hz`` by ``odr_hz``). The ``generic``
part has no figures: the scenario gives them all. :func:`accelerometer_figures` combines a part
with the scenario's choices and overrides into the keywords of ``sim.sensor.AccelerometerConfig``.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from twin.errors import ScenarioError
from twin.io import read_text
from twin.text import did_you_mean, format_path, load_yaml_mapping, where

HERE = Path(__file__).resolve().parent
DEFAULT_PART = "IIS328DQ"  # the part of a scenario that names none, and of the paper's figures


class PartError(ScenarioError):
    """A part file or a part/scenario combination that cannot be used; ``key`` names the figure
    or scenario key at fault (for the caller to locate it)."""

    def __init__(self, message: str, key: str | None = None):
        super().__init__(message)
        self.key = key


@dataclass(frozen=True)
class FigureSpec:
    """What a figure of a part file must look like."""

    unit: str
    kind: str  # "number" (≥ 0), "positive", "bits", "table" (choice → positive number), "range" ([low, high])
    meaning: str
    per: str | None = None  # tables: the scenario key that selects a row
    spellings: tuple[str, ...] = ()  # other accepted spellings of the unit


FIGURES: dict[str, FigureSpec] = {
    "sensitivity_mg_per_digit": FigureSpec("mg/digit", "table", "one output digit at each full scale [±g]",
                                           per="full_scale_g", spellings=("mg/LSB", "mg/LSb")),
    "resolution_bits": FigureSpec("bit", "bits", "output data bits, left-justified in the 16-bit register",
                                  spellings=("bits",)),
    "lowpass_hz": FigureSpec("Hz", "table", "digital low-pass cut-off at each output data rate [Hz] "
                             "(taken as the white-noise bandwidth)", per="odr_hz"),
    "noise_density_ug_per_sqrt_hz": FigureSpec("µg/√Hz", "number", "acceleration noise density",
                                               spellings=("ug/sqrt(Hz)", "ug/√Hz", "µg/sqrt(Hz)")),
    "bias_instability_mg": FigureSpec("mg", "number", "stationary σ of a first-order Gauss–Markov bias"),
    "bias_instability_tau_s": FigureSpec("s", "positive", "correlation time of that bias"),
    "zero_g_offset_accuracy_mg": FigureSpec("mg", "number", "zero-g offset accuracy (±, a spread over parts)"),
    "tcoff_mg_per_c": FigureSpec("mg/°C", "number", "zero-g level change vs temperature (±)",
                                 spellings=("mg/degC", "mg/C")),
    "tcso_pct_per_c": FigureSpec("%/°C", "number", "sensitivity change vs temperature (±)",
                                 spellings=("%/degC", "%/C")),
    "operating_temperature_c": FigureSpec("°C", "range", "operating temperature range",
                                          spellings=("degC", "C")),
}

# The figures sim.sensor.AccelerometerConfig needs; a scenario may override each (a table with
# one number, the value at its choice).
SIMULATION_FIGURES = ("sensitivity_mg_per_digit", "resolution_bits", "lowpass_hz", "noise_density_ug_per_sqrt_hz",
                      "bias_instability_mg", "bias_instability_tau_s")
CHOICES = {"full_scale_g": "sensitivity_mg_per_digit", "odr_hz": "lowpass_hz"}  # choice → table keyed by it

_TOP_KEYS = ("name", "description", "datasheet", "figures")
_FIGURE_KEYS = ("value", "unit", "source", "verified", "note")


@dataclass(frozen=True)
class Figure:
    """One datasheet figure: a number, a table (choice → number) or a range ``(low, high)``."""

    value: Any
    unit: str
    source: str
    verified: bool
    note: str = ""


@dataclass(frozen=True)
class Part:
    """A sensor part: its figures by name (see :data:`FIGURES`)."""

    name: str
    description: str
    figures: dict[str, Figure] = field(default_factory=dict)
    datasheet: str = ""
    path: str = ""

    def value(self, name: str) -> Any:
        """The value of figure ``name`` (KeyError naming the part if it has none)."""
        if name not in self.figures:
            raise KeyError(f"part {self.name!r} has no figure {name!r}")
        return self.figures[name].value

    def choices(self, key: str) -> list[float] | None:
        """The allowed values of a scenario choice (``full_scale_g``, ``odr_hz``), or None if free."""
        table = self.figures.get(CHOICES[key])
        return sorted(table.value) if table is not None else None

    def lowest(self, name: str) -> float:
        """A figure's value, or for a table its value at the lowest choice (e.g. the lowest full scale)."""
        value = self.value(name)
        return value[min(value)] if isinstance(value, dict) else value

    def tempco_text(self, acceleration_g: float) -> str:
        """The part's datasheet TCOff and TCSo, the latter in mg/°C at ``acceleration_g`` (for scale)."""
        if not {"tcoff_mg_per_c", "tcso_pct_per_c"} <= set(self.figures):
            return f"part {self.name!r} gives no datasheet TCOff/TCSo"
        tcoff, tcso = self.value("tcoff_mg_per_c"), self.value("tcso_pct_per_c")
        return (f"{self.name} datasheet TCOff {tcoff:g} mg/°C, TCSo {tcso:g} %/°C = {tcso * 10 * acceleration_g:g} mg/°C "
                f"at this input")

    def describe(self) -> dict:
        """JSON-ready description (``twin parts --json``)."""
        def plain(v):
            if isinstance(v, dict):
                return {f"{k:g}": x for k, x in v.items()}
            return list(v) if isinstance(v, tuple) else v

        return {"name": self.name, "description": self.description, "datasheet": self.datasheet, "file": self.path,
                "figures": [{"name": n, "value": plain(f.value), "unit": f.unit, "source": f.source,
                             "verified": f.verified, "note": f.note, "meaning": FIGURES[n].meaning}
                            for n, f in self.figures.items()]}


def _is_number(v: Any) -> bool:
    return isinstance(v, (int, float)) and not isinstance(v, bool)


def _check_value(spec: FigureSpec, v: Any) -> tuple[Any, str | None]:
    """(value in its stored form, None) or (None, what was expected)."""
    if spec.kind in ("number", "positive"):
        ok = _is_number(v) and (v > 0 if spec.kind == "positive" else v >= 0)
        return (float(v), None) if ok else (None, "a number" + (" > 0" if spec.kind == "positive" else " >= 0"))
    if spec.kind == "bits":
        ok = isinstance(v, int) and not isinstance(v, bool) and 2 <= v <= 16
        return (v, None) if ok else (None, "a whole number of bits in 2..16")
    if spec.kind == "table":
        ok = isinstance(v, dict) and v and all(_is_number(k) and k > 0 and _is_number(x) and x > 0 for k, x in v.items())
        return ({k: float(x) for k, x in v.items()}, None) if ok else (None, f"a mapping {spec.per} → number > 0")
    ok = isinstance(v, list) and len(v) == 2 and all(_is_number(x) for x in v) and v[0] < v[1]
    return (tuple(float(x) for x in v), None) if ok else (None, "[low, high] with low < high")


def parse_part(data: dict, path: str, lines: dict[tuple, int] | None = None) -> Part:
    """Validate the mapping of a part file; :class:`PartError` naming the file, line and key."""
    lines = lines or {}

    def fail(loc: tuple, message: str) -> PartError:
        return PartError(f"{where(path, lines, loc)}: {message}", loc[-1] if loc else None)

    for key in data:
        if key not in _TOP_KEYS:
            raise fail((key,), f"unknown key {key!r} in a part file{did_you_mean(key, _TOP_KEYS, label='valid keys', sort=False)}")
    for key in ("name", "figures"):
        if key not in data:
            raise fail((), f"a part file needs {key!r}")
    if not isinstance(data["name"], str) or not data["name"]:
        raise fail(("name",), "name: a non-empty string")
    for key in ("description", "datasheet"):
        if not isinstance(data.get(key, ""), str):
            raise fail((key,), f"{key}: a string")
    figures_in = data["figures"] or {}
    if not isinstance(figures_in, dict):
        raise fail(("figures",), "figures: a mapping of figure name → {value, unit, source, verified}")
    figures: dict[str, Figure] = {}
    for name, entry in figures_in.items():
        loc = ("figures", name)
        if name not in FIGURES:
            raise fail(loc, f"figures: unknown figure {name!r}{did_you_mean(name, FIGURES)}")
        spec = FIGURES[name]
        if not isinstance(entry, dict):
            raise fail(loc, f"{format_path(loc)}: a mapping with value, unit, source, verified")
        for key in entry:
            if key not in _FIGURE_KEYS:
                raise fail(loc + (key,), f"{format_path(loc)}: unknown key {key!r}"
                                         f"{did_you_mean(key, _FIGURE_KEYS, label='valid keys', sort=False)}")
        for key in _FIGURE_KEYS[:4]:
            if key not in entry:
                raise fail(loc, f"{format_path(loc)}: missing {key!r} (every figure has value, unit, source, verified)")
        value, expected = _check_value(spec, entry["value"])
        if expected is not None:
            raise fail(loc + ("value",), f"{format_path(loc)}.value: expected {expected}, got {entry['value']!r}")
        if entry["unit"] != spec.unit and entry["unit"] not in spec.spellings:
            raise fail(loc + ("unit",), f"{format_path(loc)}.unit: {name} is in {spec.unit!r}, got {entry['unit']!r}")
        if not isinstance(entry["source"], str) or not entry["source"].strip():
            raise fail(loc + ("source",), f"{format_path(loc)}.source: say where the figure comes from")
        if not isinstance(entry["verified"], bool):
            raise fail(loc + ("verified",), f"{format_path(loc)}.verified: true (read in a source) or false "
                                            f"(recalled/typical), got {entry['verified']!r}")
        if not isinstance(entry.get("note", ""), str):
            raise fail(loc + ("note",), f"{format_path(loc)}.note: a string")
        figures[name] = Figure(value, spec.unit, entry["source"].strip(), entry["verified"], entry.get("note", ""))
    return Part(data["name"], data.get("description", ""), figures, data.get("datasheet", ""), path)


def read_part_file(path: str | Path) -> Part:
    """Load and validate one part YAML file."""
    p = Path(path)
    text = read_text(p, "part file", PartError)
    try:
        data, lines = load_yaml_mapping(text, str(p), "a part file is a YAML mapping with 'name' and 'figures'")
    except ScenarioError as exc:
        raise PartError(str(exc)) from None
    return parse_part(data, str(p), lines)


def _builtin() -> dict[str, Part]:
    """The parts shipped in this folder: named parts alphabetically, then ``generic``."""
    parts = [read_part_file(f) for f in HERE.glob("*.yaml")]
    parts = [dataclasses.replace(p, path=Path(p.path).relative_to(HERE.parents[1]).as_posix()) for p in parts]
    return {p.name: p for p in sorted(parts, key=lambda p: (p.name == "generic", p.name.casefold()))}


PARTS: dict[str, Part] = _builtin()


def is_path(spec: str) -> bool:
    """A part spec naming a file rather than a built-in part."""
    return spec.lower().endswith((".yaml", ".yml")) or "/" in spec or "\\" in spec


def load_part(name_or_path: str, base_dir: str | Path = ".") -> Part:
    """A built-in part by name (:data:`PARTS`), or a user part file (``.yaml``, relative to ``base_dir``)."""
    if is_path(name_or_path):
        p = Path(name_or_path)
        return read_part_file(p if p.is_absolute() else Path(base_dir) / p)
    if name_or_path in PARTS:
        return PARTS[name_or_path]
    same = [n for n in PARTS if n.casefold() == name_or_path.casefold()]
    hint = f"; did you mean {same[0]!r}?" if same else did_you_mean(name_or_path, PARTS, label="parts")
    raise PartError(f"unknown part {name_or_path!r}{hint} (or give a path to a part .yaml file)")


def design_figures(lsb_mg: float | None = None, tcoff_mg_per_c: float | None = None) -> tuple[float, float]:
    """The datasheet figures of the paper's test design (eqs. 33–34): one digit at the lowest full
    scale and TCOff of :data:`DEFAULT_PART`, unless given."""
    part = PARTS[DEFAULT_PART]
    return (part.lowest("sensitivity_mg_per_digit") if lsb_mg is None else lsb_mg,
            part.value("tcoff_mg_per_c") if tcoff_mg_per_c is None else tcoff_mg_per_c)


def table_lines(parts) -> list[str]:
    """The parts as text (``twin parts``): one line per figure with value, unit, verified flag, source."""
    def shown(v) -> str:
        if isinstance(v, dict):
            return ", ".join(f"{k:g}: {x:g}" for k, x in v.items())
        return f"{v[0]:g}..{v[1]:g}" if isinstance(v, tuple) else f"{v:g}"

    out = []
    for p in parts:
        out.append(f"{p.name}: {p.description}" + (f" ({p.datasheet})" if p.datasheet else ""))
        if not p.figures:
            out.append("  no figures of its own: the scenario's device.sensor gives them all")
        for name, f in p.figures.items():
            flag = "verified" if f.verified else "UNVERIFIED"
            out.append(f"  {name:<30} {shown(f.value):<36} {f.unit:<9} {flag:<10} {f.source}")
    return out


def _fmt(values) -> str:
    shown = [f"{v:g}" for v in values]
    return shown[0] if len(shown) == 1 else f"{', '.join(shown[:-1])} or {shown[-1]}"


def accelerometer_figures(part: Part, choices: dict[str, float | None], overrides: dict[str, Any]) -> dict[str, Any]:
    """The keywords of ``sim.sensor.AccelerometerConfig`` for ``part`` at the scenario's
    ``choices`` (``full_scale_g``, ``odr_hz``; None = the part's lowest), with the scenario's
    ``overrides`` of :data:`SIMULATION_FIGURES` (None = the part's figure).

    Raises :class:`PartError` with ``key`` set to the scenario key at fault: a choice not in the
    part's table, or figures that neither the part nor the scenario gives.
    """
    out: dict[str, Any] = {}
    missing: list[str] = []
    for key, table_name in CHOICES.items():
        allowed = part.choices(key)
        chosen = choices.get(key)
        if allowed is not None and chosen is not None and chosen not in allowed:
            raise PartError(f"{key} {chosen:g} is not a setting of part {part.name!r} (allowed: {_fmt(allowed)})", key)
        if chosen is None:
            if allowed is None:
                missing.append(key)
                continue
            chosen = allowed[0]
        out[key] = chosen
    for name in SIMULATION_FIGURES:
        if overrides.get(name) is not None:
            out[name] = overrides[name]
        elif name in part.figures:
            value = part.figures[name].value
            per = FIGURES[name].per
            if per is not None:
                if per not in out:
                    continue  # the choice itself is missing (reported above)
                value = value[out[per]]
            out[name] = value
        else:
            missing.append(name)
    if missing:
        raise PartError(f"part {part.name!r} has no {', '.join(missing)}: give "
                        f"{'it' if len(missing) == 1 else 'them'} in the scenario's device.sensor", missing[0])
    return out


__all__ = ["CHOICES", "DEFAULT_PART", "FIGURES", "PARTS", "SIMULATION_FIGURES", "Figure", "FigureSpec", "Part", "PartError",
           "accelerometer_figures", "design_figures", "is_path", "load_part", "parse_part", "read_part_file", "table_lines"]
