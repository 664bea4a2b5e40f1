"""Typed descriptions of the sensor parts (``twin parts --json``; see :mod:`twin.results`)."""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class FigureRecord:
    """One datasheet figure of a part as listed by ``twin parts``.

    Attributes
    ----------
    name : str
        Figure name (see :data:`twin.parts.FIGURES`).
    value : int or float or list of float or dict of str to float
        A number, a range ``[low, high]`` or a table (choice → number) [``unit``].
    unit : str
        Unit of the value.
    source : str
        Where the figure was read.
    verified : bool
        True when it was read in a source.
    note : str
        Free text.
    meaning : str
        What the figure is.
    """

    name: str
    value: int | float | list[float] | dict[str, float]
    unit: str
    source: str
    verified: bool
    note: str
    meaning: str


@dataclass(frozen=True)
class PartRecord:
    """One sensor part as listed by ``twin parts``.

    Attributes
    ----------
    name, description, datasheet : str
        Part name, one line about it, its datasheet reference.
    file : str
        The part file (relative to the repository for a built-in part).
    figures : list of FigureRecord
        Its figures.
    """

    name: str
    description: str
    datasheet: str
    file: str
    figures: list[FigureRecord]


@dataclass(frozen=True)
class PartsListing:
    """The sensor parts (``twin parts --json``).

    Attributes
    ----------
    parts : list of PartRecord
        Each part listed.
    """

    parts: list[PartRecord]
