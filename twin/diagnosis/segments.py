"""Where the model fails (docs/diagnosis.md §1 step 2): the residual split by segment, run,
orientation and temperature bin, and the hysteresis loop area."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from twin.arrays import temperature_rate_c_per_s
from twin.estimation.problem import Problem


@dataclass(frozen=True)
class ResidualSplit:
    """The residual RMS [g] by group, as the compare JSON's ``residual``.

    Attributes
    ----------
    segment : dict of str to float
        ``dwell``, ``heating``, ``cooling`` (those present) → RMS [g].
    run : dict of str to float
        Run number → RMS [g].
    temperature_bin_c : dict of str to float
        5 °C bin (``"20..25"``) → RMS [g].
    loop_area_mg_c : dict of str to float
        Run number → ∮ residual dT, the hysteresis loop area [mg·°C].
    orientation : dict of str to float, optional
        Applied g (``"+1 g"``) → RMS [g]; only when the orientation is known.
    """

    segment: dict[str, float]
    run: dict[str, float]
    temperature_bin_c: dict[str, float]
    loop_area_mg_c: dict[str, float]
    orientation: dict[str, float] | None = None


def segment_kinds(problem: Problem) -> np.ndarray:
    """``"heating"``, ``"cooling"`` or ``"dwell"`` for each row: the die temperature's 60-s mean
    rate beyond ±0.1 °C/min.

    Parameters
    ----------
    problem : Problem

    Returns
    -------
    ndarray of str
    """
    temp = problem.inputs.die_c
    step = 1.0 / problem.rate_hz
    # rows as evenly spaced, smoothed over the whole samples in 60 s and across runs, as the kinds have
    # always been found (per run would relabel the rows beside a joint of two files)
    rate = temperature_rate_c_per_s(step, temp, smooth_s=int(60 * problem.rate_hz) * step)  # °C/s
    return np.where(rate > 0.1 / 60, "heating", np.where(rate < -0.1 / 60, "cooling", "dwell"))


def residual_segments(problem: Problem, residual: np.ndarray, kind: np.ndarray, sumsq: np.ndarray | None = None,
                      counts: np.ndarray | None = None) -> ResidualSplit:
    """Residual RMS per segment type, orientation, run and temperature bin.

    Parameters
    ----------
    problem : Problem
    residual : np.ndarray
        Residual on the problem's rows (the loop area is integrated on it) [g].
    kind : np.ndarray
        :func:`segment_kinds` of the problem.
    sumsq, counts : np.ndarray, optional
        When the rows are block means of a faster log: each row's full-rate Σ residual² and
        sample count, so the RMS are those of the samples.

    Returns
    -------
    ResidualSplit
    """
    m = problem.m
    temp = problem.inputs.die_c
    if sumsq is None:
        rms = lambda mask: float(np.sqrt(np.mean(residual[mask] ** 2))) if np.any(mask) else float("nan")  # noqa: E731
    else:
        rms = lambda mask: float(np.sqrt(sumsq[mask].sum() / counts[mask].sum())) if np.any(mask) else float("nan")  # noqa: E731
    orientation = None
    if m.applied_known:
        orientation = {f"{g:+g} g": rms(np.isclose(problem.applied, g)) for g in np.unique(np.round(problem.applied, 3))}
    bins = np.arange(np.floor(temp.min() / 5) * 5, temp.max() + 5, 5.0)
    which = np.digitize(temp, bins)
    return ResidualSplit(
        segment={k: rms(kind == k) for k in ("dwell", "heating", "cooling") if np.any(kind == k)},
        run={str(r): rms(m.run_index == r) for r in range(m.runs)},
        temperature_bin_c={f"{bins[k - 1]:g}..{bins[k - 1] + 5:g}": rms(which == k)
                           for k in np.unique(which) if 0 < k <= bins.size},
        # loop area: ∮ r dT per run, in mg·°C (heating vs cooling difference)
        loop_area_mg_c={str(r): float(np.sum(residual[m.run_index == r][:-1] * np.diff(temp[m.run_index == r])) * 1e3)
                        for r in range(m.runs)},
        orientation=orientation)
