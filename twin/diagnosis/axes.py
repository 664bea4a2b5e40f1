"""Three axes and several IMUs in one diagnosis.

One IMU's axes share a die, a temperature sensor and the lag between them, so a thermal effect
named on several axes should come with one time constant: the joint finding says whether the
per-axis estimates agree. Orientation comes from the data when it was not logged: in a static
log each axis reads the gravity projection, which is ±1 g or 0 g for a board on a face.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from twin.diagnosis.compare import compare_measurement
from twin.measurement import ImuLog, concatenate
from twin.model.scenario import LoadedScenario

# an axis whose median reading lies this close to −1, 0 or +1 g is taken to sit in that orientation
ORIENTATION_TOLERANCE_G = 0.15
# per-axis τ's within this relative spread are called consistent with one thermal path
SHARED_TAU_SPREAD = 0.15


def gravity_projection_g(accel_g: np.ndarray) -> list[float | None]:
    """Per axis: −1, 0 or +1 g when the median reading is within the tolerance of it, else None."""
    out = []
    for med in np.median(np.asarray(accel_g, float), axis=0):
        k = float(np.round(med))
        out.append(k if abs(k) <= 1 and abs(med - k) < ORIENTATION_TOLERANCE_G else None)
    return out


@dataclass(frozen=True, eq=False)
class AxisDiagnoses:
    """Per-axis diagnoses of one IMU, with the orientation used and the joint finding."""

    instance: int
    device_id: int | None
    diagnoses: dict  # axis → Diagnosis
    results: dict  # axis → JSON result
    applied_g: dict  # axis → g or None (unknown)
    finding: str

    def json(self) -> dict:
        return {"instance": self.instance, "device_id": self.device_id,
                "orientation_applied_g": {a: ("unknown" if g is None else g) for a, g in self.applied_g.items()},
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
    """Compare each axis of one IMU (its logs = runs) with the twin.

    ``applied_g``: a number for every axis, ``"unknown"``, or None to take each axis' orientation
    from the data (:func:`gravity_projection_g`; unknown where no face orientation fits).
    """
    if applied_g is None:
        detected = gravity_projection_g(np.concatenate([log.accel_g for log in logs]))
        applied = {a: detected[("x", "y", "z").index(a)] for a in axes}
    else:
        applied = {a: None if applied_g == "unknown" else float(applied_g) for a in axes}
    diagnoses, results = {}, {}
    for a in axes:
        parts = [log.axis(a, applied[a]) for log in logs]
        m = concatenate(parts) if len(parts) > 1 else parts[0]
        diagnoses[a], results[a] = compare_measurement(loaded, m, with_effects, average_s)
    return AxisDiagnoses(logs[0].instance, logs[0].device_id, diagnoses, results, applied, joint_finding(results))
