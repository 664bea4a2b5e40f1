"""Log quality: which rows of a real log are a still sensor at a known orientation, and why the rest are not.

A flight log holds a warm-up, handling, a flight, maybe a crash and the vehicle upside down, gaps
and time resets. :func:`assess_log` classifies every row once, gives each static stretch its gravity
vector, face label (``+x`` … ``-z``, else ``tilted``) and ramp direction, and says which thermal
directions the usable rows hold; :func:`cluster_directions` is the project's one orientation
clustering. Thresholds come from the log's own still noise (median/MAD of short-window statistics,
iterated up from the quietest quarter) with physical floors (:class:`QualitySettings`).
"""

from __future__ import annotations

import json
from dataclasses import asdict, dataclass, replace
from pathlib import Path

import numpy as np

from twin.io import strict_json
from twin.measurement.core import Measurement, MeasurementError
from twin.measurement.imu import AXES, ImuLog
from twin.measurement.rowstats import (clipped_rows, dilate, frozen_rows, median_dt, ramp_rate_c_per_min, runs,
                                       slow_median, still_threshold, unit, window_stats)

KINDS = ("static", "moving", "handling", "gap", "time_reset", "clipping", "temperature_frozen", "temperature_jump",
         "other_attitude")
STATIC, MOVING, HANDLING, GAP, RESET, CLIPPING, FROZEN, JUMP, OTHER_ATTITUDE = range(len(KINDS))
FACE_LABELS = tuple(f"{s}{a}" for a in AXES for s in "+-")
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


@dataclass(frozen=True)
class Thresholds:
    """The thresholds derived for one log: sample step [s], σ [mg], | |a| − still |a| | [g] and
    |ω| [rad/s] (None where not tested)."""

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
    """One line of the used/excluded table (console, JSON, HTML)."""

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
    mean unit direction and label (``+x`` … ``-z`` within the tolerance of a face, else ``tilted``)."""

    member_of: tuple[int, ...]
    directions: tuple[tuple[float, float, float], ...]
    labels: tuple[str, ...]


@dataclass(frozen=True)
class ThermalDirections:
    """Whether rows heat and cool: the temperature change [°C] their heating / cooling rows make."""

    heating_c: float
    cooling_c: float
    has_heating: bool
    has_cooling: bool


@dataclass(frozen=True, eq=False)
class LogQuality:
    """Every row classified; see the module docstring. ``usable_static`` is per row."""

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
        """Seconds excluded for ``kind`` (one of :data:`KINDS` but "static"), or for every reason."""
        return sum(s.duration_s for s in self.stretches if s.kind != "static" and kind in (None, s.kind))

    def attitudes(self) -> dict[int, tuple[Stretch, ...]]:
        """The static stretches by attitude number (three axes only)."""
        out: dict[int, list[Stretch]] = {}
        for st in self.static_stretches():
            if st.attitude is not None:
                out.setdefault(st.attitude, []).append(st)
        return {k: tuple(v) for k, v in out.items()}

    def keeping_attitudes(self, keep, reason: str) -> LogQuality:
        """This result with the static stretches of attitudes not in ``keep`` excluded for ``reason``
        (kind "other_attitude"); the thermal directions stay those of the assessment."""
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
        return tuple(s for s in self.stretches if s.kind == "static")

    def table_rows(self) -> tuple[QualityRow, ...]:
        """What was used and what was excluded, and why, in time order."""
        return tuple(QualityRow(s.kind, s.kind == "static", s.t0_s, s.t1_s, s.duration_s, s.span_c,
                                s.label or "", s.reason) for s in self.stretches)

    def summary(self) -> str:
        """One line: static seconds and span, what was excluded."""
        span = "no static rows" if self.static_min_c is None else f"{self.static_min_c:.1f}–{self.static_max_c:.1f} °C"
        groups = {"motion": MOTION_KINDS, "gaps": ("gap",), "clipping": ("clipping",), "other attitudes": ("other_attitude",),
                  "temperature faults": ("temperature_frozen", "temperature_jump")}
        parts = [f"{sum(self.excluded_s(k) for k in kinds):.0f} s of {name}" for name, kinds in groups.items()
                 if any(s.kind in kinds for s in self.stretches)]
        resets = sum(s.kind == "time_reset" for s in self.stretches)
        parts += [f"{resets} time reset(s)"] if resets else []
        return f"{self.where}: {self.static_s:.0f} s static, {span} after excluding {', '.join(parts) or 'nothing'}"

    def to_json(self) -> str:
        """Strict JSON (finite floats, None for missing values) of the summary and every stretch."""
        doc = {"where": self.where, "thresholds": asdict(self.thresholds), "static_s": self.static_s,
               "excluded_s": {k: self.excluded_s(k) for k in KINDS[1:]}, "static_min_c": self.static_min_c,
               "static_max_c": self.static_max_c, **asdict(self.directions),
               "stretches": [asdict(r) for r in self.table_rows()]}
        return json.dumps(strict_json(doc), allow_nan=False, ensure_ascii=False)

    def require_calibratable(self, min_static_s: float = 60.0, min_span_c: float = 10.0) -> None:
        """Raise :class:`LogQualityError` unless the usable static rows last ``min_static_s`` and
        span ``min_span_c`` °C, e.g. ``"IMU3: 68 s static, 25.5–33.0 °C after excluding 162 s of
        motion: < 10 °C"``."""
        span = 0.0 if self.static_min_c is None else self.static_max_c - self.static_min_c
        short = [f"< {min_static_s:g} s static"] if self.static_s < min_static_s else []
        short += [f"< {min_span_c:g} °C"] if span < min_span_c else []
        if short:
            raise LogQualityError(f"{self.summary()}: {', '.join(short)}")


def face_label(direction, tol_deg: float = 10.0) -> str:
    """``+x`` … ``-z`` when the unit ``direction`` lies within ``tol_deg`` of that axis, else ``tilted``."""
    d = np.asarray(direction, float)
    k = int(np.argmax(np.abs(d)))
    return f"{'+' if d[k] > 0 else '-'}{AXES[k]}" if abs(d[k]) >= np.cos(np.radians(tol_deg)) else "tilted"


def cluster_directions(directions, tol_deg: float = 10.0) -> DirectionClusters:
    """Group unit gravity directions (m, 3): each joins the first cluster whose running mean lies
    within ``tol_deg``, else starts one (greedy in time order: a log's orientations come in runs)."""
    dirs = np.asarray(directions, float).reshape(-1, 3)
    cos_tol = np.cos(np.radians(tol_deg))
    groups: list[list[int]] = []
    for i, d in enumerate(dirs):
        for g in groups:
            centre = dirs[g].mean(axis=0)
            if d @ centre / np.linalg.norm(centre) >= cos_tol:
                g.append(i)
                break
        else:
            groups.append([i])
    member_of = [next(c for c, g in enumerate(groups) if i in g) for i in range(len(dirs))]
    means = tuple(tuple(float(v) for v in unit(dirs[g].mean(axis=0))) for g in groups)
    return DirectionClusters(tuple(member_of), means, tuple(face_label(m, tol_deg) for m in means))


def thermal_directions(time_s, temperature_c, mask=None, settings: QualitySettings | None = None) -> ThermalDirections:
    """Heating and cooling present in the rows ``mask`` (all by default): the temperature change made
    by rows whose smoothed rate exceeds ±``ramp_c_per_min``; present when ≥ ``min_direction_c``."""
    s = settings or QualitySettings()
    t = np.asarray(time_s, float)
    rate = ramp_rate_c_per_min(t, temperature_c, s.ramp_window_s)
    dt_med = median_dt(t)
    step = np.clip(np.diff(t, append=t[-1:] + dt_med), 0.0, max(s.gap_min_s, s.gap_factor * dt_med))
    use = np.ones(t.size, bool) if mask is None else np.asarray(mask, bool)
    heat = float(np.sum((rate * step / 60)[use & (rate > s.ramp_c_per_min)]))
    cool = float(-np.sum((rate * step / 60)[use & (rate < -s.ramp_c_per_min)]))
    return ThermalDirections(heat, cool, heat >= s.min_direction_c, cool >= s.min_direction_c)


def assess_log(log: ImuLog, settings: QualitySettings | None = None, **overrides) -> LogQuality:
    """Classify every row of one IMU's log; ``overrides``: fields of :class:`QualitySettings`."""
    where = f"{Path(log.source).name} IMU{log.instance}" if log.source else f"IMU{log.instance}"
    return _assess(log.time_s, log.temperature_c, log.accel_g, log.gyro_rad_s, where,
                   replace(settings or QualitySettings(), **overrides))


def assess_measurement(m: Measurement, settings: QualitySettings | None = None, **overrides) -> LogQuality:
    """The same for a single-axis measurement: no |a| test, no face labels or handling (one axis
    cannot give a direction); stretches' ``gravity_g`` is the axis' mean."""
    where = ", ".join(Path(s).name for s in m.sources) or "measurement"
    return _assess(m.time_s, m.temperature_c, np.asarray(m.output_g, float)[:, None], None, where,
                   replace(settings or QualitySettings(), **overrides))


def _assess(time_s, temperature_c, accel_g, gyro_rad_s, where: str, s: QualitySettings) -> LogQuality:
    t, T, a = np.asarray(time_s, float), np.asarray(temperature_c, float), np.asarray(accel_g, float)
    n = t.size
    if n < 3 or a.shape[0] != n or T.shape != (n,) or not np.all(np.isfinite(t) & np.isfinite(T) & np.isfinite(a).all(1)):
        raise LogQualityError(f"{where}: {n} rows, temperature {T.shape}, accel {a.shape}; expected ≥ 3 finite rows "
                              "on one time base (readers drop non-finite rows)")
    dt_med = median_dt(t)
    w, m = max(int(round(s.window_s / dt_med)), 3), int(round(s.margin_s / dt_med))
    mean_a, sd = window_stats(a, w)
    sigma = sd.max(axis=1) * 1e3
    thr_sigma = s.sigma_mg if s.sigma_mg is not None else still_threshold(sigma, s.sigma_floor_mg,
                                                                            s.sigma_ceiling_mg)
    moving = sigma > thr_sigma
    thr_norm = thr_gyro = None
    if a.shape[1] == 3:  # a sustained acceleration (a turn, a car) leaves σ small but |a| off its still level
        norm = np.linalg.norm(mean_a, axis=1)
        quiet = ~moving if (~moving).any() else np.ones(n, bool)
        dev = np.abs(norm - np.median(norm[quiet]))
        thr_norm = still_threshold(dev[quiet], s.norm_floor_g, s.norm_ceiling_g)
        moving |= dev > thr_norm
    g = None if gyro_rad_s is None else np.asarray(gyro_rad_s, float)
    finite = None if g is None else np.isfinite(g).all(axis=1)
    if g is not None and finite.any():  # |ω| about the gyro's own slow mean (its bias drifts with T)
        g = np.where(finite[:, None], g, np.median(g[finite], axis=0))  # rows without a gyro sample: no ω test
        bias = slow_median(t, g, s.gyro_reference_s)
        omega = window_stats(np.linalg.norm(g - bias, axis=1)[:, None], w)[0][:, 0]
        thr_gyro = still_threshold(omega, s.gyro_floor_rad_s, s.gyro_ceiling_rad_s)
        moving |= omega > thr_gyro
    d = np.diff(t)
    gap, jump = d > max(s.gap_factor * dt_med, s.gap_min_s), np.zeros(n, bool)
    jump[1:] = (d > 0) & (np.abs(np.diff(T)) > s.jump_c * np.maximum(d, 1.0))  # > jump_c/s at steps over 1 s
    code = np.full(n, STATIC, np.int8)
    for rows, kind in ((dilate(moving, m), MOVING), (frozen_rows(t, T, s.frozen_s), FROZEN),
                       (dilate(jump, m), JUMP), (dilate(clipped_rows(a, s.range_g), m), CLIPPING)):
        code[rows] = kind  # later kinds win: clipping explains the motion around it
    breaks = np.flatnonzero(gap | (d <= 0)) + 1  # a stretch never spans a gap or a time reset
    for i, j in runs(code == STATIC, breaks):
        if t[j - 1] - t[i] < s.min_static_s:
            code[i:j] = MOVING
    handled = {**_mark_turning(code, t, mean_a, breaks, s), **_mark_handling(code, t, mean_a, breaks, s)} \
        if a.shape[1] == 3 else {}
    return _quality(where, t, T, a, code, breaks, gap, handled, Thresholds(dt_med, float(thr_sigma), thr_norm, thr_gyro), s)


def _mark_turning(code, t, mean_a, breaks, s: QualitySettings) -> dict[int, str]:
    """Still stretches whose gravity direction turns by more than ``turn_deg`` become moving (a
    board rotated slowly on a turntable or a sagging mount reads steady σ and |a|); returns their
    reasons by first row."""
    out = {}
    for i, j in runs(code == STATIC, breaks):
        cos = mean_a[i:j] @ unit(mean_a[i]) / np.maximum(np.linalg.norm(mean_a[i:j], axis=1), 1e-12)
        turn = float(np.degrees(np.arccos(np.clip(cos.min(), -1.0, 1.0))))
        if turn > s.turn_deg:
            code[i:j] = MOVING
            out[i] = f"turning: the gravity direction moves {turn:.0f}° within {t[j - 1] - t[i]:.0f} s of steady readings"
    return out


def _mark_handling(code, t, mean_a, breaks, s: QualitySettings) -> dict[int, str]:
    """Short moves between two static stretches that tilt the gravity direction become handling;
    returns their reasons by first row."""
    out = {}
    for i, j in runs(code == MOVING, breaks):
        if (i == 0 or j == code.size or code[i - 1] != STATIC or code[j] != STATIC or t[j] - t[i - 1] > s.handling_max_s
                or np.any((breaks >= i) & (breaks <= j))):
            continue
        before, after = unit(mean_a[i - 1]), unit(mean_a[j])
        tilt = np.degrees(np.arccos(np.clip(np.min(mean_a[i:j] @ before / np.linalg.norm(mean_a[i:j], axis=1)), -1, 1)))
        if tilt > s.handling_tilt_deg:
            code[i:j] = HANDLING
            out[i] = (f"handling: a {t[j] - t[i - 1]:.0f}-s move between static stretches, tilted {tilt:.0f}°, "
                      f"orientation changed by {np.degrees(np.arccos(np.clip(before @ after, -1, 1))):.1f}°")
    return out


def _quality(where, t, T, a, code, breaks, gap, handled, thresholds: Thresholds, s: QualitySettings) -> LogQuality:
    dt_med, rate = thresholds.sample_dt_s, ramp_rate_c_per_min(t, T, s.ramp_window_s)
    spans = sorted((i, j, int(code[i])) for k in range(len(KINDS)) for i, j in runs(code == k, breaks))
    gravity = {i: a[i:j].mean(axis=0) for i, j, k in spans if k == STATIC}
    labels, attitude = dict.fromkeys(gravity), dict.fromkeys(gravity)
    if a.shape[1] == 3 and gravity:
        clusters = cluster_directions([unit(g) for g in gravity.values()], s.face_tol_deg)
        labels = {i: clusters.labels[c] for i, c in zip(gravity, clusters.member_of)}
        attitude = _attitudes([(i, j) for i, j, k in spans if k == STATIC], labels, t, T, a, s)
    out = [Stretch(i, j, float(t[i]), float(t[j - 1] + dt_med), KINDS[k], handled.get(i) or _reason(k, t, T, i, j, s),
                   labels.get(i), tuple(float(v) for v in gravity[i]) if i in gravity else None,
                   float(T[i:j].min()), float(T[i:j].max()), _ramp(rate[i:j], s.ramp_c_per_min), attitude.get(i))
           for i, j, k in spans]
    for b in breaks:  # the break sits before row b: a stretch of no rows between rows b − 1 and b
        out.append(Stretch(b, b, float(t[b - 1] + dt_med), float(t[b]), "gap",
                           f"no sample for {t[b] - t[b - 1]:.3g} s (median step {dt_med:.3g} s)") if gap[b - 1] else
                   Stretch(b, b, float(t[b - 1]), float(t[b - 1]), "time_reset",
                           f"time goes from {t[b - 1]:.6g} s back to {t[b]:.6g} s"))
    usable = code == STATIC
    lo, hi = (float(T[usable].min()), float(T[usable].max())) if usable.any() else (None, None)
    return LogQuality(where, usable, tuple(sorted(out, key=lambda r: (r.start, r.stop))), thresholds,
                      thermal_directions(t, T, usable, s), lo, hi)


def _attitudes(static: list[tuple[int, int]], labels: dict, t, T, a, s: QualitySettings) -> dict[int, int]:
    """Attitude number per static stretch (by first row), in time order: a new one where the face
    changes, or where the mean readings at the facing ends of two consecutive stretches differ by
    more than drift and noise allow (see :class:`QualitySettings`)."""
    out, current = {}, 0
    for n, (i, j) in enumerate(static):
        if n:
            (pi, pj) = static[n - 1]
            before, after = _edge(t, pi, pj, s.attitude_edge_s, end=True), _edge(t, i, j, s.attitude_edge_s, end=False)
            step_mg = float(np.linalg.norm(a[after].mean(0) - a[before].mean(0))) * 1e3
            noise_mg = 1e3 * float(np.sqrt(np.sum(a[before].var(0) / before.size + a[after].var(0) / after.size)))
            allowed = s.attitude_step_mg + s.attitude_mg_per_c * abs(float(T[after].mean() - T[before].mean())) + 6 * noise_mg
            current += labels[i] != labels[pi] or step_mg > allowed
        out[i] = current
    return out


def _edge(t, i: int, j: int, seconds: float, end: bool) -> np.ndarray:
    """Row indices of the last (``end``) or first ``seconds`` of rows i:j (at least two rows)."""
    if end:
        return np.arange(min(int(np.searchsorted(t[i:j], t[j - 1] - seconds)) + i, j - 2), j).clip(i)
    return np.arange(i, max(int(np.searchsorted(t[i:j], t[i] + seconds, side="right")) + i, i + 2)).clip(max=j - 1)


def _reason(k: int, t, T, i: int, j: int, s: QualitySettings) -> str:
    """Why rows i:j are what they are (static rows: why they are used)."""
    return {STATIC: f"still ≥ {s.min_static_s:g} s, {s.margin_s:g} s cut beside each move",
            MOVING: f"moving, or still < {s.min_static_s:g} s between moves (with {s.margin_s:g} s settling margins)",
            CLIPPING: f"|a| at the log's flat maximum or beyond ±{s.range_g:g} g",
            FROZEN: f"temperature stuck at {T[i]:.2f} °C for {t[j - 1] - t[i]:.0f} s while the rest of the log changes",
            JUMP: f"temperature steps > {s.jump_c:g} °C in one sample (max {np.abs(np.diff(T[i:j])).max(initial=0):.3g} °C)"}[k]


def _ramp(rate: np.ndarray, thr: float) -> str | None:
    if rate.size == 0:
        return None
    heat, cool = np.mean(rate > thr), np.mean(rate < -thr)
    if heat >= 0.25 and cool >= 0.25:
        return "mixed"
    return max((heat, "heating"), (cool, "cooling"), (1 - heat - cool, "dwell"))[1]
