"""What the audit and the selection record: typed, frozen, and the same in the compare JSON.

Each record is written to the JSON field for field (``twin.results.to_json``); a field whose
default is ``None`` is left out of the JSON while it is ``None``.
"""

from __future__ import annotations

from dataclasses import dataclass

#: the alias partner of a model amplitude the per-run offsets absorb (one offset per run)
PER_RUN_OFFSETS = "per-run offsets"


@dataclass(frozen=True)
class Untestable:
    """A candidate effect this data cannot test.

    Attributes
    ----------
    effect, family : str
        The effect and its family.
    reason : str
        Why: structurally unidentifiable, absorbed by the calibrated model (its novelty), or the
        orientation is not logged.
    remedy : str
        The test-plan change that would make it testable ('' when none is known).
    """

    effect: str
    family: str
    reason: str
    remedy: str


@dataclass(frozen=True)
class Alias:
    """Effects this data cannot tell apart, or an effect aliased with a model column.

    Attributes
    ----------
    effects, families : tuple of str
        The effects alike in shape (sorted) and their families.
    remedy : str
        What would separate them.
    aliased_with : str, optional
        The model column the effect is aliased with (a nuisance offset, another amplitude, or
        ``PER_RUN_OFFSETS``); absent for a group of candidates aliased with each other.
    """

    effects: tuple[str, ...]
    families: tuple[str, ...]
    remedy: str
    aliased_with: str | None = None

    @property
    def among_candidates(self) -> bool:
        """True for a group of candidates alike in shape (not a model column's alias)."""
        return self.aliased_with is None


@dataclass(frozen=True)
class ModelAliased:
    """A model amplitude this data cannot estimate.

    Attributes
    ----------
    effect, parameter : str
        The effect and its amplitude.
    novelty : float
        Share of its column [1] left after projecting out the others (0: fully absorbed).
    aliased_with : str
        The column closest to it.
    pinned : bool
        Held at its default during calibration (rather than fitted).
    """

    effect: str
    parameter: str
    novelty: float
    aliased_with: str
    pinned: bool = False

    @property
    def with_run_offsets(self) -> bool:
        """Aliased with a per-run offset (temperature confounded with the runs)."""
        return self.aliased_with.startswith("offset_run")


@dataclass(frozen=True)
class Withheld:
    """A significant candidate not named because another family's candidate ranks above it.

    Attributes
    ----------
    effect, family : str
        The withheld candidate.
    outranked_by, outranked_by_family : str
        The candidate ranked above it (not significant itself) and its family.
    delta_bic : tuple of float
        ΔBIC of the withheld candidate and of the one above it [1].
    """

    effect: str
    family: str
    outranked_by: str
    outranked_by_family: str
    delta_bic: tuple[float, float]


@dataclass(frozen=True)
class FamilyModel:
    """One candidate of a family calibrated whole, beside the named one.

    Attributes
    ----------
    effect : str
    free_parameters : int
        Parameters fitted (amplitudes and time constants).
    bic_minus_named : float
        Its BIC minus the named candidate's [1].
    rss_over_best : float
        Its prewhitened residual sum of squares over the family's lowest [1].
    """

    effect: str
    free_parameters: int
    bic_minus_named: float
    rss_over_best: float


@dataclass(frozen=True)
class FamilyChoice:
    """Why one effect of a family is named over the others, all calibrated whole.

    Attributes
    ----------
    family, named, first_by_screening : str
        The family, the candidate named and the one screening ranked first.
    reason : str
        ``fewest_parameters``, ``decisively_better`` or ``lowest_bic``.
    models : tuple of FamilyModel
        Each candidate's fit, the named one first.
    """

    family: str
    named: str
    first_by_screening: str
    reason: str
    models: tuple[FamilyModel, ...]


@dataclass(frozen=True)
class SeparatedAlias:
    """Candidates alike in shape with this test plan that the evidence nevertheless tells apart.

    Attributes
    ----------
    effects : tuple of str
        The alias group.
    named : str
        The effect named missing, and its ΔBIC ``named_delta_bic`` [1].
    partner : str
        The group's best effect of another family, and its ΔBIC ``partner_delta_bic`` [1].
    """

    effects: tuple[str, ...]
    named: str
    named_delta_bic: float
    partner: str
    partner_delta_bic: float
