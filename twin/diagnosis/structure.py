"""Where the residual has structure white noise would not make: in temperature, rate or time.

Asked only when the residual stands above the white-noise floor (``HONESTY_RATIO`` in
:mod:`~twin.diagnosis.diagnose`), so the null hypothesis is the one the issue names: white noise
at the floor measured from the data's differences. The residual of the model (plus any named
effects) on 10-s means is grouped one way at a time — 5 °C temperature bins, heating / cooling /
dwell, the temperature bins split by direction (the hysteresis view, only when the data both heat
and cool: :func:`both_directions`), one-hour chunks of each run —
and the between-group sum of squares is compared with χ²(G − 1) at that floor (one-way ANOVA with
known variance), Bonferroni over the groupings. An AR noise model is deliberately not used here:
fitted to a smooth residual it learns the structure and whitens it away. A grouping is *structure*
when p_adj < 0.01; its size is the RMS of the group means, and the finding quotes the group that
departs most.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from twin.arrays import temperature_rate_c_per_s
from twin.estimation.fit import TwinFit
from twin.estimation.problem import Problem
from twin.estimation.tails import chi2_survival
from twin.diagnosis.screen import CandidateResult
from twin.measurement.quality import thermal_directions

BIN_C = 5.0
CHUNK_S = 3600.0
RATE_DWELL_C_PER_MIN = 0.1


@dataclass(frozen=True)
class Structure:
    """Where the residual has structure white noise would not make.

    Attributes
    ----------
    grouping : str
        ``temperature``, ``rate``, ``temperature_direction`` or ``time``.
    delta_bic, p_adjusted : float
        Evidence for the group means against noise alone [1].
    rms_g : float
        RMS of the fitted group means [g].
    where : str
        The group that departs most.
    departure_g : float
        Its fitted mean [g].
    """

    grouping: str
    delta_bic: float
    p_adjusted: float
    rms_g: float
    where: str
    departure_g: float


def _groups(problem: Problem, cal: TwinFit) -> dict[str, tuple[np.ndarray, list[str]]]:
    avg = problem.avg
    temp = avg(cal.inputs.die_c)
    t = avg(problem.m.time_s)
    runs = problem.run_avg
    rate = temperature_rate_c_per_s(t, temp, runs) * 60.0  # °C/min of the block means
    tb = np.floor(temp / BIN_C).astype(int)
    rate_g = np.where(rate > RATE_DWELL_C_PER_MIN, 0, np.where(rate < -RATE_DWELL_C_PER_MIN, 1, 2))
    first = {r: t[runs == r][0] for r in np.unique(runs)}
    t0 = np.array([first[r] for r in runs])
    chunk = runs * 10_000 + ((t - t0) // CHUNK_S).astype(int)
    loop = tb * 3 + rate_g
    groups = {
        "temperature": (tb, [f"{b * BIN_C:g}–{(b + 1) * BIN_C:g} °C" for b in np.unique(tb)]),
        "rate": (rate_g, [("heating", "cooling", "dwells")[g] for g in np.unique(rate_g)]),
        "temperature_direction": (loop, [f"{(v // 3) * BIN_C:g}–{(v // 3 + 1) * BIN_C:g} °C, "
                                         f"{('heating', 'cooling', 'dwell')[v % 3]}" for v in np.unique(loop)]),
        "time": (chunk, [f"run {c // 10_000}, hour {c % 10_000 + 1}" for c in np.unique(chunk)]),
    }
    if not both_directions(problem):  # heating against cooling at one temperature needs both in the data
        del groups["temperature_direction"]
    return groups


def both_directions(problem: Problem) -> bool:
    """Whether the compared rows both heat and cool, as the log-quality stage counts them (≥ 1 °C each
    way at > 0.05 °C/min): without both, no grouping or sentence sets heating against cooling.

    Parameters
    ----------
    problem : Problem
        Its measurement's time [s] and temperature [°C].

    Returns
    -------
    bool
        Both heating and cooling are present.
    """
    d = thermal_directions(problem.m.time_s, problem.m.temperature_c)
    return d.has_heating and d.has_cooling


def residual_structure(problem: Problem, cal: TwinFit, selected: list[CandidateResult],
                       floor_g: float, extra_full: np.ndarray | None = None) -> list[Structure]:
    """Groupings in which the residual departs from white noise at the floor; see the module docstring.

    Parameters
    ----------
    problem, cal : Problem, TwinFit
    selected : list of CandidateResult
        Named effects, part of the model here.
    floor_g : float
        Per-sample white-noise σ from the data [g].
    extra_full : np.ndarray, optional
        More full-rate columns (a discovered term).

    Returns
    -------
    list of Structure
        Significant groupings, largest first.
    """
    cfg = problem.config
    cols = [cal.X_full] + [c.columns_full for c in selected if c.columns_full is not None]
    if extra_full is not None:
        cols.append(extra_full.reshape(problem.n, -1))
    J = problem.avg(np.column_stack(cols))
    y = problem.avg(problem.y - cal.fixed_full)
    r = y - J @ np.linalg.lstsq(J, y, rcond=None)[0]
    var = floor_g ** 2 / problem.avg.lengths  # variance of each block mean under white noise at the floor
    groups = _groups(problem, cal)
    found = []
    for name, (g, labels) in groups.items():
        levels, inv = np.unique(g, return_inverse=True)
        if levels.size < 2:
            continue
        w = 1.0 / var
        sw = np.bincount(inv, weights=w)
        means = np.bincount(inv, weights=w * r) / sw
        grand = float(np.sum(w * r) / np.sum(w))
        chi2 = float(np.sum(sw * (means - grand) ** 2))
        p_adj = min(1.0, float(chi2_survival(levels.size - 1, chi2)) * len(groups))
        dbic = chi2 - (levels.size - 1) * np.log(r.size)  # group means against white noise at the floor
        if p_adj < cfg.alpha and dbic > cfg.min_delta_bic:
            dev = means - grand
            i = int(np.argmax(np.abs(dev)))
            counts = np.bincount(inv)
            rms = float(np.sqrt(np.average(dev ** 2, weights=counts)))
            found.append(Structure(name, float(dbic), p_adj, rms, labels[i], float(dev[i])))
    return sorted(found, key=lambda s: -s.delta_bic)
