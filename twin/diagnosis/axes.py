"""Three axes and several IMUs in one diagnosis.

One IMU's axes share a die, a temperature sensor and the lag between them, so a thermal effect
named on several axes should come with one time constant: the joint finding says whether the
per-axis estimates agree. Which rows are compared, and the gravity applied on each, come from the
log-quality stage (:mod:`twin.measurement.quality`): only usable static rows are compared (moving,
handling, gaps, clipping and temperature faults are dropped, with the reason in the result), and
each static stretch gets its own applied g — from ``--applied-g`` when given (refused when the
stretch's mean reads otherwise), else from the face the stretch lies on (a log at −1 g then +1 g
gets each on its rows). An axis nobody gave an orientation for and whose stretches lie on no face
is refused, never absorbed into an offset.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from twin.diagnosis.compare import diagnose_measurement
from twin.diagnosis.diagnose import Diagnosis
from twin.errors import TwinError
from twin.measurement import ImuLog, Measurement, check, concatenate
from twin.measurement.log_quality import LogQuality
from twin.measurement.quality import assess_log, assess_measurement, face_gravity
from twin.measurement.quality_records import QualityRow
from twin.model.scenario import LoadedScenario

# a static stretch whose mean departs from the --applied-g value by more than this reads another orientation
# (a MEMS offset, even uncalibrated, is tens of mg; a 6° tilt already makes 0.1 g on a 0-g axis)
APPLIED_TOLERANCE_G = 0.1
# per-axis τ's within this relative spread are called consistent with one thermal path
SHARED_TAU_SPREAD = 0.15


def tau_spread(taus: list[float]) -> float:
    """Relative spread of per-axis time constants: (max − min) / median [1].

    Parameters
    ----------
    taus : list of float
        One τ per axis [s].

    Returns
    -------
    float
        One thermal path when at most ``SHARED_TAU_SPREAD``.
    """
    return float((max(taus) - min(taus)) / np.median(taus))


class OrientationError(TwinError):
    """An axis whose applied acceleration is contradicted by the data or cannot be known."""


@dataclass(frozen=True)
class AppliedStretch:
    """A static stretch of one axis: its time span, rows, face label, mean reading and the g applied.

    Attributes
    ----------
    from_s, to_s : float
        Start and end of the stretch [s].
    rows : int
        Samples in the stretch.
    label : str
        Face label (``+x`` … ``-z``, ``tilted`` or ``""``).
    measured_g : float
        Mean reading of the axis [g].
    applied_g : float or None
        Gravity applied [g]; None: unknown, or excluded as ``reason`` says.
    reason : str
        Where ``applied_g`` came from, or why the stretch was excluded.
    """

    from_s: float
    to_s: float
    rows: int
    label: str
    measured_g: float
    applied_g: float | None
    reason: str


@dataclass(frozen=True, eq=False)
class AxisRows:
    """The rows of one axis of one log that enter the comparison and the gravity applied on each.

    Attributes
    ----------
    axis : str
        ``x``, ``y``, ``z`` (or ``output`` for a single-axis measurement).
    keep : numpy.ndarray of bool
        Per usable static row: compared.
    applied_g : numpy.ndarray or None
        Per row [g] (NaN where not kept), or None when the orientation is unknown.
    stretches : tuple of AppliedStretch
        Each static stretch and the g applied on it.
    excluded : tuple of QualityRow
        The log's rows not used, with the reason.
    """

    axis: str
    keep: np.ndarray
    applied_g: np.ndarray | None
    stretches: tuple[AppliedStretch, ...]
    excluded: tuple[QualityRow, ...]


def _g(x: float) -> str:
    """A reading in g with a true minus sign, as the messages quote it."""
    return f"{x:+.2f}".replace("-", "−") + " g"


def axis_rows(quality: LogQuality, axis: str, applied_g: float | str | None, column: int | None = None,
              tolerance_g: float = APPLIED_TOLERANCE_G) -> AxisRows:
    """Which rows of ``axis`` to compare and with what applied g, from the quality stage.

    Parameters
    ----------
    quality : LogQuality
    axis : {"x", "y", "z"}
    applied_g : float, "unknown" or None
        A value given for every row (checked against each static stretch's mean), unknown, or
        None: each stretch's face decides (stretches off every face are dropped).
    column : int, optional
        Index of the axis in the stretches' ``gravity_g`` (default: x, y, z → 0, 1, 2).

    Raises
    ------
    OrientationError
        A given value that a static stretch contradicts by more than ``tolerance_g``; no
        orientation given and none estimable; no usable static stretch at all.

    Returns
    -------
    AxisRows
        The rows kept and the applied g [g] per row and per stretch.
    """
    col = "xyz".index(axis) if column is None else column
    where = f"{quality.where} {axis}"
    static = quality.static_stretches()
    if not static:
        raise OrientationError(f"{where}: no static stretch of the log to compare ({quality.summary()})")
    n = quality.usable_static.size
    known = applied_g != "unknown"
    applied = np.full(n, np.nan)
    keep = np.zeros(n, bool)
    out = []
    for s in static:
        read = s.gravity_g[col]
        label = s.label or ""
        if isinstance(applied_g, (int, float)):
            if abs(read - applied_g) > tolerance_g:
                raise OrientationError(f"{where}: --applied-g {applied_g:g} but the static rows at {s.t0_s:.0f}–"
                                       f"{s.t1_s:.0f} s read {_g(read)} (tolerance {tolerance_g:g} g); give the "
                                       "orientation of those rows, or --applied-g unknown")
            value, reason = float(applied_g), "given (--applied-g)"
        elif not known:
            value, reason = None, "orientation unknown (--applied-g unknown)"
        elif label in ("", "tilted"):
            value, reason = None, f"excluded: gravity off every face ({label or 'one axis'}), orientation not given"
        else:
            value, reason = float(face_gravity(label)[col]) + 0.0, f"on the {label} face"  # + 0.0: no "−0 g"
        use = value is not None or not known
        keep[s.start:s.stop] = use
        applied[s.start:s.stop] = np.nan if value is None else value
        out.append(AppliedStretch(s.t0_s, s.t1_s, s.stop - s.start, label, float(read), value, reason))
    if not keep.any():
        g = ", ".join(_g(v) for v in static[0].gravity_g)
        raise OrientationError(f"{where}: orientation not given and not estimable: {len(static)} static stretch(es), "
                               f"none on a face (the first reads {g}); give --applied-g VALUE or unknown")
    excluded = tuple(r for r in quality.table_rows() if not r.used)
    return AxisRows(axis, keep, applied if known else None, tuple(out), excluded)


def axis_measurement(log: ImuLog, rows: AxisRows) -> Measurement:
    """The kept rows of one axis as a :class:`Measurement` (one run), with a note of what went.

    Parameters
    ----------
    log : ImuLog
        Time [s], temperature [°C], acceleration [g].
    rows : AxisRows
        The rows to keep and their applied g [g].

    Returns
    -------
    Measurement
        The axis' output [g] on the kept rows, checked.
    """
    k = rows.keep
    col = log.accel_g[:, "xyz".index(rows.axis)]
    known = rows.applied_g is not None
    applied = rows.applied_g[k] if known else np.full(int(k.sum()), np.nan)
    dropped = sum(r.duration_s for r in rows.excluded)
    note = (f"{log.source} IMU{log.instance} {rows.axis}: {int(k.sum())} of {k.size} rows compared; "
            f"{dropped:.0f} s excluded (" + ", ".join(sorted({r.kind for r in rows.excluded})) + ")"
            if rows.excluded or not k.all() else "")
    m = Measurement(log.time_s[k].astype(float), log.temperature_c[k].astype(float), col[k].astype(float), applied,
                    np.zeros(int(k.sum()), np.int16), np.zeros(int(k.sum()), bool), known, [log.source], 0,
                    list(log.notes) + ([note] if note else []))
    check(m, f"{log.source} (instance {log.instance}, axis {rows.axis}, usable static rows)")
    return m


def check_applied_measurement(m: Measurement, applied_g: float, tolerance_g: float = APPLIED_TOLERANCE_G) -> None:
    """Refuse a single-axis ``--applied-g`` that a static stretch of ``m`` contradicts (see :func:`axis_rows`);
    a file logging its own applied column is left to that column.

    Parameters
    ----------
    m : Measurement
    applied_g, tolerance_g : float
        The value given and the largest departure of a stretch's mean from it [g].

    Raises
    ------
    OrientationError
        A static stretch reads otherwise.
    """
    if m.applied_known and np.all(m.applied_g == applied_g):
        quality = assess_measurement(m)
        if quality.static_stretches():
            axis_rows(quality, "output", float(applied_g), column=0, tolerance_g=tolerance_g)


@dataclass(frozen=True, eq=False)
class AxisDiagnoses:
    """Per-axis diagnoses of one IMU, with the orientation used and the rows compared.

    Attributes
    ----------
    instance : int
    device_id : int or None
    diagnoses : dict of str to Diagnosis
    applied_g : dict of str to float or str
        Axis → g applied, ``unknown`` or ``per stretch``.
    rows : dict of str to tuple of AxisRows
        Axis → the rows of each log compared.
    qualities : tuple of LogQuality
        Each log's quality assessment.
    """

    instance: int
    device_id: int | None
    diagnoses: dict[str, Diagnosis]
    applied_g: dict[str, float | str]
    rows: dict[str, tuple[AxisRows, ...]]
    qualities: tuple[LogQuality, ...] = ()


def compare_imu(loaded: LoadedScenario, logs: list[ImuLog], axes: list[str], with_effects: list[str],
                average_s: float = 10.0, applied_g: float | str | None = None) -> AxisDiagnoses:
    """Compare each axis of one IMU (its logs = runs) with the twin, on the usable static rows.

    Parameters
    ----------
    loaded : LoadedScenario
        The scenario's twin.
    logs : list of ImuLog
        The IMU's logs, one run each.
    axes : list of str
        Axes to compare (``x``, ``y``, ``z``).
    with_effects : list of str
        Library effects added to the twin.
    average_s : float
        Screening block length [s].
    applied_g : float, "unknown" or None
        A number for every axis [g] (refused where a static stretch reads otherwise), ``"unknown"``,
        or None to take each static stretch's orientation from its face (:func:`axis_rows`).

    Returns
    -------
    AxisDiagnoses
        One diagnosis per axis, the orientation used and the rows compared.
    """
    qualities = tuple(assess_log(log) for log in logs)
    diagnoses, applied, used = {}, {}, {}
    for a in axes:
        used[a] = tuple(axis_rows(q, a, applied_g) for q in qualities)
        parts = [axis_measurement(log, r) for log, r in zip(logs, used[a])]
        m = concatenate(parts) if len(parts) > 1 else parts[0]
        values = {s.applied_g for r in used[a] for s in r.stretches if s.applied_g is not None}
        applied[a] = ("unknown" if not m.applied_known else values.pop() if len(values) == 1 else "per stretch")
        diagnoses[a] = diagnose_measurement(loaded, m, with_effects, average_s)
    return AxisDiagnoses(logs[0].instance, logs[0].device_id, diagnoses, applied, used, qualities)
