"""Effect abstraction and registry.

An effect is a named piece of drift physics with physical parameters (unit, default, bounds,
source). It reads named inputs (die temperature, time, applied acceleration …) and contributes
to the bias [g] and/or the relative scale factor [1]. The model sums contributions; every slot is
filled, "absent" being the explicit ``null`` effect (architecture principles 1–4).
"""

from __future__ import annotations

import difflib
from dataclasses import dataclass, field
from typing import ClassVar

import numpy as np

from twin.errors import ModelError


@dataclass(frozen=True)
class Parameter:
    """A physical parameter: unit, default, bounds (the calibrator's box) and where it comes from."""

    name: str
    unit: str
    default: float
    bounds: tuple[float, float]
    source: str
    description: str = ""


@dataclass
class EffectInputs:
    """Named, unit-bearing inputs an effect may read (all arrays on one time base)."""

    time_s: np.ndarray
    die_c: np.ndarray
    thermometer_c: np.ndarray
    applied_g: np.ndarray
    run_index: np.ndarray
    time_since_power_on_s: np.ndarray


@dataclass
class Contribution:
    """Bias [g] and relative scale-factor change [1] of one effect."""

    bias_g: np.ndarray | float = 0.0
    scale_factor: np.ndarray | float = 0.0

    def output_g(self, applied_g: np.ndarray) -> np.ndarray:
        """Drift in the output [g]: bias + scale-factor change × applied acceleration."""
        return np.asarray(self.bias_g) + np.asarray(self.scale_factor) * np.asarray(applied_g)


class Effect:
    """Base class. Subclasses set ``name``, ``family``, ``parameters``, ``reads`` and
    implement :meth:`contribution`."""

    name: ClassVar[str]
    family: ClassVar[str]
    parameters: ClassVar[tuple[Parameter, ...]] = ()
    reads: ClassVar[tuple[str, ...]] = ()
    description: ClassVar[str] = ""

    def __init__(self, **values: float) -> None:
        known = {p.name: p for p in self.parameters}
        for key in values:
            if key not in known:
                raise ModelError(f"effect {self.name!r} has no parameter {key!r}{_did_you_mean(key, known)}")
        self.values: dict[str, float] = {}
        for p in self.parameters:
            v = float(values.get(p.name, p.default))
            lo, hi = p.bounds
            if not lo <= v <= hi:
                raise ModelError(f"effect {self.name!r}: {p.name} = {v:g} {p.unit} is outside its bounds [{lo:g}, {hi:g}]")
            self.values[p.name] = v

    def contribution(self, inputs: EffectInputs) -> Contribution:  # pragma: no cover - abstract
        raise NotImplementedError

    @classmethod
    def describe(cls) -> dict:
        """Registry entry as plain data (for ``twin effects`` and the docs)."""
        return {
            "name": cls.name,
            "family": cls.family,
            "description": cls.description,
            "reads": list(cls.reads),
            "parameters": [
                {"name": p.name, "unit": p.unit, "default": p.default, "bounds": list(p.bounds), "source": p.source}
                for p in cls.parameters
            ],
        }


REGISTRY: dict[str, type[Effect]] = {}


def register(cls: type[Effect]) -> type[Effect]:
    """Class decorator: add an effect to the registry under its ``name``."""
    if cls.name in REGISTRY and REGISTRY[cls.name] is not cls:
        raise ModelError(f"an effect named {cls.name!r} is already registered")
    REGISTRY[cls.name] = cls
    return cls


def _did_you_mean(name: str, options) -> str:
    close = difflib.get_close_matches(name, list(options), n=1)
    return f"; did you mean {close[0]!r}?" if close else f"; valid: {', '.join(sorted(options))}"


def get_effect(name: str) -> type[Effect]:
    """The registered effect class called ``name``; unknown names get "did you mean"."""
    try:
        return REGISTRY[name]
    except KeyError:
        raise ModelError(f"unknown effect {name!r}{_did_you_mean(name, REGISTRY)}") from None


@dataclass
class Composition:
    """Effects summed into one drift; contributions kept per effect as ground truth."""

    effects: list[Effect] = field(default_factory=list)

    def evaluate(self, inputs: EffectInputs) -> dict[str, Contribution]:
        return {e.name: e.contribution(inputs) for e in self.effects}
