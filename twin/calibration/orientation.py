"""Static orientations (six-position or tumble tests) and per-axis offset(T) and scale factor(T).

A static segment is a static stretch of the log-quality stage (:mod:`twin.measurement.quality`:
still by σ, ‖a‖ and the gyro, 2 s cut beside every move); its mean is gravity seen by the sensor.
Segments are clustered by direction into orientations; axis-aligned ones get a label
(``+x`` … ``−z``) and a nominal gravity projection of ±1 g or 0 per axis, which is the truth the
fit ``a = (1 + s(T))·g_true + o(T)`` needs. Gravity is the unit: results are in local g.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.stats import t as student_t

from twin.calibration.models import AXES
from twin.errors import TwinError
from twin.measurement import ImuLog
from twin.measurement.log_quality import LogQuality
from twin.measurement.quality import FACE_LABELS, assess_log, cluster_directions, face_gravity

LABELS = FACE_LABELS


@dataclass(frozen=True)
class StaticSegment:
    """Samples ``start:stop`` held still: their mean [g], spread [mg], temperature and direction.

    Attributes
    ----------
    start, stop : int
        Row range of the segment.
    mean_g, std_mg : tuple of 3 floats
        Per-axis mean [g] and standard deviation [mg].
    temperature_c : float
        Mean temperature [°C].
    duration_s : float
        Length [s].
    """

    start: int
    stop: int
    mean_g: tuple[float, float, float]
    std_mg: tuple[float, float, float]
    temperature_c: float
    duration_s: float

    @property
    def direction(self) -> np.ndarray:
        """Unit vector of ``mean_g`` [dimensionless]."""
        m = np.asarray(self.mean_g)
        return m / np.linalg.norm(m)


@dataclass(frozen=True)
class Orientation:
    """A cluster of static segments with one gravity direction.

    ``label`` is ``"+x"`` … ``"-z"`` when within the tolerance of a sensor axis, else ``"tilted"``;
    ``nominal_g`` is then the signed unit axis, else the measured direction.

    Attributes
    ----------
    label : str
        Face label or ``"tilted"``.
    direction, nominal_g : tuple of 3 floats
        Measured and nominal gravity direction [g, unit vector].
    segments : tuple of int
        Indices of its static segments.
    temperatures_c : tuple of float
        Mean temperature of each segment [°C].
    """

    label: str
    direction: tuple[float, float, float]
    nominal_g: tuple[float, float, float]
    segments: tuple[int, ...]
    temperatures_c: tuple[float, ...]


@dataclass(frozen=True)
class OrientationReport:
    """Which orientations were found: ``kind`` is "six-position", "tumble" or "partial (k of 6)".

    Attributes
    ----------
    kind : str
        Kind of test.
    orientations : tuple of Orientation
        The clusters found.
    found, missing : tuple of str
        Axis-aligned face labels present and absent.
    """

    kind: str
    orientations: tuple[Orientation, ...]
    found: tuple[str, ...]
    missing: tuple[str, ...]


def detect_static_segments(time_s, accel_g, temperature_c=None, window_s: float = 2.0,
                           max_std_mg: float | None = None, min_duration_s: float = 10.0,
                           max_span_c: float = 2.0) -> list[StaticSegment]:
    """The static stretches of the log-quality stage (:func:`twin.measurement.quality.assess_log`),
    cut where they span more than ``max_span_c``.

    Parameters
    ----------
    time_s, temperature_c : (n,) array-like
        Sample times [s] and temperatures [°C] (``temperature_c`` optional: zero).
    accel_g : (n, 3) array-like
        Readings [g].
    window_s : float
        Moving window [s] for the standard deviation.
    max_std_mg : float, optional
        Static when every axis' moving σ is below this [mg]; default: derived from the log's own
        still noise (median + 6 MAD of the quiet windows, at least 1 mg).
    min_duration_s : float
        Shorter still stretches are ignored (2 s after and before every move are cut first).
    max_span_c : float
        Segments spanning more temperature [°C] are cut, so one mean temperature describes each.

    Returns
    -------
    list of StaticSegment
        The segments, in time order.
    """
    t = np.asarray(time_s, float)
    a = np.asarray(accel_g, float)
    T = np.zeros(t.size) if temperature_c is None else np.asarray(temperature_c, float)
    if a.shape != (t.size, 3) or t.size < 8:
        raise TwinError(f"accel_g must be (n, 3) with n = {t.size} ≥ 8; got {a.shape}")
    quality = assess_log(ImuLog(t, T, a), window_s=window_s, sigma_mg=max_std_mg, min_static_s=min_duration_s)
    return segments_of(quality, t, T, a, min_duration_s, max_span_c)


def segments_of(quality: LogQuality, time_s, temperature_c, accel_g, min_duration_s: float = 10.0,
                max_span_c: float = 2.0) -> list[StaticSegment]:
    """The static stretches of an assessed log as segments, each cut where it spans more than
    ``max_span_c`` and kept when it still lasts ``min_duration_s``.

    Parameters
    ----------
    quality : LogQuality
        The assessed log.
    time_s, temperature_c : (n,) array-like
        Sample times [s] and temperatures [°C].
    accel_g : (n, 3) array-like
        Readings [g].
    min_duration_s, max_span_c : float
        Shortest segment kept [s]; widest temperature span of one segment [°C].

    Returns
    -------
    list of StaticSegment
        The segments, in time order.
    """
    t, T, a = np.asarray(time_s, float), np.asarray(temperature_c, float), np.asarray(accel_g, float)
    out = []
    for stretch in quality.static_stretches():
        for p0, p1 in cut_by_temperature(T, stretch.start, stretch.stop, max_span_c):
            if p1 - p0 >= 2 and t[p1 - 1] - t[p0] >= min_duration_s:
                seg = a[p0:p1]
                out.append(StaticSegment(int(p0), int(p1), tuple(seg.mean(0)), tuple(seg.std(0) * 1e3),
                                         float(T[p0:p1].mean()), float(t[p1 - 1] - t[p0])))
    return out


FIRST_LOOK = 1024  # rows the search for a piece's end reads first; it doubles while none is found


def cut_by_temperature(T: np.ndarray, s0: int, s1: int, span_c: float) -> list[tuple[int, int]]:
    """Rows ``s0:s1`` cut into pieces, each ending at the first row more than ``span_c`` from the
    temperature of its first row.

    Parameters
    ----------
    T : (n,) ndarray
        Temperatures [°C].
    s0, s1 : int
        The stretch (``s1`` exclusive).
    span_c : float
        Widest temperature span of a piece [°C].

    Returns
    -------
    list of (int, int)
        (start, stop) of each piece, in order, covering ``s0:s1``.
    """
    pieces, start = [], s0
    while start < s1:
        end = _first_beyond(T, start, s1, span_c)
        pieces.append((start, max(end, start + 1)))
        start = max(end, start + 1)
    return pieces


def _first_beyond(T: np.ndarray, start: int, stop: int, span_c: float) -> int:
    """The first row in ``start:stop`` more than ``span_c`` from ``T[start]`` (``stop`` if none),
    read in windows doubling from :data:`FIRST_LOOK` rows: a piece costs its own length, not the
    rest of the stretch (which made a long ramp quadratic in its length: one piece per 2 °C)."""
    pos, width = start, FIRST_LOOK
    while pos < stop:
        hit = np.abs(T[pos:min(pos + width, stop)] - T[start]) > span_c
        if hit.any():
            return pos + int(np.argmax(hit))
        pos, width = pos + width, 2 * width
    return stop


def cluster_orientations(segments: list[StaticSegment], tol_deg: float = 10.0) -> OrientationReport:
    """Group segments whose gravity directions lie within ``tol_deg`` and name the orientations
    (the log-quality stage's clustering, :func:`twin.measurement.quality.cluster_directions`).

    Parameters
    ----------
    segments : list of StaticSegment
        The static segments.
    tol_deg : float
        Clustering tolerance [°].

    Returns
    -------
    OrientationReport
        The orientations and the kind of test.
    """
    clusters = cluster_directions([s.direction for s in segments], tol_deg)
    found = []
    for c, (d, label) in enumerate(zip(clusters.directions, clusters.labels)):
        nominal = tuple(face_gravity(label)) if label != "tilted" else d
        g = tuple(i for i, m in enumerate(clusters.member_of) if m == c)
        found.append(Orientation(label, d, nominal, g, tuple(segments[j].temperature_c for j in g)))
    labels = tuple(o.label for o in found if o.label != "tilted")
    missing = tuple(lab for lab in LABELS if lab not in labels)
    if not missing and len(found) == 6:
        kind = "six-position"
    elif len(found) > 6 or any(o.label == "tilted" for o in found):
        kind = "tumble"
    else:
        kind = f"partial ({6 - len(missing)} of 6)"
    return OrientationReport(kind, tuple(found), labels, missing)


@dataclass(frozen=True, eq=False)
class OffsetScaleFit:
    """Per-axis ``a = (1 + s(T))·g_true + o(T)``, s and o polynomials in ``T − reference_c``.

    Attributes
    ----------
    scale_ppm, offset_mg : (3, degree + 1) arrays
        s_k [ppm/°C^k] and o_k [mg/°C^k]; k = 1 is the tempco (TCSo, TCOff).
    scale_ci95_ppm, offset_ci95_mg : (3, degree + 1, 2) arrays
        95 % intervals (Student t on the segment means' residual).
    residual_rms_mg : (3,) array
    dof : int
    notes : tuple of str
    """

    reference_c: float
    scale_ppm: np.ndarray
    scale_se_ppm: np.ndarray
    scale_ci95_ppm: np.ndarray
    offset_mg: np.ndarray
    offset_se_mg: np.ndarray
    offset_ci95_mg: np.ndarray
    residual_rms_mg: np.ndarray
    dof: int
    notes: tuple[str, ...] = ()


def fit_offset_scale(segments: list[StaticSegment], report: OrientationReport, degree: int = 1,
                     reference_c: float = 25.0) -> OffsetScaleFit:
    """Least squares per axis over the static segments' means (one row per segment).

    Parameters
    ----------
    segments : list of StaticSegment
        The static segments.
    report : OrientationReport
        Their orientations (nominal gravity per segment).
    degree : int
        Degree of s(T) and o(T).
    reference_c : float
        Expansion point [°C].

    Returns
    -------
    OffsetScaleFit
        Scale factor [ppm/°C^k] and offset [mg/°C^k] per axis, with intervals.
    """
    g_true = np.zeros((len(segments), 3))
    for o in report.orientations:
        g_true[list(o.segments)] = o.nominal_g
    y = np.array([s.mean_g for s in segments])
    dT = np.array([s.temperature_c for s in segments]) - reference_c
    P = np.vander(dT, degree + 1, increasing=True)
    n, p = len(segments), 2 * (degree + 1)
    if n <= p:
        raise TwinError(f"{n} static segments cannot fix {p} coefficients per axis; add orientations or temperatures")
    shape = (3, degree + 1)
    est, se = np.full((2,) + shape, np.nan), np.full((2,) + shape, np.nan)
    rms, notes = np.zeros(3), []
    q = student_t.ppf(0.975, n - p)
    for a in range(3):
        F = np.column_stack([P * g_true[:, a:a + 1], P])
        if np.ptp(g_true[:, a]) < 0.5:
            notes.append(f"{AXES[a]}: gravity never changes along this axis, scale factor not identifiable")
            F = P
        coef, *_ = np.linalg.lstsq(F, y[:, a] - g_true[:, a], rcond=None)
        r = y[:, a] - g_true[:, a] - F @ coef
        cov = (r @ r) / (n - F.shape[1]) * np.linalg.pinv(F.T @ F)
        c, s = coef.reshape(-1, degree + 1), np.sqrt(np.diag(cov)).reshape(-1, degree + 1)
        est[2 - c.shape[0]:, a], se[2 - c.shape[0]:, a] = c, s
        rms[a] = np.sqrt(np.mean(r * r)) * 1e3
    units = np.array([1e6, 1e3])[:, None, None]
    est, se = est * units, se * units
    ci = est[..., None] + q * se[..., None] * np.array([-1.0, 1.0])
    return OffsetScaleFit(reference_c, est[0], se[0], ci[0], est[1], se[1], ci[1], rms, n - p, tuple(notes))


def six_position(time_s, accel_g, temperature_c, degree: int = 1, reference_c: float = 25.0,
                 tol_deg: float = 10.0, **detect) -> tuple[OrientationReport, OffsetScaleFit]:
    """Detect, cluster and fit in one call (``detect``: keywords of :func:`detect_static_segments`).

    Parameters
    ----------
    time_s, temperature_c : (n,) array-like
        Sample times [s] and temperatures [°C].
    accel_g : (n, 3) array-like
        Readings [g].
    degree, reference_c, tol_deg
        As in :func:`fit_offset_scale` [°C] and :func:`cluster_orientations` [°].
    **detect
        Keywords of :func:`detect_static_segments`.

    Returns
    -------
    (OrientationReport, OffsetScaleFit)
        The orientations found and the offset/scale fit.
    """
    segments = detect_static_segments(time_s, accel_g, temperature_c, **detect)
    if not segments:
        raise TwinError("no static segment found: lower window_s/min_duration_s or raise max_std_mg")
    report = cluster_orientations(segments, tol_deg)
    return report, fit_offset_scale(segments, report, degree, reference_c)


def orientation_calibration(time_s, temperature_c, accel_g, quality: LogQuality):
    """Orientations found in a log, and per axis offset(T) and scale factor(T) from its static segments.

    Returns None for a log in one orientation. Otherwise (summary for the document, the static rows,
    the nominal gravity of every row, zero off those rows): the firmware methods and the twin are then
    fitted on the static rows with gravity removed, so what they leave is the scale factor they do
    not model.

    Parameters
    ----------
    time_s, temperature_c : ndarray
        [s], [°C].
    accel_g : ndarray
        (n, 3) [g].
    quality : LogQuality

    Returns
    -------
    tuple of (dict, ndarray of bool, ndarray) or None
    """
    segments = segments_of(quality, time_s, temperature_c, accel_g)
    report = cluster_orientations(segments) if segments else None
    if report is None or len(report.orientations) < 2:
        return None
    fit = fit_offset_scale(segments, report, degree=1)
    keep = np.zeros(len(time_s), bool)
    gravity = np.zeros((len(time_s), 3))
    for o in report.orientations:
        for j in o.segments:
            keep[segments[j].start:segments[j].stop] = True
            gravity[segments[j].start:segments[j].stop] = o.nominal_g
    summary = {
        "kind": report.kind, "found": list(report.found), "missing": list(report.missing),
        "static_segments": len(segments), "reference_c": fit.reference_c,
        "tcso_ppm_per_c": {a: {"value": float(fit.scale_ppm[i, 1]), "ci95": list(map(float, fit.scale_ci95_ppm[i, 1]))}
                           for i, a in enumerate(AXES)},
        "tcoff_mg_per_c": {a: {"value": float(fit.offset_mg[i, 1]), "ci95": list(map(float, fit.offset_ci95_mg[i, 1]))}
                           for i, a in enumerate(AXES)},
        "zero_g_offset_mg": {a: float(fit.offset_mg[i, 0]) for i, a in enumerate(AXES)},
        "residual_rms_mg": dict(zip(AXES, map(float, fit.residual_rms_mg))), "notes": list(fit.notes),
    }
    return summary, keep, gravity
