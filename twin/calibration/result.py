"""The calibration document ``twin calibrate`` writes (``-o CAL.json``), typed and built once.

:func:`twin.calibration.document.calibration_document` builds a :class:`CalibrationDocument` from
the calibrations; :func:`twin.results.to_json` writes it field for field and ``twin schema
--result calibration`` derives its schema from these types. The layout is that of ``schema_version``
1, which ``twin firmware`` and ``twin apply`` read (:mod:`twin.calibration.deploy` checks files
from elsewhere as untrusted data). Where a key's name carries the unit, the accelerometer's [mg]
and the gyro's [mrad/s] are two optional fields, the other one left out.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

from twin.calibration.fragment import document_html
from twin.calibration.method_records import FirmwareMethod, MethodRecord
from twin.measurement.quality_records import QualitySummary
from twin.results import PerAxis, to_json


@dataclass(frozen=True)
class InputFile:
    """One input file, as read.

    Attributes
    ----------
    path : str
    bytes : int
        Size [bytes].
    sha256 : str
        Hex digest of the content.
    """

    path: str
    bytes: int
    sha256: str


@dataclass(frozen=True)
class SkippedImu:
    """An IMU the logs hold that was not calibrated.

    Attributes
    ----------
    instance : int
    reason : str
    """

    instance: int
    reason: str


@dataclass(frozen=True)
class HeldoutScores:
    """One held-out test of one fold: every method's RMS per axis on its rows.

    Attributes
    ----------
    samples : int
        Rows of the test.
    extrapolated_fraction : float
        Share of them outside the training temperatures [1].
    rms_mg : dict of str to PerAxis of float, optional
        Method → RMS [mg] (the accelerometer).
    rms_mrad_s : dict of str to PerAxis of float, optional
        Method → RMS [mrad/s] (the gyro).
    """

    samples: int
    extrapolated_fraction: float
    rms_mg: dict[str, PerAxis[float]] | None = None
    rms_mrad_s: dict[str, PerAxis[float]] | None = None


@dataclass(frozen=True, kw_only=True)
class ValidationTable:
    """Held-out validation of every method, with the white-noise floor of the data.

    The accelerometer's figures are in mg (the ``_mg`` fields), the gyro's in mrad/s (the
    ``_mrad_s`` fields); the other unit's fields are None and left out.

    Attributes
    ----------
    noise_floor_mg, noise_floor_mrad_s : PerAxis of float, optional
        White-noise floor per axis [mg] or [mrad/s].
    heldout_rms_mg, heldout_rms_mrad_s : dict of str to PerAxis of float, optional
        Method → held-out RMS pooled over folds and tests [mg] or [mrad/s].
    best_overall : PerAxis of str
        The method with the lowest held-out RMS on each axis.
    tests : dict of str to HeldoutScores
        ``"<fold>: <test>"`` → the scores.
    notes : tuple of str
    as_applied : str
        What the ``<method>_as_applied`` entries are.
    """

    noise_floor_mg: PerAxis[float] | None = None
    noise_floor_mrad_s: PerAxis[float] | None = None
    heldout_rms_mg: dict[str, PerAxis[float]] | None = None
    heldout_rms_mrad_s: dict[str, PerAxis[float]] | None = None
    best_overall: PerAxis[str]
    tests: dict[str, HeldoutScores]
    notes: tuple[str, ...]
    as_applied: str


@dataclass(frozen=True)
class RecommendedMethods:
    """The method each target runs by default (None: none it can run unflagged).

    Attributes
    ----------
    px4, ardupilot : str or None
        The firmware's own method unless flagged.
    c : str or None
        Custom C and ``twin apply``: the method the recommendation chose.
    """

    px4: str | None
    ardupilot: str | None
    c: str | None


@dataclass(frozen=True)
class RecommendedGyroMethods:
    """The gyro method each firmware runs by default (None: flagged or not fitted).

    Attributes
    ----------
    px4, ardupilot : str or None
    """

    px4: str | None
    ardupilot: str | None


@dataclass(frozen=True)
class VerdictRecord:
    """What the data could say about one candidate method.

    Attributes
    ----------
    folds : tuple of str
        The folds that can validate it.
    eligible : bool
    reason : str
    rms_mg : PerAxis of float or None
        Held-out RMS pooled over those folds [mg] (None: no such fold).
    worst_ratio_to_cubic : float or None
        Its largest RMS ratio to the cubic over those folds and axes [1].
    """

    folds: tuple[str, ...]
    eligible: bool
    reason: str
    rms_mg: PerAxis[float] | None
    worst_ratio_to_cubic: float | None


@dataclass(frozen=True)
class RecommendationRecord:
    """The default method of ``twin apply`` and the C export, and why.

    Attributes
    ----------
    method : str or None
    reason : str
    custom_firmware_gain : str or None
        What only custom firmware removes against the cubic PX4 and ArduPilot run.
    verdicts : dict of str to VerdictRecord
        Every candidate's verdict.
    """

    method: str | None
    reason: str
    custom_firmware_gain: str | None
    verdicts: dict[str, VerdictRecord]


@dataclass(frozen=True)
class GyroRecord:
    """The gyro of one IMU: firmware methods fitted on its still rows, validated held out.

    Attributes
    ----------
    device_id : int or None
    unit : str
        ``rad/s``.
    validation : ValidationTable
        In mrad/s.
    recommended : RecommendedGyroMethods
    flags : dict of str to tuple of str
        Method → why it is implausible (plausible methods left out).
    methods : dict of str to FirmwareMethod
    """

    device_id: int | None
    unit: str
    validation: ValidationTable
    recommended: RecommendedGyroMethods
    flags: dict[str, tuple[str, ...]]
    methods: dict[str, FirmwareMethod]


@dataclass(frozen=True)
class Tempco:
    """A fitted temperature coefficient and its 95 % interval, in the unit of the field holding it.

    Attributes
    ----------
    value : float
    ci95 : (float, float)
    """

    value: float
    ci95: tuple[float, float]


@dataclass(frozen=True)
class OrientationRecord:
    """The orientations one log holds, and per axis offset(T) and scale factor(T) from them.

    Attributes
    ----------
    kind : str
        ``six-position``, ``tumble`` … .
    found, missing : tuple of str
        Faces found and not found (``+x`` … ``-z``).
    static_segments : int
    reference_c : float
        Expansion point of the fits [°C].
    tcso_ppm_per_c : PerAxis of Tempco
        Scale-factor tempco [ppm/°C].
    tcoff_mg_per_c : PerAxis of Tempco
        Offset tempco [mg/°C].
    zero_g_offset_mg : PerAxis of float
        Offset at ``reference_c`` [mg].
    residual_rms_mg : PerAxis of float
        RMS left by the fit [mg].
    notes : tuple of str
    flags : tuple of str
        Tempcos beyond what the part can have.
    """

    kind: str
    found: tuple[str, ...]
    missing: tuple[str, ...]
    static_segments: int
    reference_c: float
    tcso_ppm_per_c: PerAxis[Tempco]
    tcoff_mg_per_c: PerAxis[Tempco]
    zero_g_offset_mg: PerAxis[float]
    residual_rms_mg: PerAxis[float]
    notes: tuple[str, ...]
    flags: tuple[str, ...]


@dataclass(frozen=True, kw_only=True)
class ImuRecord:
    """One IMU calibrated: its data, validation, recommendation and every fitted method.

    Attributes
    ----------
    instance : int
    device_id : int or None
        The accelerometer's device id (None: not known).
    sources : tuple of str
        The logs (several: several runs).
    samples : int
        Rows fitted.
    temperature_span_c : (float, float)
        Temperature span of those rows [°C].
    sample_rate_hz : float
        Of the first log [Hz].
    protocol : str
        How the folds were formed.
    validation : ValidationTable
        In mg.
    recommended : RecommendedMethods
    recommendation : RecommendationRecord, optional
    flags : dict of str to tuple of str
        Method → why it is implausible (plausible methods left out).
    notes : tuple of str
    board_orientation : int or None
        ArduPilot ``AHRS_ORIENTATION`` of the logs.
    log_quality : tuple of QualitySummary
        Per log: what was still and used, what was excluded and why.
    orientations : OrientationRecord, optional
        When the log holds several orientations.
    gyro : GyroRecord, optional
        When the logs hold this IMU's gyro.
    methods : dict of str to MethodRecord
        Method name → the fitted method.
    """

    instance: int
    device_id: int | None
    sources: tuple[str, ...]
    samples: int
    temperature_span_c: tuple[float, float]
    sample_rate_hz: float
    protocol: str
    validation: ValidationTable
    recommended: RecommendedMethods
    recommendation: RecommendationRecord | None = None
    flags: dict[str, tuple[str, ...]]
    notes: tuple[str, ...]
    board_orientation: int | None
    log_quality: tuple[QualitySummary, ...]
    orientations: OrientationRecord | None = None
    gyro: GyroRecord | None = None
    methods: dict[str, MethodRecord]


@dataclass(frozen=True)
class CalibrationDocument:
    """The versioned calibration document (``-o CAL.json``).

    Attributes
    ----------
    schema : str
        ``tde-twin calibration``.
    schema_version : int
    software_version : str
    created_utc : str
        ISO 8601, to the second.
    inputs : tuple of InputFile
    skipped : tuple of SkippedImu
    imus : tuple of ImuRecord
    """

    schema: Literal["tde-twin calibration"]
    schema_version: int
    software_version: str
    created_utc: str
    inputs: tuple[InputFile, ...]
    skipped: tuple[SkippedImu, ...]
    imus: tuple[ImuRecord, ...]
    _repr_html_ = document_html  # a notebook shows the sentences and table of twin.calibration.fragment

    def to_json(self) -> dict:
        """The JSON of the document (see :mod:`twin.results`).

        Returns
        -------
        dict
        """
        return to_json(self)
