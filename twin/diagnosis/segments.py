"""Where the model fails (diagnosis-methods §1 step 3): the residual split by segment, run,
orientation and temperature bin, and the hysteresis loop area."""

from __future__ import annotations

import numpy as np
from scipy.ndimage import uniform_filter1d

from twin.diagnosis.problem import Problem


def residual_segments(problem: Problem, residual: np.ndarray) -> dict:
    """Residual RMS per segment type, orientation, run and temperature bin.

    Parameters
    ----------
    problem : Problem
    residual : np.ndarray
        Full-rate residual.

    Returns
    -------
    dict
        ``segment``, ``run``, ``orientation`` (when known), ``temperature_bin_c``: RMS [g];
        ``loop_area_mg_c`` per run; ``kind``: the segment of each sample.
    """
    m = problem.m
    temp = problem.inputs.die_c
    rate = np.gradient(uniform_filter1d(temp, max(1, int(60 * problem.rate_hz)), mode="nearest")) * problem.rate_hz
    kind = np.where(rate > 0.1 / 60, "heating", np.where(rate < -0.1 / 60, "cooling", "dwell"))
    rms = lambda x: float(np.sqrt(np.mean(x * x))) if x.size else float("nan")  # noqa: E731
    out = {"segment": {k: rms(residual[kind == k]) for k in ("dwell", "heating", "cooling") if np.any(kind == k)},
           "run": {str(r): rms(residual[m.run_index == r]) for r in range(m.runs)}}
    if m.applied_known:
        out["orientation"] = {f"{g:+g} g": rms(residual[np.isclose(problem.applied, g)])
                              for g in np.unique(np.round(problem.applied, 3))}
    bins = np.arange(np.floor(temp.min() / 5) * 5, temp.max() + 5, 5.0)
    which = np.digitize(temp, bins)
    out["temperature_bin_c"] = {f"{bins[k - 1]:g}..{bins[k - 1] + 5:g}": rms(residual[which == k])
                                for k in np.unique(which) if 0 < k <= bins.size}
    # loop area: ∮ r dT per run, in mg·°C (heating vs cooling difference)
    out["loop_area_mg_c"] = {str(r): float(np.sum(residual[m.run_index == r][:-1] * np.diff(temp[m.run_index == r])) * 1e3)
                             for r in range(m.runs)}
    out["kind"] = kind
    return out
