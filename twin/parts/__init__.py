"""Sensor part sets: every datasheet figure of a part as data, with its unit, source and whether
it was read in the datasheet (the way PyBaMM ships parameter sets and pvlib its
``TEMPERATURE_MODEL_PARAMETERS``).

One YAML file per part in this folder (``iis328dq.yaml``, ``generic.yaml``); a user part is a
YAML file of the same format named in a scenario (``device.sensor.part: my_part.yaml``, relative
to the scenario). The format, the figures a part may hold (:data:`FIGURES`) and its checks are in
:mod:`twin.parts.part_file`. The ``generic`` part has no figures: the scenario gives them all.
:func:`accelerometer_figures` combines a part with the scenario's choices and overrides into the
keywords of ``sim.sensor.AccelerometerConfig``.
"""

from __future__ import annotations

import dataclasses
from pathlib import Path
from typing import Any

from twin.parts.part_file import (
    CHOICES,
    FIGURES,
    Figure,
    FigureSpec,
    Part,
    PartError,
    parse_part,
    read_part_file,
)
from twin.text import did_you_mean

HERE = Path(__file__).resolve().parent
DEFAULT_PART = "IIS328DQ"  # the part of a scenario that names none, and of the paper's figures

# The figures sim.sensor.AccelerometerConfig needs; a scenario may override each (a table with
# one number, the value at its choice).
SIMULATION_FIGURES = ("sensitivity_mg_per_digit", "resolution_bits", "lowpass_hz", "noise_density_ug_per_sqrt_hz",
                      "bias_instability_mg", "bias_instability_tau_s")


def _builtin() -> dict[str, Part]:
    """The parts shipped in this folder: named parts alphabetically, then ``generic``."""
    parts = [read_part_file(f) for f in HERE.glob("*.yaml")]
    parts = [dataclasses.replace(p, path=Path(p.path).relative_to(HERE.parents[1]).as_posix()) for p in parts]
    return {p.name: p for p in sorted(parts, key=lambda p: (p.name == "generic", p.name.casefold()))}


PARTS: dict[str, Part] = _builtin()


def is_path(spec: str) -> bool:
    """A part spec naming a file rather than a built-in part.

    Parameters
    ----------
    spec : str
        A part name or a file.

    Returns
    -------
    bool
        True for a ``.yaml``/``.yml`` name or one with a path separator.
    """
    return spec.lower().endswith((".yaml", ".yml")) or "/" in spec or "\\" in spec


def load_part(name_or_path: str, base_dir: str | Path = ".") -> Part:
    """A built-in part by name (:data:`PARTS`), or a user part file (``.yaml``, relative to ``base_dir``).

    Parameters
    ----------
    name_or_path : str
        Part name or file.
    base_dir : str or Path
        Directory a relative file is taken from (the scenario's).

    Returns
    -------
    Part
        The part.
    """
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
    scale and TCOff of :data:`DEFAULT_PART`, unless given.

    Parameters
    ----------
    lsb_mg : float, optional
        One output digit [mg].
    tcoff_mg_per_c : float, optional
        Zero-g offset tempco TCOff [mg/°C].

    Returns
    -------
    tuple of float
        (LSB [mg], TCOff [mg/°C]).
    """
    part = PARTS[DEFAULT_PART]
    return (part.lowest("sensitivity_mg_per_digit") if lsb_mg is None else lsb_mg,
            part.value("tcoff_mg_per_c") if tcoff_mg_per_c is None else tcoff_mg_per_c)


def table_lines(parts) -> list[str]:
    """The parts as text (``twin parts``): one line per figure with value, unit, verified flag, source.

    Parameters
    ----------
    parts : iterable of Part
        The parts to list.

    Returns
    -------
    list of str
        A heading line per part, then one line per figure [its unit].
    """
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

    Parameters
    ----------
    part : Part
        The sensor part.
    choices : dict
        ``full_scale_g`` [g] and ``odr_hz`` [Hz], None for the part's lowest.
    overrides : dict
        Scenario values of :data:`SIMULATION_FIGURES` [their units], None for the part's.

    Returns
    -------
    dict
        Full scale [g], ODR [Hz] and the simulation figures [their units].

    Raises
    ------
    PartError
        With ``key`` set to the scenario key at fault: a choice not in the part's table, or
        figures that neither the part nor the scenario gives.
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
