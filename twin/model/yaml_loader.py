"""Pydantic validation errors of a YAML file turned into one line naming the file, the YAML line,
the key path and what was expected (``file:line: key.path: ...``).

The YAML side (safe loading, the key → line map, key paths, "did you mean") is in
:mod:`twin.text`, shared with the part files and the study files.
"""

from __future__ import annotations

import re
import types
import typing
from typing import Annotated, Any, Union

from pydantic import BaseModel, ValidationError

from twin.text import did_you_mean, format_path, where


def _unwrap(annotation: Any) -> list[Any]:
    """The concrete types behind Optional/Union/Annotated/list/dict annotations."""
    origin = typing.get_origin(annotation)
    if origin is Annotated:
        return _unwrap(typing.get_args(annotation)[0])
    if origin in (Union, types.UnionType):
        return [t for a in typing.get_args(annotation) for t in _unwrap(a)]
    return [annotation]


def _model_at(root: type[BaseModel], loc: tuple) -> tuple[type[BaseModel] | None, tuple]:
    """Walk a pydantic error location from ``root``; return the model that holds its last key
    and the location with union tags removed (pydantic inserts the discriminator into ``loc``)."""
    current: list[Any] = [root]
    clean: list[Any] = []
    parent: type[BaseModel] | None = root
    for part in loc:
        models = [t for t in current if isinstance(t, type) and issubclass(t, BaseModel)]
        containers = [t for t in current if typing.get_origin(t) in (list, dict)]
        if current and not models and not containers and isinstance(part, str):
            continue  # a union member's tag under a scalar key (e.g. 'int' of ``int | float``)
        if isinstance(part, int) or (containers and not models):
            args = [a for t in containers for a in typing.get_args(t)]
            current = [t for a in args[-1:] for t in _unwrap(a)] if args else []
            clean.append(part)
            continue
        # A discriminator tag: pick the union member whose literal ``type`` equals it.
        tagged = [m for m in models if "type" in m.model_fields and part in typing.get_args(m.model_fields["type"].annotation)]
        if tagged and len(models) > 1:
            current = tagged
            continue
        model = models[0] if models else None
        parent = model
        clean.append(part)
        if model is not None and part in model.model_fields:
            current = _unwrap(model.model_fields[part].annotation)
        else:
            current = []
    return parent, tuple(clean)


_BOUNDS = ("greater_than", "greater_than_equal", "less_than", "less_than_equal")


def validation_message(err: ValidationError, root: type[BaseModel], path: str, lines: dict[tuple, int]) -> str:
    """One line for a pydantic error: ``file:line: key.path: what was expected``; an unknown key
    gets the closest valid one, an unknown step type the closest type.

    Parameters
    ----------
    err : ValidationError
        The pydantic error (its first error, misspelt keys first, is reported).
    root : type of BaseModel
        Model the document was validated against.
    path : str
        File name shown.
    lines : dict of tuple to int
        Line of each key path in the file.

    Returns
    -------
    str
        The message.
    """
    # A misspelt key shows as "unknown" and "missing" at once; the unknown one, with its
    # suggestion, is the message that helps.
    order = {"extra_forbidden": 0, "union_tag_invalid": 1}
    e = min(err.errors(include_url=False), key=lambda x: order.get(x["type"], 2))
    loc = tuple(e["loc"])
    parent, clean = _model_at(root, loc)
    key = format_path(clean)
    at = where(path, lines, clean)
    if e["type"] == "extra_forbidden":
        name = clean[-1]
        valid = list(parent.model_fields) if parent is not None else []
        hint = did_you_mean(name, valid, label="valid keys", sort=False)
        return f"{at}: unknown key {name!r} at {format_path(clean[:-1])}{hint}"
    if e["type"] == "union_tag_invalid":
        tags, tag = e["ctx"]["expected_tags"], e["ctx"]["tag"]
        options = [t.strip(" '") for t in tags.split(",")]
        hint = did_you_mean(tag, options, label=None)
        return f"{at}: {key}.type: unknown step type {tag!r} (expected {tags}){hint}"
    if e["type"] == "missing":
        return f"{at}: missing required key {key!r}"
    msg = e["msg"]
    if e["type"] in _BOUNDS and parent is not None and clean and clean[-1] in parent.model_fields:
        unit = re.search(r"\[([^\]]+)\]\s*$", parent.model_fields[clean[-1]].description or "")
        msg += f" {unit.group(1)}" if unit else ""  # the bound with its unit: "<= 300 °C"
    got = e.get("input")
    shown = "" if isinstance(got, (dict, list)) else f" (got {got!r})"
    return f"{at}: {key}: {msg}{shown}"
