"""What a study's analysis holds, typed: ``analysis.json`` and ``twin doe --json``.

Frozen dataclasses written field for field by :func:`twin.results.to_json`; a response's figures
are in that response's unit (``docs/doe.md`` lists them; a plugin response declares its own).
"""

from __future__ import annotations

from dataclasses import dataclass

from twin.studies.fragment import doe_html


@dataclass(frozen=True)
class MainEffect:
    """One factor's main effect on one response.

    Attributes
    ----------
    means : dict of str to float
        Factor level (or, for a ranged factor with many values, quartile bin ``lo..hi``) → mean
        response of the successful runs at it, in the response's unit.
    effect : float
        Largest minus smallest of those means, in the response's unit.
    """

    means: dict[str, float]
    effect: float


@dataclass(frozen=True)
class SobolIndex:
    """One factor's Sobol indices for one response (Saltelli design), with bootstrap intervals.

    Attributes
    ----------
    S1 : float
        First-order index [1].
    S1_ci95 : tuple of float
        Its bootstrap 95 % interval [1].
    ST : float
        Total index [1].
    ST_ci95 : tuple of float
        Its bootstrap 95 % interval [1].
    """

    S1: float
    S1_ci95: tuple[float, float]
    ST: float
    ST_ci95: tuple[float, float]


@dataclass(frozen=True)
class StudyAnalysis:
    """A finished study's analysis (``analysis.json``).

    Attributes
    ----------
    runs : int
        Runs in the table (finished, failed ones included).
    failed : int
        Runs that failed.
    main_effects : dict of str to dict of str to MainEffect
        Factor → numeric response → its main effect.
    interactions : dict of str to dict of str to float
        ``"a × b"`` → numeric response → coefficient of the product term with both factors scaled
        to [−1, 1], in the response's unit.
    sobol : dict of str to dict of str to SobolIndex or None
        Response → factor → indices; None unless the design is a complete Saltelli design.
    """

    runs: int
    failed: int
    main_effects: dict[str, dict[str, MainEffect]]
    interactions: dict[str, dict[str, float]]
    sobol: dict[str, dict[str, SobolIndex]] | None


@dataclass(frozen=True)
class DoeResult:
    """``twin doe --json``: where the study went, how many runs it has, and its analysis.

    Attributes
    ----------
    output : str
        The output folder.
    runs : int
        Finished runs (failed ones included).
    planned : int
        Runs in the design (points × replicates).
    failed : int
        Runs that failed.
    main_effects, interactions, sobol
        As in :class:`StudyAnalysis`.
    """

    output: str
    runs: int
    planned: int
    failed: int
    main_effects: dict[str, dict[str, MainEffect]]
    interactions: dict[str, dict[str, float]]
    sobol: dict[str, dict[str, SobolIndex]] | None
    _repr_html_ = doe_html  # a notebook shows the sentences and tables of twin.studies.fragment
