"""The result of ``twin compare``, typed and built once: its JSON, schema and notebook display derive from the types.

:func:`twin.finding.build.compare_result` builds a :class:`CompareResult` (the finding worded once, there); the CLI, the
report, fleets, studies and notebooks (``_repr_html_``) read attributes; JSON and schema come via :mod:`twin.results`."""

from __future__ import annotations

from dataclasses import dataclass

from twin.diagnosis.axes import AppliedStretch
from twin.diagnosis.records import Alias, FamilyChoice, Untestable, Withheld
from twin.diagnosis.segments import ResidualSplit
from twin.diagnosis.structure import Structure
from twin.discovery.search import RunnerUp
from twin.finding.fragment import axes_html, compare_html, imu_html
from twin.measurement.quality_records import QualitySummary
from twin.results import to_json


@dataclass(frozen=True)
class ParameterEstimate:
    """One parameter of the calibrated twin.

    Attributes
    ----------
    value : float
        In ``unit``.
    unit : str
    role : str
        ``amplitude``, ``nonlinear`` or ``fixed``.
    free : bool
        Fitted to the data (else held at its scenario value).
    on_bound : bool
        Fitted and at a bound of its physical range.
    outside_physical_range : bool
        Outside its physical range (a scenario value, never a fit).
    ci95 : tuple of float, optional
        95 % interval, in ``unit``, when fitted.
    pinned : str, optional
        Why it was held at its default although free (aliased in this data).
    """

    value: float
    unit: str
    role: str
    free: bool
    on_bound: bool
    outside_physical_range: bool
    ci95: tuple[float, float] | None = None
    pinned: str | None = None


@dataclass(frozen=True)
class NuisanceEstimate:
    """A nuisance column's coefficient: a per-run offset [g] or a scale [1].

    Attributes
    ----------
    value : float
        Offset [g] or scale [1], in ``unit``.
    unit : str
    """

    value: float
    unit: str


@dataclass(frozen=True)
class Amplitude:
    """A candidate's fitted amplitude and the half-width of its 95 % interval, in its unit.

    Attributes
    ----------
    value, ci95_half_width : float
        Amplitude and 95 % half-width [the amplitude's unit].
    """

    value: float
    ci95_half_width: float


@dataclass(frozen=True)
class Candidate:
    """One screened effect on top of the calibrated twin.

    Attributes
    ----------
    effect, family : str
    significant : bool
        Passes p (Bonferroni) < 0.01, ΔBIC > 10 and held-out gain > 5 %.
    rms_residual_g : float
        Residual RMS with it added, at the sample rate [g].
    explained_fraction : float
        Share of the residual sum of squares it explains [1].
    delta_bic : float
        BIC improvement, prewhitened [1].
    p_adjusted : float
        F-test p-value times the number of tests [1].
    heldout_gain : float
        Relative fall of the held-out error [1].
    novelty : float
        Share of its column the calibrated model cannot absorb [1].
    parameters : dict of str to float
        Its best grid point, in each parameter's unit.
    amplitudes : dict of str to Amplitude
    parameters_refined : dict of str to float, optional
        The grid point refined between grid points (the first named effect).
    """

    effect: str
    family: str
    significant: bool
    rms_residual_g: float
    explained_fraction: float
    delta_bic: float
    p_adjusted: float
    heldout_gain: float
    novelty: float
    parameters: dict[str, float]
    amplitudes: dict[str, Amplitude]
    parameters_refined: dict[str, float] | None = None


@dataclass(frozen=True)
class NoiseModel:
    """The residual's noise model: AR order and the screening block [s].

    Attributes
    ----------
    ar_order : int
        Order p of the AR(p) prewhitening model (docs/diagnosis.md §1 step 3).
    average_s : float
        Block length of the screening means [s].
    """

    ar_order: int
    average_s: float


@dataclass(frozen=True)
class MeasurementInfo:
    """Where the measurement came from and what reading it dropped.

    Attributes
    ----------
    files : tuple of str
    bad_rows_skipped : int
    notes : tuple of str
        What the reader noticed (unit guesses, sorted times …).
    applied_known : bool
        The applied acceleration (orientation) was logged or given.
    diagnosed_on_means_of : int, optional
        Samples per row diagnosed, when a fast log was diagnosed on means.
    """

    files: tuple[str, ...]
    bad_rows_skipped: int
    notes: tuple[str, ...]
    applied_known: bool
    diagnosed_on_means_of: int | None = None


@dataclass(frozen=True)
class LookAlike:
    """A physical mechanism that makes the same residual signature.

    Attributes
    ----------
    name : str
    effect : str or None
        The library effect that models it (None: outside the library).
    in_library : bool
    reason : str
        Why it makes this signature.
    test : str
        What separates it from the others.
    """

    name: str
    effect: str | None
    in_library: bool
    reason: str
    test: str


@dataclass(frozen=True)
class Feature:
    """A discovered term's feature: its kind, parameters, printed form and unit.

    Attributes
    ----------
    kind : str
        Feature kind (``rate``, ``lag``, ``power`` …).
    params : dict of str to float
        Its parameters, in each one's unit (τ [s], threshold [°C] …).
    label, unit : str
        Printed form and the feature's unit.
    """

    kind: str
    params: dict[str, float]
    label: str
    unit: str


@dataclass(frozen=True)
class DiscoveredTerm:
    """One term of a discovery, its coefficient [mg per feature unit] with its 95 % half-width.

    Attributes
    ----------
    feature : Feature
    coefficient_mg, ci95_half_width_mg : float
        Coefficient and its 95 % half-width [mg per feature unit].
    delta_bic, p_adjusted : float
        BIC improvement and adjusted p-value of the term [1].
    """

    feature: Feature
    coefficient_mg: float
    ci95_half_width_mg: float
    delta_bic: float
    p_adjusted: float


@dataclass(frozen=True)
class DiscoverySummary:
    """What ``--discover`` found outside the library.

    Attributes
    ----------
    proposed : bool
    reason : str
    equation : str
        The proposed bias term, e.g. ``bias = +0.31 mg/(°C/min) · rate``.
    terms : tuple of DiscoveredTerm
    features_tried : int
    heldout_gain : float
        [1], on blocks the search did not see.
    delta_bic : float
    rms_before_g, rms_predicted_g : float
        Residual RMS before, and predicted with the terms [g].
    beaten : tuple of RunnerUp
    preferred_library : str or None
        A library effect that explains the structure as well.
    average_s : float
        Block length of the search [s].
    attribution : str, optional
        ``signature`` when a term is proposed.
    lookalikes : tuple of LookAlike, optional
    plugin : str, optional
        Where the term was written as an effect plugin.
    """

    proposed: bool
    reason: str
    equation: str
    terms: tuple[DiscoveredTerm, ...]
    features_tried: int
    heldout_gain: float
    delta_bic: float
    rms_before_g: float
    rms_predicted_g: float
    beaten: tuple[RunnerUp, ...]
    preferred_library: str | None
    average_s: float
    attribution: str | None = None
    lookalikes: tuple[LookAlike, ...] | None = None
    plugin: str | None = None


@dataclass(frozen=True)
class LedgerEntry:
    """One model's errors on the same data, from the ledger beside the report.

    Attributes
    ----------
    model : tuple of str
        The twin's effects.
    rms_residual_g, heldout_rms_g, noise_floor_g : float
        [g].
    delta_bic : float or None
        Against the previous entry (None: the first, or different blocks).
    """

    model: tuple[str, ...]
    rms_residual_g: float
    heldout_rms_g: float
    noise_floor_g: float
    delta_bic: float | None


@dataclass(frozen=True)
class CompareResult:
    """``twin compare`` of one axis: the calibrated twin, where it fails, and what is missing.

    Attributes
    ----------
    rms_residual_g : float
        Residual RMS of the calibrated twin at the sample rate [g].
    noise_floor_g : float
        White-noise floor of the residual from the data [g].
    noise_floor_model_g : float or None
        Per-sample σ of the scenario's sensor model [g].
    heldout_rms_g : float
        RMS of held-out errors on block means [g].
    effects : tuple of str
        The twin's effects.
    parameters : dict of str to dict of str to ParameterEstimate
        Effect → parameter → estimate.
    nuisance : dict of str to NuisanceEstimate
        Per-run offsets [g] and scales [1].
    missing_effect_detected : bool
    selected : tuple of str
        The effects named missing, in order.
    withheld, family_choices, aliases, untestable : tuple
        The selection's and the audit's records (:mod:`twin.diagnosis.records`).
    rivals : tuple of str
    confidence : str
        ``confident``, ``uncertain`` or ``none``.
    candidates : tuple of Candidate
        Every screened effect, best first.
    finding : str
        The finding in plain language.
    noise_model : NoiseModel
    residual : ResidualSplit
    samples : int
    sample_rate_hz : float
    runs : int
    measurement : MeasurementInfo
    rms_after_selected_g : float
        Residual RMS with the named effects added [g].
    structure : tuple of Structure
        Where the residual is not white noise.
    attribution : str, optional
        ``mechanism`` or ``signature`` (when an effect is named).
    lookalikes : tuple of LookAlike, optional
    discovery : DiscoverySummary, optional
    ledger : tuple of LedgerEntry, optional
        The errors of every model compared with this data, this one last.
    """

    rms_residual_g: float
    noise_floor_g: float
    noise_floor_model_g: float | None
    heldout_rms_g: float
    effects: tuple[str, ...]
    parameters: dict[str, dict[str, ParameterEstimate]]
    nuisance: dict[str, NuisanceEstimate]
    missing_effect_detected: bool
    selected: tuple[str, ...]
    withheld: tuple[Withheld, ...]
    rivals: tuple[str, ...]
    family_choices: tuple[FamilyChoice, ...]
    confidence: str
    candidates: tuple[Candidate, ...]
    aliases: tuple[Alias, ...]
    untestable: tuple[Untestable, ...]
    finding: str
    noise_model: NoiseModel
    residual: ResidualSplit
    samples: int
    sample_rate_hz: float
    runs: int
    measurement: MeasurementInfo
    rms_after_selected_g: float
    structure: tuple[Structure, ...]
    attribution: str | None = None
    lookalikes: tuple[LookAlike, ...] | None = None
    discovery: DiscoverySummary | None = None
    ledger: tuple[LedgerEntry, ...] | None = None
    _repr_html_ = compare_html  # a notebook shows the sentences and tables of twin.finding.fragment

    def candidate(self, effect: str) -> Candidate:
        """The screening result of ``effect`` (KeyError when it was not screened).

        Parameters
        ----------
        effect : str
            A screened effect's name.

        Returns
        -------
        Candidate
        """
        for c in self.candidates:
            if c.effect == effect:
                return c
        raise KeyError(effect)

    def to_json(self) -> dict:
        """The JSON of ``twin compare --json`` (see :mod:`twin.results`).

        Returns
        -------
        dict
        """
        return to_json(self)


@dataclass(frozen=True)
class ImuCompareResult:
    """``twin compare --axes`` of one IMU: each axis compared on its usable static rows.

    Attributes
    ----------
    instance : int
    device_id : int or None
    orientation_applied_g : dict of str to float or str
        Axis → g applied, ``unknown`` or ``per stretch``.
    orientation_per_stretch : dict of str to tuple of AppliedStretch
    log_quality : tuple of QualitySummary
        What each log lost before the comparison, and why.
    finding : str
        The IMU's joint finding (effects named on several axes, their τ).
    axes : dict of str to CompareResult
    """

    instance: int
    device_id: int | None
    orientation_applied_g: dict[str, float | str]
    orientation_per_stretch: dict[str, tuple[AppliedStretch, ...]]
    log_quality: tuple[QualitySummary, ...]
    finding: str
    axes: dict[str, CompareResult]
    _repr_html_ = imu_html


@dataclass(frozen=True)
class AxesCompareResult:
    """``twin compare --axes`` over every IMU asked for.

    Attributes
    ----------
    imus : tuple of ImuCompareResult
    finding : str
    """

    imus: tuple[ImuCompareResult, ...]
    finding: str
    _repr_html_ = axes_html

    def to_json(self) -> dict:
        """The JSON of ``twin compare --axes … --json``.

        Returns
        -------
        dict
        """
        return to_json(self)
