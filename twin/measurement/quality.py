"""Log quality: which rows of a real log are a still sensor at a known orientation, and why the rest are not.

A flight log holds a warm-up, handling, a flight, maybe a crash and the vehicle upside down, gaps
and time resets. :func:`assess_log` classifies every row once, gives each static stretch its gravity
vector, face label (``+x`` … ``-z``, else ``tilted``) and ramp direction, and says which thermal
directions the usable rows hold; :func:`cluster_directions` is the project's one orientation
clustering. Thresholds come from the log's own still noise (median/MAD of short-window statistics,
iterated up from the quietest quarter) with physical floors
(:class:`~twin.measurement.log_quality.QualitySettings`). The row kinds, the settings and the
result, :class:`~twin.measurement.log_quality.LogQuality`, are in :mod:`twin.measurement.log_quality`.
"""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np

from twin.arrays import median_dt, temperature_rate_c_per_s
from twin.measurement.core import Measurement
from twin.measurement.imu import AXES, ImuLog
from twin.measurement.log_quality import (
    CLIPPING,
    FROZEN,
    HANDLING,
    JUMP,
    KINDS,
    MOVING,
    STATIC,
    LogQuality,
    LogQualityError,
    QualitySettings,
)
from twin.measurement.quality_records import DirectionClusters, Stretch, ThermalDirections, Thresholds
from twin.measurement.rowstats import (clipped_rows, dilate, frozen_rows, runs, slow_median, still_threshold, unit,
                                       window_stats)

FACE_LABELS = tuple(f"{s}{a}" for a in AXES for s in "+-")


def face_label(direction, tol_deg: float = 10.0) -> str:
    """``+x`` … ``-z`` when the unit ``direction`` lies within ``tol_deg`` of that axis, else ``tilted``.

    Parameters
    ----------
    direction : array_like
        Unit vector x, y, z [1].
    tol_deg : float
        Angle to an axis [°].

    Returns
    -------
    str
        The face label.
    """
    d = np.asarray(direction, float)
    k = int(np.argmax(np.abs(d)))
    return f"{'+' if d[k] > 0 else '-'}{AXES[k]}" if abs(d[k]) >= np.cos(np.radians(tol_deg)) else "tilted"


def face_gravity(label: str) -> np.ndarray:
    """Gravity along x, y, z for a sensor resting on the face ``label`` (``"-z"`` → (0, 0, −1)): the
    nominal truth a static stretch with that :func:`face_label` is compared with.

    Parameters
    ----------
    label : str
        ``+x`` … ``-z`` (not ``tilted``).

    Returns
    -------
    ndarray
        Unit gravity vector [g]; a minus face's zeros carry its sign (−0.0), as the six-position
        fits have always been given them (least squares differs in the last bits otherwise).
    """
    return np.eye(3)[AXES.index(label[1])] * (1.0 if label[0] == "+" else -1.0)


def cluster_directions(directions, tol_deg: float = 10.0) -> DirectionClusters:
    """Group unit gravity directions (m, 3): each joins the first cluster whose running mean lies
    within ``tol_deg``, else starts one (greedy in time order: a log's orientations come in runs).

    Parameters
    ----------
    directions : array_like
        Unit vectors, shape (m, 3) [1].
    tol_deg : float
        Angle to a cluster's mean [°].

    Returns
    -------
    DirectionClusters
        Membership, mean unit direction and face label per cluster.
    """
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
    by rows whose smoothed rate exceeds ±``ramp_c_per_min``; present when ≥ ``min_direction_c``.

    Parameters
    ----------
    time_s, temperature_c : array_like
        Sample times [s] and temperature [°C].
    mask : array_like of bool, optional
        Rows counted.
    settings : QualitySettings, optional
        Ramp-rate window and thresholds.

    Returns
    -------
    ThermalDirections
        Heating and cooling change [°C] and whether each is present.
    """
    s = settings or QualitySettings()
    t = np.asarray(time_s, float)
    rate = temperature_rate_c_per_s(t, temperature_c, smooth_s=s.ramp_window_s, method="half_windows") * 60.0  # °C/min
    dt_med = median_dt(t)
    step = np.clip(np.diff(t, append=t[-1:] + dt_med), 0.0, max(s.gap_min_s, s.gap_factor * dt_med))
    use = np.ones(t.size, bool) if mask is None else np.asarray(mask, bool)
    heat = float(np.sum((rate * step / 60)[use & (rate > s.ramp_c_per_min)]))
    cool = float(-np.sum((rate * step / 60)[use & (rate < -s.ramp_c_per_min)]))
    return ThermalDirections(heat, cool, heat >= s.min_direction_c, cool >= s.min_direction_c)


def assess_log(log: ImuLog, settings: QualitySettings | None = None, **overrides) -> LogQuality:
    """Classify every row of one IMU's log; ``overrides``: fields of :class:`QualitySettings`.

    Parameters
    ----------
    log : ImuLog
        Time [s], temperature [°C], acceleration [g], gyro [rad/s].
    settings : QualitySettings, optional
        Thresholds; default :class:`QualitySettings`.
    **overrides
        Fields of the settings replaced [their units].

    Returns
    -------
    LogQuality
        Every row classified, stretches, thresholds and thermal directions.
    """
    where = f"{Path(log.source).name} IMU{log.instance}" if log.source else f"IMU{log.instance}"
    return _assess(log.time_s, log.temperature_c, log.accel_g, log.gyro_rad_s, where,
                   replace(settings or QualitySettings(), **overrides))


def assess_measurement(m: Measurement, settings: QualitySettings | None = None, **overrides) -> LogQuality:
    """The same for a single-axis measurement: no ‖a‖ test, no face labels or handling (one axis
    cannot give a direction); stretches' ``gravity_g`` is the axis' mean.

    Parameters
    ----------
    m : Measurement
        Time [s], temperature [°C], output [g].
    settings : QualitySettings, optional
        Thresholds; default :class:`QualitySettings`.
    **overrides
        Fields of the settings replaced [their units].

    Returns
    -------
    LogQuality
        As :func:`assess_log`.
    """
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
    board rotated slowly on a turntable or a sagging mount reads steady σ and ‖a‖); returns their
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
    dt_med = thresholds.sample_dt_s
    rate = temperature_rate_c_per_s(t, T, smooth_s=s.ramp_window_s, method="half_windows") * 60.0  # °C/min
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
