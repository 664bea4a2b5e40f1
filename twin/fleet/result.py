"""What a fleet writes, typed: one unit's row (a line of ``units.jsonl``), the population view
(``population.json``) and the results of ``twin fleet`` and ``twin fleet-simulate``.

Every type is a frozen dataclass written field for field by :func:`twin.results.to_json` (a field
whose default is ``None`` is left out while ``None``; a number that is not finite is written as
``null``). A row is read back with :meth:`FleetRow.from_json`, so a fleet resumes from the lines a
killed run wrote, ``null`` numbers included.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Literal

from twin.diagnosis.records import Withheld
from twin.fleet.fragment import fleet_html

#: the ``kind`` of every line of ``units.jsonl``: a line without it is not a fleet's unit record
KIND = "twin-fleet-unit"


def _number(value) -> float:
    """A JSON number back as a float: ``null`` is what a NaN or an infinity was written as."""
    return math.nan if value is None else float(value)


@dataclass(frozen=True)
class ParameterValue:
    """One quantity of a unit: a fitted parameter, a named effect's refined parameter or amplitude,
    or (calibrate) a held-out error or noise floor.

    Attributes
    ----------
    value : float
        In ``unit``.
    unit : str
        Its unit (``mg``, ``s``, ``mg/degC`` …; ``""`` for a dimensionless one).
    ci95 : tuple of float or None
        95 % interval, in ``unit``; None when the fit gives none (a grid point, a calibrate figure).
    """

    value: float
    unit: str
    ci95: tuple[float, float] | None

    @classmethod
    def from_json(cls, data: dict) -> ParameterValue:
        """The value as :func:`twin.results.to_json` wrote it.

        Parameters
        ----------
        data : dict
            ``{"value", "unit", "ci95"}``.

        Returns
        -------
        ParameterValue
        """
        ci = data.get("ci95")
        return cls(_number(data["value"]), str(data.get("unit", "")),
                   None if ci is None else (_number(ci[0]), _number(ci[1])))


@dataclass(frozen=True)
class UnitReports:
    """Where a unit's own files are, relative to the fleet's output folder.

    Attributes
    ----------
    json : str
        ``units/<id>/compare.json`` (compare) or ``units/<id>/cal.json`` (calibrate).
    html : str, optional
        ``units/<id>/report.html``, written with the option ``report: true``.
    """

    json: str
    html: str | None = None


@dataclass(frozen=True, kw_only=True)
class FleetRow:
    """One unit's analysis, as appended to ``units.jsonl``: the ok fields are left out of a unit
    that failed, and ``error`` out of one that did not.

    Attributes
    ----------
    kind : str
        Always ``twin-fleet-unit`` (how a fleet's ledger line is told from another file's).
    unit : str
        The unit id (its folder ``units/<id>``).
    files : tuple of str
        Its log files (several are several runs).
    command : str
        ``compare`` or ``calibrate``.
    named : tuple of str, optional
        The effects named missing, in order (compare; empty for calibrate).
    families : tuple of str, optional
        The family of each named effect.
    confidence : str, optional
        ``confident``, ``uncertain`` or ``none`` (compare).
    detected : bool, optional
        A missing effect was detected (compare).
    withheld : tuple of Withheld, optional
        Significant candidates not named because another family's ranks above them.
    finding : str, optional
        The finding in plain language (calibrate: each IMU's recommended methods).
    recommended : dict of str to dict of str to str or None, optional
        Calibrate: IMU instance → target firmware → recommended method (None: flagged).
    parameters : dict of str to ParameterValue, optional
        ``effect.parameter`` (compare) or ``imu<n>.<figure>.<axis>`` (calibrate) → value, unit, 95 %.
    rms_residual_mg : float, optional
        Residual RMS of the calibrated twin at the sample rate [mg] (calibrate: the largest IMU's
        held-out RMS of its best method [mg]).
    noise_floor_mg : float, optional
        White-noise floor of the residual [mg] (compare).
    residual_over_floor : float, optional
        ``rms_residual_mg / noise_floor_mg`` [1]; 1 = nothing left but noise (compare, floor > 0).
    heldout_rms_mg : float, optional
        RMS of the held-out errors [mg].
    samples : int, optional
        Samples analysed [1].
    reports : UnitReports, optional
        The unit's own files.
    status : str
        ``ok`` or ``error``.
    error : str, optional
        Why the unit failed, in one line.
    seconds : float
        Wall time of the unit's analysis [s].
    """

    kind: Literal["twin-fleet-unit"] = KIND
    unit: str
    files: tuple[str, ...]
    command: str
    named: tuple[str, ...] | None = None
    families: tuple[str, ...] | None = None
    confidence: str | None = None
    detected: bool | None = None
    withheld: tuple[Withheld, ...] | None = None
    finding: str | None = None
    recommended: dict[str, dict[str, str | None]] | None = None
    parameters: dict[str, ParameterValue] | None = None
    rms_residual_mg: float | None = None
    noise_floor_mg: float | None = None
    residual_over_floor: float | None = None
    heldout_rms_mg: float | None = None
    samples: int | None = None
    reports: UnitReports | None = None
    status: Literal["ok", "error"]
    error: str | None = None
    seconds: float

    @property
    def ok(self) -> bool:
        """The unit was analysed (its status is ``ok``)."""
        return self.status == "ok"

    @property
    def report(self) -> str:
        """Its HTML report, else its JSON, else ``""`` (relative to the output folder)."""
        if self.reports is None:
            return ""
        return self.reports.html if self.reports.html is not None else self.reports.json

    @classmethod
    def from_json(cls, data: dict) -> FleetRow:
        """A row as a ledger line holds it (lines of older runs, with ``NaN`` tokens, included).

        Parameters
        ----------
        data : dict
            One parsed line of ``units.jsonl``.

        Returns
        -------
        FleetRow

        Raises
        ------
        KeyError, TypeError, ValueError
            The line is not a unit record of a fleet.
        """
        def strings(key):
            return None if data.get(key) is None else tuple(str(x) for x in data[key])

        def scalar(key):
            return None if data.get(key) is None else float(data[key])

        reports = data.get("reports")
        params = data.get("parameters")
        withheld = data.get("withheld")
        recommended = data.get("recommended")
        return cls(
            unit=str(data["unit"]), files=tuple(str(f) for f in data.get("files", ())),
            command=str(data.get("command", "compare")), named=strings("named"), families=strings("families"),
            confidence=data.get("confidence"), detected=data.get("detected"),
            withheld=None if withheld is None else tuple(
                Withheld(w["effect"], w["family"], w["outranked_by"], w["outranked_by_family"],
                         (_number(w["delta_bic"][0]), _number(w["delta_bic"][1]))) for w in withheld),
            finding=data.get("finding"),
            recommended=None if recommended is None else {str(k): dict(v) for k, v in recommended.items()},
            parameters=None if params is None else {k: ParameterValue.from_json(v) for k, v in params.items()},
            rms_residual_mg=scalar("rms_residual_mg"), noise_floor_mg=scalar("noise_floor_mg"),
            residual_over_floor=scalar("residual_over_floor"), heldout_rms_mg=scalar("heldout_rms_mg"),
            samples=None if data.get("samples") is None else int(data["samples"]),
            reports=None if reports is None else UnitReports(str(reports["json"]), reports.get("html")),
            status=data["status"], error=data.get("error"), seconds=_number(data.get("seconds")))


@dataclass(frozen=True)
class Prevalence:
    """How many analysed units name an effect (or a family).

    Attributes
    ----------
    units : int
        Units naming it.
    share : float
        Their share of the analysed units [1].
    ci95 : tuple of float
        Wilson 95 % interval of the share [1].
    """

    units: int
    share: float
    ci95: tuple[float, float]


@dataclass(frozen=True)
class NoneNamed:
    """The analysed units that name no effect: their count and share [1] (None: no unit analysed).

    Attributes
    ----------
    units : int
        Analysed units naming no effect.
    share : float or None
        Their share of the analysed units [1]; None when no unit was analysed.
    """

    units: int
    share: float | None


@dataclass(frozen=True)
class Distribution:
    """One quantity over the analysed units that have it.

    Attributes
    ----------
    units : int
        Units with a value.
    unit : str
        The unit of every figure below.
    median, mad, q05, q25, q75, q95, mean, std, min, max : float
        Median, median absolute deviation, quantiles (5 … 95 %), mean, standard deviation (ddof 1;
        0 for one unit), smallest and largest value, in ``unit``.
    """

    units: int
    unit: str
    median: float
    mad: float
    q05: float
    q25: float
    q75: float
    q95: float
    mean: float
    std: float
    min: float
    max: float


@dataclass(frozen=True)
class Outlier:
    """A unit whose value is far from those of the units of the same finding.

    Attributes
    ----------
    unit, quantity : str
        The unit and the quantity (a key of ``parameters`` or a row's scalar).
    group : str
        The finding it was judged among (the family named first, or ``none``).
    value : float
        In the quantity's unit.
    robust_z : float
        (x − median) / (1.4826 · MAD) among the group [1].
    """

    unit: str
    quantity: str
    group: str
    value: float
    robust_z: float


@dataclass(frozen=True)
class FailedUnit:
    """A unit that was not analysed, and why (one line).

    Attributes
    ----------
    unit : str
        The unit's id.
    error : str
        Why, in one line.
    """

    unit: str
    error: str


@dataclass(frozen=True)
class Population:
    """The population view of a fleet (``population.json``).

    Attributes
    ----------
    units, ok, errors : int
        Units with a row, analysed, failed.
    prevalence, prevalence_by_family, prevalence_primary_family : dict of str to Prevalence
        Per named effect; per family named; per family of the effect named first.
    none_named : NoneNamed
    confidence : dict of str to int
        Confidence label → analysed units with it.
    parameters : dict of str to Distribution
        Per quantity (fitted parameters and the rows' scalars).
    outlier_threshold : float
        |robust z| above which a unit is listed [1].
    outliers : tuple of Outlier
        Sorted by unit and quantity.
    failed : tuple of FailedUnit
    """

    units: int
    ok: int
    errors: int
    prevalence: dict[str, Prevalence]
    prevalence_by_family: dict[str, Prevalence]
    prevalence_primary_family: dict[str, Prevalence]
    none_named: NoneNamed
    confidence: dict[str, int]
    parameters: dict[str, Distribution]
    outlier_threshold: float
    outliers: tuple[Outlier, ...]
    failed: tuple[FailedUnit, ...]


@dataclass(frozen=True)
class FleetResult:
    """``twin fleet --json``: what the run did and the population view of every finished unit.

    Attributes
    ----------
    output : str
        The output folder.
    units : int
        Units in the fleet.
    ran, skipped : int
        Units analysed by this run; finished before it (their rows kept).
    notes : tuple of str
        What the run repaired (a torn ledger line, temporary files of a killed run).
    ok, errors : int
        Units analysed, failed.
    prevalence, prevalence_by_family, prevalence_primary_family, none_named, confidence, parameters
        As in :class:`Population`.
    outlier_threshold : float
        |robust z| above which a unit is listed [1].
    outliers : tuple of Outlier
    failed : tuple of FailedUnit
    """

    output: str
    units: int
    ran: int
    skipped: int
    notes: tuple[str, ...]
    ok: int
    errors: int
    prevalence: dict[str, Prevalence]
    prevalence_by_family: dict[str, Prevalence]
    prevalence_primary_family: dict[str, Prevalence]
    none_named: NoneNamed
    confidence: dict[str, int]
    parameters: dict[str, Distribution]
    outlier_threshold: float
    outliers: tuple[Outlier, ...]
    failed: tuple[FailedUnit, ...]
    _repr_html_ = fleet_html  # a notebook shows the sentences and tables of twin.fleet.fragment


@dataclass(frozen=True)
class SimulatedFleet:
    """``twin fleet-simulate --json``: where the logs, the truth and the spec went.

    Attributes
    ----------
    output : str
        The output folder (logs in ``logs/``).
    units : int
        Units in the fleet scenario.
    written : int
        Logs written by this run (the others were there already).
    spec : str
        ``fleet.yaml``, the spec that analyses the logs blind.
    truth : str
        ``truth.json``, never read by ``twin fleet``.
    prevalence : dict of str to float
        Hidden effect → share of the units that carry it [1].
    """

    output: str
    units: int
    written: int
    spec: str
    truth: str
    prevalence: dict[str, float]
