"""Typed registry entries of the effects (``twin effects --json``; see :mod:`twin.results`)."""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class ParameterRecord:
    """One parameter of an effect as listed by ``twin effects``.

    Attributes
    ----------
    name : str
        Parameter name.
    unit : str
        Its unit (e.g. ``"mg/degC"``).
    default : float
        Default value [unit].
    bounds : list of float
        (lower, upper): the calibrator's box [unit].
    role : str
        ``"amplitude"``, ``"nonlinear"`` or ``"fixed"``.
    free : bool
        Calibrated by default.
    source : str
        Where the default comes from.
    grid : list of float, optional
        Screening grid of a nonlinear parameter [unit]; left out when it has none.
    """

    name: str
    unit: str
    default: float
    bounds: list[float]
    role: str
    free: bool
    source: str
    grid: list[float] | None = None


@dataclass(frozen=True)
class EffectRecord:
    """One registered effect as listed by ``twin effects``.

    Attributes
    ----------
    name, family : str
        Effect name and family.
    slot : str
        ``"drift"`` or ``"temperature"``.
    description : str
        One line about the effect.
    reads : list of str
        The inputs it reads.
    identifiable : bool
        False when structurally unidentifiable from residuals.
    module : str
        The module defining it.
    parameters : list of ParameterRecord
        Its parameters, in declaration order.
    """

    name: str
    family: str
    slot: str
    description: str
    reads: list[str]
    identifiable: bool
    module: str
    parameters: list[ParameterRecord]


@dataclass(frozen=True)
class EffectsListing:
    """The registered effects (``twin effects --json``).

    Attributes
    ----------
    effects : list of EffectRecord
        Each effect, by family then name.
    """

    effects: list[EffectRecord]
