"""What a log-quality assessment takes and gives: the row kinds, :class:`QualitySettings` (what
counts as still, a gap, a fault, and why) and :class:`LogQuality` (every row classified).

The assessment itself, :func:`~twin.measurement.quality.assess_log`, is in
:mod:`twin.measurement.quality`; the records the JSON holds are in
:mod:`twin.measurement.quality_records`.
"""

from __future__ import annotations

import json
from dataclasses import dataclass, replace

import numpy as np

from twin.io import strict_json
from twin.measurement.core import MeasurementError
from twin.measurement.quality_records import QualityRow, QualitySummary, Stretch, ThermalDirections, Thresholds
from twin.results import to_json

KINDS = ("static", "moving", "handling", "gap", "time_reset", "clipping", "temperature_frozen", "temperature_jump",
         "other_attitude")
STATIC, MOVING, HANDLING, GAP, RESET, CLIPPING, FROZEN, JUMP, OTHER_ATTITUDE = range(len(KINDS))
MOTION_KINDS = ("moving", "handling")


class LogQualityError(MeasurementError):
    """A log whose usable rows cannot support what was asked of them (one line, with the numbers)."""


@dataclass(frozen=True)
class QualitySettings:
    """What counts as still, a gap, a fault; the defaults and why.

    window_s 1 s resolves a 5-s handling step. A static stretch lasts ≥ min_static_s 10 s after
    margin_s 2 s (the settling after a hand lets go) is cut beside every move, clip and jump.
    Derived thresholds never fall below sigma_floor_mg 1 mg (a noise-free log has σ = 0),
    norm_floor_g 0.1 g (|a| differs by twice an uncalibrated offset between faces) or
    gyro_floor_rad_s 0.05 rad/s. A gap: dt > gap_factor 5 median steps and > gap_min_s 1 s.
    Clipping: |a| ≥ range_g 16 g or a flat top. frozen_s 60 s of one temperature while the rest of
    the log changes most steps; jump_c 2 °C in one ≤ 1-s step (a die cannot). ramp_c_per_min
    0.05 °C/min on a ramp_window_s 60-s slope: heating / cooling / dwell; a direction is present
    when it changes the temperature ≥ min_direction_c 1 °C. face_tol_deg 10° from an axis is that
    face. Handling: a move ≤ handling_max_s 60 s between static stretches tilting > handling_tilt_deg
    3°. sigma_mg: a fixed σ threshold [mg] instead of the derived one.

    Derived thresholds never rise above sigma_ceiling_mg 50 mg (no MEMS accelerometer at rest is
    that noisy over 1 s: a log that is mostly flight would otherwise call its vibration still),
    norm_ceiling_g 0.3 g and gyro_ceiling_rad_s 0.3 rad/s (17 °/s). The gyro is compared with its
    own mean over gyro_reference_s 60 s, not the whole log's: its bias drifts with temperature.
    Attitude: two consecutive static stretches whose mean readings over attitude_edge_s 10 s at
    the facing ends differ by more than attitude_step_mg 5 mg + attitude_mg_per_c 3.5 mg/°C of the
    temperature change between them (the drift of three axes at 2× a typical 0.8 mg/°C, added in
    quadrature) + 6 σ of the means sit at another attitude (a re-placed or crashed vehicle): a
    2° re-placement is 35 mg on a cross axis, which an offset fit would take for drift. A still
    stretch whose direction turns by more than turn_deg 10° is moving (a slow rotation keeps σ and
    |a| steady); 10° is 175 mg on a cross axis, beyond the drift of any plausible part over its range.

    Attributes
    ----------
    window_s : float
        Window of the short-window statistics [s].
    min_static_s, margin_s : float
        Shortest static stretch; settling cut beside every move, clip and jump [s].
    sigma_floor_mg, sigma_ceiling_mg : float
        Bounds of the derived σ threshold [mg].
    norm_floor_g, norm_ceiling_g : float
        Bounds of the derived | |a| − still |a| | threshold [g].
    gyro_floor_rad_s, gyro_ceiling_rad_s : float
        Bounds of the derived |ω| threshold [rad/s].
    gap_factor : float
        A gap is a step above this many median steps [1] ...
    gap_min_s : float
        ... and above this [s].
    range_g : float
        |a| at or above this is clipping [g].
    frozen_s : float
        One temperature held this long is a frozen thermometer [s].
    jump_c : float
        A temperature step above this in one ≤ 1-s step is a jump [°C].
    ramp_c_per_min : float
        Slope above which rows are heating or cooling [°C/min].
    ramp_window_s : float
        Window of that slope [s].
    min_direction_c : float
        Temperature change that makes a thermal direction present [°C].
    face_tol_deg : float
        Angle to an axis within which a direction is that face [°].
    handling_max_s, handling_tilt_deg : float
        Longest move counted as handling [s]; the tilt it must make [°].
    sigma_mg : float or None
        A fixed σ threshold instead of the derived one [mg].
    gyro_reference_s : float
        Window of the gyro's own slow mean [s].
    attitude_step_mg, attitude_mg_per_c : float
        Allowed change between consecutive static stretches at one attitude [mg], plus this much
        per degree of temperature change between them [mg/°C].
    attitude_edge_s : float
        Span of the facing ends compared [s].
    turn_deg : float
        Turn of the gravity direction within a still stretch that makes it moving [°].
    """

    window_s: float = 1.0
    min_static_s: float = 10.0
    margin_s: float = 2.0
    sigma_floor_mg: float = 1.0
    norm_floor_g: float = 0.1
    gyro_floor_rad_s: float = 0.05
    gap_factor: float = 5.0
    gap_min_s: float = 1.0
    range_g: float = 16.0
    frozen_s: float = 60.0
    jump_c: float = 2.0
    ramp_c_per_min: float = 0.05
    ramp_window_s: float = 60.0
    min_direction_c: float = 1.0
    face_tol_deg: float = 10.0
    handling_max_s: float = 60.0
    handling_tilt_deg: float = 3.0
    sigma_mg: float | None = None
    sigma_ceiling_mg: float = 50.0
    norm_ceiling_g: float = 0.3
    gyro_ceiling_rad_s: float = 0.3
    gyro_reference_s: float = 60.0
    attitude_step_mg: float = 5.0
    attitude_mg_per_c: float = 3.5
    attitude_edge_s: float = 10.0
    turn_deg: float = 10.0


@dataclass(frozen=True, eq=False)
class LogQuality:
    """Every row of one log classified (:func:`~twin.measurement.quality.assess_log`).

    Attributes
    ----------
    where : str
        The log (file and IMU instance), for messages.
    usable_static : ndarray of bool
        Per row: a usable static row.
    stretches : tuple of Stretch
        Every stretch (used and excluded, gaps and time resets as empty stretches), in time order.
    thresholds : Thresholds
        The thresholds derived for this log.
    directions : ThermalDirections
        Heating and cooling the usable rows hold [°C].
    static_min_c, static_max_c : float or None
        Temperature range of the usable static rows [°C]; None without any.
    """

    where: str
    usable_static: np.ndarray
    stretches: tuple[Stretch, ...]
    thresholds: Thresholds
    directions: ThermalDirections
    static_min_c: float | None
    static_max_c: float | None

    has_heating = property(lambda self: self.directions.has_heating)
    has_cooling = property(lambda self: self.directions.has_cooling)
    static_s = property(lambda self: sum(s.duration_s for s in self.stretches if s.kind == "static"))

    def excluded_s(self, kind: str | None = None) -> float:
        """Seconds excluded for ``kind`` (one of :data:`KINDS` but "static"), or for every reason.

        Parameters
        ----------
        kind : str, optional
            The reason; None for all.

        Returns
        -------
        float
            Excluded time [s].
        """
        return sum(s.duration_s for s in self.stretches if s.kind != "static" and kind in (None, s.kind))

    def attitudes(self) -> dict[int, tuple[Stretch, ...]]:
        """The static stretches by attitude number (three axes only).

        Returns
        -------
        dict of int to tuple of Stretch
            Static stretches of each attitude, in time order; empty for a single-axis log.
        """
        out: dict[int, list[Stretch]] = {}
        for st in self.static_stretches():
            if st.attitude is not None:
                out.setdefault(st.attitude, []).append(st)
        return {k: tuple(v) for k, v in out.items()}

    def keeping_attitudes(self, keep, reason: str) -> LogQuality:
        """This result with the static stretches of attitudes not in ``keep`` excluded for ``reason``
        (kind "other_attitude"); the thermal directions stay those of the assessment.

        Parameters
        ----------
        keep : collection of int
            Attitude numbers kept.
        reason : str
            Why the others are excluded (in each excluded stretch's reason).

        Returns
        -------
        LogQuality
            The result with those rows no longer usable (this one itself when nothing is dropped).
        """
        drop = [st for st in self.static_stretches() if st.attitude not in keep]
        if not drop:
            return self
        usable = self.usable_static.copy()
        for st in drop:
            usable[st.start:st.stop] = False
        stretches = tuple(replace(st, kind="other_attitude", reason=f"attitude {st.attitude} ({st.label or 'tilted'}): "
                                  f"{reason}") if st in drop else st for st in self.stretches)
        kept = [st for st in stretches if st.kind == "static"]
        return replace(self, usable_static=usable, stretches=stretches,
                       static_min_c=min((st.temperature_min_c for st in kept), default=None),
                       static_max_c=max((st.temperature_max_c for st in kept), default=None))

    def static_stretches(self) -> tuple[Stretch, ...]:
        """The stretches of kind "static" (the usable rows), in time order.

        Returns
        -------
        tuple of Stretch
            The static stretches.
        """
        return tuple(s for s in self.stretches if s.kind == "static")

    def table_rows(self) -> tuple[QualityRow, ...]:
        """What was used and what was excluded, and why, in time order.

        Returns
        -------
        tuple of QualityRow
            One row per stretch: kind, used, start and end [s], duration [s], span [°C], face, reason.
        """
        return tuple(QualityRow(s.kind, s.kind == "static", s.t0_s, s.t1_s, s.duration_s, s.span_c,
                                s.label or "", s.reason) for s in self.stretches)

    def summary(self) -> str:
        """One line: static seconds and span, what was excluded.

        Returns
        -------
        str
            E.g. ``"IMU0: 600 s static, 20.0–45.0 °C after excluding 30 s of motion"``.
        """
        span = "no static rows" if self.static_min_c is None else f"{self.static_min_c:.1f}–{self.static_max_c:.1f} °C"
        groups = {"motion": MOTION_KINDS, "gaps": ("gap",), "clipping": ("clipping",), "other attitudes": ("other_attitude",),
                  "temperature faults": ("temperature_frozen", "temperature_jump")}
        parts = [f"{sum(self.excluded_s(k) for k in kinds):.0f} s of {name}" for name, kinds in groups.items()
                 if any(s.kind in kinds for s in self.stretches)]
        resets = sum(s.kind == "time_reset" for s in self.stretches)
        parts += [f"{resets} time reset(s)"] if resets else []
        return f"{self.where}: {self.static_s:.0f} s static, {span} after excluding {', '.join(parts) or 'nothing'}"

    def record(self) -> QualitySummary:
        """The summary and every stretch, as the JSON holds them.

        Returns
        -------
        QualitySummary
            Thresholds, static and excluded time [s], static range and thermal directions [°C],
            and the table rows.
        """
        d = self.directions
        return QualitySummary(self.where, self.thresholds, self.static_s, {k: self.excluded_s(k) for k in KINDS[1:]},
                              self.static_min_c, self.static_max_c, d.heating_c, d.cooling_c, d.has_heating,
                              d.has_cooling, self.table_rows())

    def to_json(self) -> str:
        """Strict JSON (finite floats, None for missing values) of the summary and every stretch.

        Returns
        -------
        str
            The JSON text of :meth:`record`.
        """
        return json.dumps(strict_json(to_json(self.record())), allow_nan=False, ensure_ascii=False)

    def require_calibratable(self, min_static_s: float = 60.0, min_span_c: float = 10.0) -> None:
        """Raise :class:`LogQualityError` unless the usable static rows last ``min_static_s`` and
        span ``min_span_c`` °C, e.g. ``"IMU3: 68 s static, 25.5–33.0 °C after excluding 162 s of
        motion: < 10 °C"``.

        Parameters
        ----------
        min_static_s : float
            Least usable static time [s].
        min_span_c : float
            Least temperature span of the usable static rows [°C].

        Raises
        ------
        LogQualityError
            Too little static time or span, with the summary.
        """
        span = 0.0 if self.static_min_c is None else self.static_max_c - self.static_min_c
        short = [f"< {min_static_s:g} s static"] if self.static_s < min_static_s else []
        short += [f"< {min_span_c:g} °C"] if span < min_span_c else []
        if short:
            raise LogQualityError(f"{self.summary()}: {', '.join(short)}")
