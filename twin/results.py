"""Typed results: frozen dataclasses whose JSON and JSON Schema both derive from the types.

A result is built once, as a tree of frozen dataclasses; :func:`to_json` writes it field for field
(the field names are the JSON keys), and :func:`json_schema` derives the schema from the same type
annotations, so the schema shipped with ``twin schema`` cannot drift from what the commands write.

Two conventions keep the JSON what readers expect:

- a field whose default is ``None`` is an optional key, left out while ``None``; a field without a
  default is always written (``null`` when it is ``None``);
- a float that is not finite is written as ``null`` (JSON has no NaN), so every ``number`` in the
  schema also admits ``null``.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Iterable, Mapping
from dataclasses import dataclass
from functools import lru_cache
from typing import Generic, TypeVar

T = TypeVar("T")


@dataclass(frozen=True)
class PerAxis(Generic[T]):
    """One figure per sensor axis, written as ``{"x": …, "y": …, "z": …}``.

    Attributes
    ----------
    x, y, z : T
        The figure of each axis, in the unit the field holding the record names.
    """

    x: T
    y: T
    z: T

    @classmethod
    def of(cls, values: Iterable[T]) -> PerAxis[T]:
        """The record of three values in axis order x, y, z.

        Parameters
        ----------
        values : iterable of three values

        Returns
        -------
        PerAxis
        """
        x, y, z = values
        return cls(x, y, z)


def to_json(value):
    """``value`` as plain JSON data.

    Parameters
    ----------
    value : dataclass instance, mapping, sequence, NumPy value or scalar

    Returns
    -------
    dict, list, str, int, float, bool or None
        Dataclasses as objects keyed by field name (optional ``None`` fields left out), tuples and
        arrays as lists, non-finite floats as None.
    """
    import numpy as np

    if dataclasses.is_dataclass(value) and not isinstance(value, type):
        out = {}
        for f in dataclasses.fields(value):
            v = getattr(value, f.name)
            if v is None and f.default is None:
                continue
            out[f.name] = to_json(v)
        return out
    if isinstance(value, Mapping):
        return {str(k): to_json(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [to_json(v) for v in value]
    if isinstance(value, np.ndarray):
        return to_json(value.tolist())
    if isinstance(value, (bool, np.bool_)):
        return bool(value)
    if isinstance(value, (int, np.integer)):
        return int(value)
    if isinstance(value, (float, np.floating)):
        return float(value) if math.isfinite(value) else None
    return value


def _nullable_numbers(node):
    """Every ``number`` admits ``null`` (a NaN is written as null)."""
    if isinstance(node, dict):
        out = {k: _nullable_numbers(v) for k, v in node.items()}
        if out.get("type") == "number":
            del out["type"]
            out = {"anyOf": [{"type": "number"}, {"type": "null"}], **out}
        return out
    if isinstance(node, list):
        return [_nullable_numbers(v) for v in node]
    return node


@lru_cache(maxsize=None)
def _schema(cls: type) -> dict:
    from pydantic import TypeAdapter

    return _nullable_numbers(TypeAdapter(cls).json_schema(mode="serialization"))


def json_schema(cls: type) -> dict:
    """The JSON Schema (draft 2020-12) of ``cls``'s JSON, derived from its type annotations.

    Parameters
    ----------
    cls : type
        A result dataclass.

    Returns
    -------
    dict
    """
    import copy

    schema = copy.deepcopy(_schema(cls))
    schema["$schema"] = "https://json-schema.org/draft/2020-12/schema"
    return schema
