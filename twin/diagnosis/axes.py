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

from twin.diagnosis.compare import compare_measurement
from twin.errors import TwinError
from twin.measurement import ImuLog, Measurement, check, concatenate
from twin.measurement.quality import LogQuality, QualityRow, assess_log, assess_measurement
from twin.model.scenario import LoadedScenario

# a static stretch whose mean departs from the --applied-g value by more than this reads another orientation
# (a MEMS offset, even uncalibrated, is tens of mg; a 6° tilt already makes 0.1 g on a 0-g axis)
APPLIED_TOLERANCE_G = 0.1
# per-axis τ's within this relative spread are called consistent with one thermal path
SHARED_TAU_SPREAD = 0.15


class OrientationError(TwinError):
    """An axis whose applied acceleration is contradicted by the data or cannot be known."""


@dataclass(frozen=True)
class AppliedStretch:
    """A static stretch of one axis: its time span, rows, face label, mean reading and the g applied
    (None: unknown, or excluded as ``reason`` says)."""

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

    ``applied_g`` is per row [g] (NaN where not kept), or None when the orientation is unknown.
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
            value, reason = float(_face_projection(label, col)), f"on the {label} face"
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


def _face_projection(label: str, col: int) -> float:
    """Gravity along axis ``col`` for a board on the face ``label`` (``"-z"`` → (0, 0, −1))."""
    return (1.0 if label[0] == "+" else -1.0) if "xyz".index(label[1]) == col else 0.0


def axis_measurement(log: ImuLog, rows: AxisRows) -> Measurement:
    """The kept rows of one axis as a :class:`Measurement` (one run), with a note of what went."""
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
    a file logging its own applied column is left to that column."""
    if m.applied_known and np.all(m.applied_g == applied_g):
        quality = assess_measurement(m)
        if quality.static_stretches():
            axis_rows(quality, "output", float(applied_g), column=0, tolerance_g=tolerance_g)


@dataclass(frozen=True, eq=False)
class AxisDiagnoses:
    """Per-axis diagnoses of one IMU, with the orientation used, the rows compared and the joint finding."""

    instance: int
    device_id: int | None
    diagnoses: dict  # axis → Diagnosis
    results: dict  # axis → JSON result
    applied_g: dict  # axis → g, "unknown" or "per stretch"
    finding: str
    rows: dict  # axis → tuple of AxisRows, one per log
    qualities: tuple[LogQuality, ...] = ()

    def json(self) -> dict:
        import json

        stretches = {a: [vars(s) for r in rows for s in r.stretches] for a, rows in self.rows.items()}
        return {"instance": self.instance, "device_id": self.device_id,
                "orientation_applied_g": self.applied_g, "orientation_per_stretch": stretches,
                "log_quality": [json.loads(q.to_json()) for q in self.qualities],
                "finding": self.finding, "axes": self.results}


def joint_finding(results: dict) -> str:
    """One sentence per effect named on more than one axis, with its τ per axis and whether they agree."""
    named: dict[str, list[tuple[str, dict]]] = {}
    for axis, r in results.items():
        for c in r["candidates"]:
            if c["effect"] in r["selected"][:1]:
                named.setdefault(c["effect"], []).append((axis, c.get("parameters_refined") or c["parameters"]))
    parts = []
    for effect, hits in named.items():
        axes = ", ".join(a for a, _ in hits)
        taus = [p["tau_s"] for _, p in hits if "tau_s" in p]
        if len(hits) > 1 and len(taus) == len(hits):
            spread = (max(taus) - min(taus)) / np.median(taus)
            agree = ("consistent with one thermal path" if spread <= SHARED_TAU_SPREAD else
                     f"they differ by {100 * spread:.0f} %: not one thermal path, or the data cannot fix τ")
            what = "the die lags the sensor" if effect == "thermal_lag" else f"{effect}, τ"
            parts.append(f"{what} by ≈{' / '.join(f'{t:.0f}' for t in taus)} s on {axes} ({agree}).")
        else:
            parts.append(f"{effect} named on {axes}.")
    return " ".join(parts) or "No effect is named on any axis."


def compare_imu(loaded: LoadedScenario, logs: list[ImuLog], axes: list[str], with_effects: list[str],
                average_s: float = 10.0, applied_g: float | str | None = None) -> AxisDiagnoses:
    """Compare each axis of one IMU (its logs = runs) with the twin, on the usable static rows.

    ``applied_g``: a number for every axis (refused where a static stretch reads otherwise),
    ``"unknown"``, or None to take each static stretch's orientation from its face (:func:`axis_rows`).
    """
    qualities = tuple(assess_log(log) for log in logs)
    diagnoses, results, applied, used = {}, {}, {}, {}
    for a in axes:
        used[a] = tuple(axis_rows(q, a, applied_g) for q in qualities)
        parts = [axis_measurement(log, r) for log, r in zip(logs, used[a])]
        m = concatenate(parts) if len(parts) > 1 else parts[0]
        values = {s.applied_g for r in used[a] for s in r.stretches if s.applied_g is not None}
        applied[a] = ("unknown" if not m.applied_known else values.pop() if len(values) == 1 else "per stretch")
        diagnoses[a], results[a] = compare_measurement(loaded, m, with_effects, average_s)
    return AxisDiagnoses(logs[0].instance, logs[0].device_id, diagnoses, results, applied, joint_finding(results),
                         used, qualities)
