"""The part file: the figures a part may hold (:data:`FIGURES`), the :class:`Part` they make, and
:func:`parse_part`, which checks a file's mapping and names the file, line and key of a fault.

A part file::

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

Tables are keyed by the scenario's choice (``sensitivity_mg_per_digit`` by ``full_scale_g``,
``lowpass_hz`` by ``odr_hz``: :data:`CHOICES`). The built-in parts and their combination with a
scenario are in :mod:`twin.parts`.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from twin.errors import ScenarioError
from twin.io import read_text
from twin.parts.records import FigureRecord, PartRecord
from twin.text import did_you_mean, format_path, load_yaml_mapping, where


class PartError(ScenarioError):
    """A part file or a part/scenario combination that cannot be used; ``key`` names the figure
    or scenario key at fault (for the caller to locate it).

    Parameters
    ----------
    message : str
        One line naming the file, line and key.
    key : str, optional
        The figure or scenario key at fault.
    """

    def __init__(self, message: str, key: str | None = None):
        super().__init__(message)
        self.key = key


@dataclass(frozen=True)
class FigureSpec:
    """What a figure of a part file must look like.

    Attributes
    ----------
    unit, meaning : str
        The figure's unit and what it is.
    kind : str
        "number" (≥ 0), "positive", "bits", "table" (choice → positive number), "range" ([low, high]).
    per : str or None
        Tables: the scenario key that selects a row.
    spellings : tuple of str
        Other accepted spellings of the unit.
    """

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

CHOICES = {"full_scale_g": "sensitivity_mg_per_digit", "odr_hz": "lowpass_hz"}  # choice → table keyed by it

_TOP_KEYS = ("name", "description", "datasheet", "figures")
_FIGURE_KEYS = ("value", "unit", "source", "verified", "note")


@dataclass(frozen=True)
class Figure:
    """One datasheet figure: a number, a table (choice → number) or a range ``(low, high)``.

    Attributes
    ----------
    value : float or dict or tuple
        The figure [``unit``].
    unit, source, note : str
        Its unit, where it comes from, a remark.
    verified : bool
        Read in a source (True) or recalled/typical (False).
    """

    value: Any
    unit: str
    source: str
    verified: bool
    note: str = ""


@dataclass(frozen=True)
class Part:
    """A sensor part: its figures by name (see :data:`FIGURES`).

    Attributes
    ----------
    name, description, datasheet : str
        Part name, one line about it, its datasheet reference.
    figures : dict of str to Figure
        Figures by name.
    path : str
        The part file (relative to the repository for a built-in part).
    """

    name: str
    description: str
    figures: dict[str, Figure] = field(default_factory=dict)
    datasheet: str = ""
    path: str = ""

    def value(self, name: str) -> Any:
        """The value of figure ``name`` (KeyError naming the part if it has none).

        Parameters
        ----------
        name : str
            A key of :data:`FIGURES`.

        Returns
        -------
        float or dict or tuple
            The value [the figure's unit].
        """
        if name not in self.figures:
            raise KeyError(f"part {self.name!r} has no figure {name!r}")
        return self.figures[name].value

    def choices(self, key: str) -> list[float] | None:
        """The allowed values of a scenario choice (``full_scale_g``, ``odr_hz``), or None if free.

        Parameters
        ----------
        key : str
            A key of :data:`CHOICES`.

        Returns
        -------
        list of float or None
            The keys of the part's table for that choice, ascending [g or Hz]; None when the
            part has no such table (the scenario chooses freely).
        """
        table = self.figures.get(CHOICES[key])
        return sorted(table.value) if table is not None else None

    def lowest(self, name: str) -> float:
        """A figure's value, or for a table its value at the lowest choice (e.g. the lowest full scale).

        Parameters
        ----------
        name : str
            A key of :data:`FIGURES`.

        Returns
        -------
        float or tuple
            The value [the figure's unit].
        """
        value = self.value(name)
        return value[min(value)] if isinstance(value, dict) else value

    def tempco_text(self, acceleration_g: float) -> str:
        """The part's datasheet TCOff and TCSo, the latter in mg/°C at ``acceleration_g`` (for scale).

        Parameters
        ----------
        acceleration_g : float
            Input acceleration at which TCSo [%/°C] is given in mg/°C [g].

        Returns
        -------
        str
            One line with TCOff [mg/°C] and TCSo [%/°C and mg/°C], or why there is none.
        """
        if not {"tcoff_mg_per_c", "tcso_pct_per_c"} <= set(self.figures):
            return f"part {self.name!r} gives no datasheet TCOff/TCSo"
        tcoff, tcso = self.value("tcoff_mg_per_c"), self.value("tcso_pct_per_c")
        return (f"{self.name} datasheet TCOff {tcoff:g} mg/°C, TCSo {tcso:g} %/°C = {tcso * 10 * acceleration_g:g} mg/°C "
                f"at this input")

    def describe(self) -> PartRecord:
        """Typed description (``twin parts --json``).

        Returns
        -------
        PartRecord
            Name, description, datasheet, file, and each figure's name, value [its unit], unit,
            source, verified flag, note and meaning.
        """
        def plain(v):
            if isinstance(v, dict):
                return {f"{k:g}": x for k, x in v.items()}
            return list(v) if isinstance(v, tuple) else v

        return PartRecord(name=self.name, description=self.description, datasheet=self.datasheet, file=self.path,
                          figures=[FigureRecord(name=n, value=plain(f.value), unit=f.unit, source=f.source,
                                                verified=f.verified, note=f.note, meaning=FIGURES[n].meaning)
                                   for n, f in self.figures.items()])


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
    """Validate the mapping of a part file; :class:`PartError` naming the file, line and key.

    Parameters
    ----------
    data : dict
        The parsed YAML mapping.
    path : str
        The file, for messages and ``Part.path``.
    lines : dict, optional
        Line of each key path in the file.

    Returns
    -------
    Part
        The part.
    """
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
    """Load and validate one part YAML file.

    Parameters
    ----------
    path : str or Path
        The file.

    Returns
    -------
    Part
        The part.
    """
    p = Path(path)
    text = read_text(p, "part file", PartError)
    try:
        data, lines = load_yaml_mapping(text, str(p), "a part file is a YAML mapping with 'name' and 'figures'")
    except ScenarioError as exc:
        raise PartError(str(exc)) from None
    return parse_part(data, str(p), lines)
