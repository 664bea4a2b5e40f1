"""The records of a log-quality assessment: thresholds, stretches, the used/excluded table.

Frozen and plain, so the JSON (``twin.results.to_json``) writes them field for field.
"""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class Thresholds:
    """The thresholds derived for one log (None where not tested).

    Attributes
    ----------
    sample_dt_s : float
        Sample step [s].
    sigma_mg : float
        Short-window σ of the acceleration above which rows move [mg].
    norm_g : float or None
        | |a| − still |a| | above which rows move [g].
    gyro_rad_s : float or None
        |ω| about the gyro's slow mean above which rows move [rad/s].
    """

    sample_dt_s: float
    sigma_mg: float
    norm_g: float | None
    gyro_rad_s: float | None


@dataclass(frozen=True)
class Stretch:
    """Rows ``start:stop`` of one kind (a gap or time reset holds no row: ``start == stop``).

    ``label`` and ``gravity_g`` (mean acceleration per logged axis [g]) are set for static
    stretches; ``ramp`` is "heating", "cooling", "dwell" or "mixed" (None without rows);
    ``attitude`` numbers the static stretches' attitudes in time order (a new one at every face
    change or re-placement, see :class:`QualitySettings`; None for other kinds and one axis).

    Attributes
    ----------
    start, stop : int
        Rows ``start:stop``.
    t0_s, t1_s : float
        Start and end time [s].
    kind, reason : str
        Kind of stretch and why it was used or excluded.
    label : str or None
        Face label (``+x`` … ``-z`` or ``tilted``).
    gravity_g : tuple of float or None
        Mean acceleration per logged axis [g].
    temperature_min_c, temperature_max_c : float or None
        Temperature span [°C].
    ramp : str or None
        "heating", "cooling", "dwell" or "mixed".
    attitude : int or None
        Attitude number.
    """

    start: int
    stop: int
    t0_s: float
    t1_s: float
    kind: str
    reason: str
    label: str | None = None
    gravity_g: tuple[float, ...] | None = None
    temperature_min_c: float | None = None
    temperature_max_c: float | None = None
    ramp: str | None = None
    attitude: int | None = None

    duration_s = property(lambda self: max(self.t1_s - self.t0_s, 0.0))
    span_c = property(lambda self: None if self.temperature_min_c is None else
                      self.temperature_max_c - self.temperature_min_c)


@dataclass(frozen=True)
class QualityRow:
    """One line of the used/excluded table (console, JSON, HTML).

    Attributes
    ----------
    kind, orientation, reason : str
        Kind of stretch, face label, why used or excluded.
    used : bool
        Used for calibration.
    from_s, to_s, duration_s : float
        Start, end and duration [s].
    span_c : float or None
        Temperature span [°C].
    """

    kind: str
    used: bool
    from_s: float
    to_s: float
    duration_s: float
    span_c: float | None
    orientation: str
    reason: str


@dataclass(frozen=True)
class DirectionClusters:
    """Directions grouped within a tolerance: ``member_of[i]`` is item i's cluster; per cluster its
    mean unit direction and label (``+x`` … ``-z`` within the tolerance of a face, else ``tilted``).

    Attributes
    ----------
    member_of : tuple of int
        Cluster of each item.
    directions : tuple of tuple of float
        Mean unit direction per cluster [1].
    labels : tuple of str
        Label per cluster.
    """

    member_of: tuple[int, ...]
    directions: tuple[tuple[float, float, float], ...]
    labels: tuple[str, ...]


@dataclass(frozen=True)
class ThermalDirections:
    """Whether rows heat and cool: the temperature change [°C] their heating / cooling rows make.

    Attributes
    ----------
    heating_c, cooling_c : float
        Temperature change of the heating and of the cooling rows [°C].
    has_heating, has_cooling : bool
        Whether that change reaches ``min_direction_c``.
    """

    heating_c: float
    cooling_c: float
    has_heating: bool
    has_cooling: bool


@dataclass(frozen=True)
class QualitySummary:
    """What a log lost before use, and why: the JSON's ``log_quality`` entry.

    Attributes
    ----------
    where : str
        The log (file and IMU).
    thresholds : Thresholds
        The thresholds used.
    static_s : float
        Seconds of usable static rows [s].
    excluded_s : dict of str to float
        Seconds excluded for each reason [s].
    static_min_c, static_max_c : float or None
        Temperature span of the static rows [°C].
    heating_c, cooling_c : float
        Temperature change made by heating and by cooling rows [°C].
    has_heating, has_cooling : bool
        Whether the log heats / cools.
    stretches : tuple of QualityRow
        Every stretch used or excluded, in time order.
    """

    where: str
    thresholds: Thresholds
    static_s: float
    excluded_s: dict[str, float]
    static_min_c: float | None
    static_max_c: float | None
    heating_c: float
    cooling_c: float
    has_heating: bool
    has_cooling: bool
    stretches: tuple[QualityRow, ...]
