"""Three-axis devices (``device.axes``): gravity per axis, the per-axis dataset keys, and the
columns a three-axis calibration reads.

A three-axis dataset keeps every common array of the one-axis layout (time, program,
temperatures, runs, power) and stores the per-axis ones under per-axis names (:data:`AXIS_LAYOUT`,
``<a>`` = x, y, z): still one-dimensional on the common time base. The die and the thermometer are
shared by the axes (one thermal path); effects, zero-g offsets and noise streams are per axis.
"""

from __future__ import annotations

import numpy as np

from twin.model.dataset import LAYOUT, Dataset
from twin.model.plan import TestPlanSection
from twin.model.sections import AXES

#: one-axis path → its per-axis template (``<a>`` = x, y or z); ``truth/*`` → ``truth/<a>/*``
_RENAMED = {
    "test/applied_g": ("test/gravity_<a>_g", "gravity along axis <a>: the acceleration applied to it (orientation)"),
    "output/output_g": ("output/accel_<a>_g", "axis <a> output as logged (quantised)"),
    "output/output_digits": ("output/accel_<a>_digits", "axis <a> 12-bit output in digits (raw register >> 4)"),
}

#: per-axis paths of a three-axis dataset → (units, description); ``truth/<a>/effects/<name>_g`` per effect
AXIS_LAYOUT: dict[str, tuple[str, str]] = {
    **{t: (LAYOUT[p][0], d) for p, (t, d) in _RENAMED.items()},
    **{f"truth/<a>/{p[len('truth/'):]}": (u, f"axis <a>: {d}") for p, (u, d) in LAYOUT.items() if p.startswith("truth/")},
    "truth/<a>/effects/<name>_g": ("g", "axis <a>: contribution of effect <name> to the output"),
}


def axis_path(path: str, axis: str) -> str:
    """Where the one-axis array ``path`` of axis ``axis`` is stored in a three-axis dataset.

    Parameters
    ----------
    path : str
        One-axis dataset path (``test/applied_g``, ``output/*`` or ``truth/*``).
    axis : str
        ``"x"``, ``"y"`` or ``"z"``.

    Returns
    -------
    str
        The per-axis path.
    """
    if path in _RENAMED:
        return _RENAMED[path][0].replace("<a>", axis)
    if path.startswith("truth/"):
        return f"truth/{axis}/{path[len('truth/'):]}"
    raise KeyError(f"{path!r} is not a per-axis array")


def axis_description(description: str, axis: str) -> str:
    """A one-axis array's description, for axis ``axis``.

    Parameters
    ----------
    description : str
        The one-axis description.
    axis : str
        ``"x"``, ``"y"`` or ``"z"``.

    Returns
    -------
    str
        ``"axis <axis>: <description>"``.
    """
    return f"axis {axis}: {description}"


def gravity_g(test_plan: TestPlanSection, t_run: np.ndarray) -> np.ndarray:
    """Gravity seen by the axes x, y, z at ``t_run`` [g], (n, 3), from the test plan
    (``six_position`` or ``orientations`` with ``gravity_g``).

    Orientations step at their ``at_s``. Six-position blocks begin with a turn of ``turn_s``: the
    gravity vector rotates at a constant rate along the great circle from the previous position
    (a half turn, between opposite positions, goes through the next axis), so |g| = 1 throughout
    and a static-segment detector sees the move.

    Parameters
    ----------
    test_plan : TestPlanSection
        The scenario's test plan.
    t_run : ndarray
        Times within the run [s].

    Returns
    -------
    ndarray
        Gravity along x, y, z, shape (n, 3) [g].

    References
    ----------
    Rotation along a great circle (spherical linear interpolation), a standard result.
    """
    at_s, vectors = test_plan.gravity_schedule(float(t_run[-1]))
    v = np.asarray(vectors, float)
    idx = np.clip(np.searchsorted(np.asarray(at_s), t_run, side="right") - 1, 0, len(v) - 1)
    turn_s = test_plan.six_position.turn_s if test_plan.six_position is not None else 0.0
    if turn_s <= 0 or len(v) < 2:
        return v[idx]
    start, end = v[np.maximum(idx - 1, 0)], v[idx]
    frac = np.where(idx > 0, np.clip((t_run - np.asarray(at_s)[idx]) / turn_s, 0.0, 1.0), 1.0)
    cos_omega = np.clip(np.sum(start * end, axis=1), -1.0, 1.0)
    omega = np.arccos(cos_omega)
    normal = end - cos_omega[:, None] * start  # towards the end position, orthogonal to the start
    half = np.linalg.norm(normal, axis=1) < 1e-9
    normal[half] = np.roll(start[half], 1, axis=1)  # opposite positions: turn through the next axis
    normal /= np.maximum(np.linalg.norm(normal, axis=1), 1e-300)[:, None]
    angle = (frac * omega)[:, None]
    return np.where((frac >= 1.0)[:, None], end, np.cos(angle) * start + np.sin(angle) * normal)


def is_three_axis(ds: Dataset) -> bool:
    """Whether ``ds`` is a three-axis dataset (has ``output/accel_x_g``).

    Parameters
    ----------
    ds : Dataset
        The dataset.

    Returns
    -------
    bool
        True for a three-axis dataset.
    """
    return "output/accel_x_g" in ds.arrays


def stack(ds: Dataset, template: str) -> np.ndarray:
    """The per-axis arrays of ``template`` (e.g. ``"output/accel_<a>_g"``) as one (n, 3) array.

    Parameters
    ----------
    ds : Dataset
        A three-axis dataset.
    template : str
        Path with ``<a>`` for the axis.

    Returns
    -------
    ndarray
        Columns x, y, z [units of the arrays].
    """
    return np.column_stack([ds[template.replace("<a>", a)] for a in AXES])


def imu_log_fields(ds: Dataset) -> dict:
    """The logged columns of a three-axis dataset as the keyword arguments of
    :class:`twin.measurement.ImuLog` (``ImuLog(**imu_log_fields(ds))``): time, the thermometer
    reading as the temperature, the three outputs (n, 3). No truth. (A function of this layer
    cannot build the ``ImuLog`` itself: measurement sits above the model.)

    Parameters
    ----------
    ds : Dataset
        A three-axis dataset.

    Returns
    -------
    dict
        ``time_s`` [s], ``temperature_c`` [°C], ``accel_g`` (n, 3) [g] and the log's metadata.
    """
    if not is_three_axis(ds):
        raise KeyError("not a three-axis dataset (no output/accel_x_g): simulate a scenario with device.axes")
    return {"time_s": ds["time_s"].astype(float), "temperature_c": ds["temperature/thermometer_c"].astype(float),
            "accel_g": stack(ds, "output/accel_<a>_g"), "instance": 0, "device_id": None,
            "source": str(ds.attrs.get("scenario_path", "") or "<dataset>"),
            "notes": (f"simulated three-axis dataset, seed {ds.attrs.get('seed')}, {int(ds.attrs.get('runs', 1))} run(s)",)}


def summary_fields(ds: Dataset) -> dict:
    """Drift and output statistics of a three-axis dataset, over all axes (``twin run --json``).

    Parameters
    ----------
    ds : Dataset
        A three-axis dataset.

    Returns
    -------
    dict
        ``axes``, ``drift_range_mg`` [mg], ``output_rms_minus_truth_mg`` [mg], ``saturated_samples``.
    """
    drift = stack(ds, "truth/<a>/drift_g")
    err = stack(ds, "output/accel_<a>_g") - stack(ds, "test/gravity_<a>_g") - drift
    return {
        "axes": list(AXES),
        "drift_range_mg": [float(drift.min() * 1e3), float(drift.max() * 1e3)],
        "output_rms_minus_truth_mg": float(np.sqrt(np.mean(err**2)) * 1e3),
        "saturated_samples": int(np.count_nonzero(stack(ds, "truth/<a>/saturated").any(axis=1))),
    }
