"""Where the model fails (docs/diagnosis.md §1 step 2): the residual split by segment, run,
orientation and temperature bin, and the hysteresis loop area."""

from __future__ import annotations

import numpy as np
from scipy.ndimage import uniform_filter1d

from twin.diagnosis.problem import Problem


def residual_segments(problem: Problem, residual: np.ndarray, sumsq: np.ndarray | None = None,
                      counts: np.ndarray | None = None) -> dict:
    """Residual RMS per segment type, orientation, run and temperature bin.

    Parameters
    ----------
    problem : Problem
    residual : np.ndarray
        Residual on the problem's rows (the loop area is integrated on it).
    sumsq, counts : np.ndarray, optional
        When the rows are block means of a faster log: each row's full-rate Σ residual² and
        sample count, so the RMS are those of the samples.

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
    if sumsq is None:
        rms = lambda mask: float(np.sqrt(np.mean(residual[mask] ** 2))) if np.any(mask) else float("nan")  # noqa: E731
    else:
        rms = lambda mask: float(np.sqrt(sumsq[mask].sum() / counts[mask].sum())) if np.any(mask) else float("nan")  # noqa: E731
    out = {"segment": {k: rms(kind == k) for k in ("dwell", "heating", "cooling") if np.any(kind == k)},
           "run": {str(r): rms(m.run_index == r) for r in range(m.runs)}}
    if m.applied_known:
        out["orientation"] = {f"{g:+g} g": rms(np.isclose(problem.applied, g))
                              for g in np.unique(np.round(problem.applied, 3))}
    bins = np.arange(np.floor(temp.min() / 5) * 5, temp.max() + 5, 5.0)
    which = np.digitize(temp, bins)
    out["temperature_bin_c"] = {f"{bins[k - 1]:g}..{bins[k - 1] + 5:g}": rms(which == k)
                                for k in np.unique(which) if 0 < k <= bins.size}
    # loop area: ∮ r dT per run, in mg·°C (heating vs cooling difference)
    out["loop_area_mg_c"] = {str(r): float(np.sum(residual[m.run_index == r][:-1] * np.diff(temp[m.run_index == r])) * 1e3)
                             for r in range(m.runs)}
    out["kind"] = kind
    return out
