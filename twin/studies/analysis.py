"""A finished study's table (CSV, HDF5) and analysis: main effects, two-factor interactions,
Sobol indices (Saltelli designs). String responses are tabulated; the analysis covers the numeric
ones."""

from __future__ import annotations

import itertools
import json
from pathlib import Path

import numpy as np

from twin.studies.result import MainEffect, SobolIndex, StudyAnalysis
from twin.studies.spec import Study


def _is_number(v) -> bool:
    return isinstance(v, (int, float)) and not isinstance(v, bool)


def table(study: Study, runs: list[dict]) -> tuple[list[str], np.ndarray, list[dict]]:
    """Factor names, the numeric responses per run (NaN for strings and failed runs), and one row
    per run (factors, responses, status, error) in design order.

    Parameters
    ----------
    study : Study
    runs : list of dict
        The finished runs (:func:`twin.studies.runner.run_design_points`), in design order.

    Returns
    -------
    names : list of str
        The factors (dotted scenario paths).
    Y : ndarray
        (runs, responses), in each response's unit; NaN for a string or a failed run.
    rows : list of dict
        Per run: ``index``, ``replicate``, ``status``, the factors, the responses, ``error``.
    """
    names = list(study.factors)
    rows = []
    for r in runs:
        row = {"index": r["index"], "replicate": r["replicate"], "status": r["status"], **r["point"]}
        row.update(r.get("responses", {k: np.nan for k in study.responses}))
        row["error"] = r.get("error", "")
        rows.append(row)
    Y = np.array([[row[k] if _is_number(row[k]) else np.nan for k in study.responses] for row in rows], float) if rows \
        else np.zeros((0, len(study.responses)))
    return names, Y, rows


def numeric_responses(study: Study, rows: list[dict]) -> list[str]:
    """The responses whose value is a number in every successful run.

    Parameters
    ----------
    study : Study
    rows : list of dict
        The table's rows (:func:`table`).

    Returns
    -------
    list of str
        Those responses, in the study's order.
    """
    ok = [r for r in rows if r["status"] == "ok"]
    return [resp for resp in study.responses if all(_is_number(r[resp]) for r in ok)]


def main_effects(study: Study, rows: list[dict]) -> dict[str, dict[str, MainEffect]]:
    """Mean response per factor level (ranged factors: per quartile bin) and the effect size
    (max − min of those means).

    Parameters
    ----------
    study : Study
    rows : list of dict
        The table's rows (:func:`table`).

    Returns
    -------
    dict of str to dict of str to MainEffect
        Factor → numeric response → its means and effect, in the response's unit.
    """
    out = {}
    ok = [r for r in rows if r["status"] == "ok"]
    responses = numeric_responses(study, rows)
    for f in study.factors:
        vals = [r[f] for r in ok]
        numeric = all(isinstance(v, (int, float)) for v in vals)
        if numeric and len(set(vals)) > 6:
            edges = np.quantile(vals, [0, 0.25, 0.5, 0.75, 1.0])
            groups = {f"{edges[i]:.4g}..{edges[i + 1]:.4g}": [r for r in ok if edges[i] <= r[f] <= edges[i + 1]]
                      for i in range(4)}
        else:
            # numeric levels in numeric order (as text, 15 sorts before 5)
            levels = sorted(set(vals)) if numeric else sorted(set(vals), key=str)
            groups = {str(v): [r for r in ok if r[f] == v] for v in levels}
        out[f] = {}
        for resp in responses:
            means = {g: float(np.mean([r[resp] for r in members])) for g, members in groups.items() if members}
            out[f][resp] = MainEffect(means, float(max(means.values()) - min(means.values())) if means else 0.0)
    return out


def interactions(study: Study, rows: list[dict]) -> dict[str, dict[str, float]]:
    """Two-factor interactions: the coefficient of the product term in a linear model with main
    effects (factors scaled to [−1, 1]), per response.

    Parameters
    ----------
    study : Study
    rows : list of dict
        The table's rows (:func:`table`).

    Returns
    -------
    dict of str to dict of str to float
        ``"a × b"`` → numeric response → coefficient, in the response's unit.
    """
    ok = [r for r in rows if r["status"] == "ok"]
    names = [f for f in study.factors if all(isinstance(r[f], (int, float)) for r in ok)]
    if len(names) < 2 or len(ok) < len(names) + 2:
        return {}
    X = np.array([[r[f] for f in names] for r in ok], float)
    span = X.max(0) - X.min(0)
    span[span == 0] = 1
    Z = 2 * (X - X.min(0)) / span - 1
    out = {}
    for a, b in itertools.combinations(range(len(names)), 2):
        A = np.column_stack([np.ones(len(ok)), Z, Z[:, a] * Z[:, b]])
        key = f"{names[a]} × {names[b]}"
        out[key] = {}
        for resp in numeric_responses(study, rows):
            y = np.array([r[resp] for r in ok])
            coef = np.linalg.lstsq(A, y, rcond=None)[0]
            out[key][resp] = float(coef[-1])
    return out


def sobol_indices(study: Study, runs: list[dict], n_boot: int = 200,
                  responses: list[str] | None = None) -> dict[str, dict[str, SobolIndex]] | None:
    """First-order and total Sobol indices from a Saltelli design (Jansen/Saltelli 2010 estimators)
    with bootstrap 95 % intervals; None for other designs.

    With f(A), f(B), f(A_B^i) the responses (mean over replicates) at the design's blocks (A_B^i:
    A with column i from B) and V the variance of f(A) and f(B) pooled: S1_i = mean(f(B) (f(A_B^i) − f(A))) / V and
    ST_i = mean((f(A) − f(A_B^i))²) / (2 V). The intervals are bootstrap percentile intervals
    over the N base samples.

    Parameters
    ----------
    study : Study
    runs : list of dict
        The finished runs.
    n_boot : int
        Bootstrap resamples.
    responses : list of str, optional
        The responses (default: all of the study's).

    Returns
    -------
    dict of str to dict of str to SobolIndex or None
        Response → factor → indices [1]; None unless the design is a complete Saltelli design.

    References
    ----------
    Saltelli, Annoni, Azzini, Campolongo, Ratto & Tarantola (2010), Comput. Phys. Commun. 181,
    259–270: the design and the first-order estimator; Jansen (1999), Comput. Phys. Commun. 117,
    35–43: the total-effect estimator. Efron & Tibshirani (1993), *An Introduction to the
    Bootstrap*: percentile intervals.
    """
    if study.design.type != "saltelli":
        return None
    d, N = len(study.factors), study.design.points
    by_index: dict[int, list] = {}
    for r in runs:
        if r["status"] == "ok":
            by_index.setdefault(r["index"], []).append(r["responses"])
    if len(by_index) < N * (d + 2):
        return None
    rng = np.random.default_rng(study.seed)
    out = {}
    for resp in study.responses if responses is None else responses:
        f = np.array([np.mean([x[resp] for x in by_index[i]]) for i in range(N * (d + 2))])
        fA, fB = f[:N], f[N : 2 * N]
        res = {}
        for i, name in enumerate(study.factors):
            fAB = f[(2 + i) * N : (3 + i) * N]

            def est(idx):
                var = np.var(np.r_[fA[idx], fB[idx]])
                if var == 0:
                    return 0.0, 0.0
                s1 = np.mean(fB[idx] * (fAB[idx] - fA[idx])) / var
                st = 0.5 * np.mean((fA[idx] - fAB[idx]) ** 2) / var
                return s1, st

            s1, st = est(np.arange(N))
            boots = np.array([est(rng.integers(0, N, N)) for _ in range(n_boot)])
            s1_ci, st_ci = np.percentile(boots[:, 0], [2.5, 97.5]), np.percentile(boots[:, 1], [2.5, 97.5])
            res[name] = SobolIndex(float(s1), (float(s1_ci[0]), float(s1_ci[1])),
                                   float(st), (float(st_ci[0]), float(st_ci[1])))
        out[resp] = res
    return out


def _cell(v) -> str:
    return json.dumps(v) if isinstance(v, str) else f"{v:.6g}" if isinstance(v, float) else str(v)


def write_outputs(study: Study, runs: list[dict], out_dir: Path) -> StudyAnalysis:
    """Table (CSV and HDF5), analysis JSON, plots.

    Parameters
    ----------
    study : Study
    runs : list of dict
        The finished runs, in design order.
    out_dir : Path
        The study's output folder.

    Returns
    -------
    StudyAnalysis
        What ``analysis.json`` holds.
    """
    from twin.io import atomic_hdf5, atomic_write_text
    from twin.results import to_json
    from twin.studies.plots import write_plots

    names, Y, rows = table(study, runs)
    cols = ["index", "replicate", "status", *names, *study.responses, "error"]
    lines = [",".join(cols)] + [",".join(_cell(r[c]) for c in cols) for r in rows]
    atomic_write_text(out_dir / "table.csv", "\n".join(lines) + "\n")
    numeric = numeric_responses(study, rows)
    with atomic_hdf5(out_dir / "table.h5") as f:  # built in memory: a full disk is an OSError, not a crash
        f.attrs["study"] = study.model_dump_json(exclude={"plugins"} if not study.plugins else None)
        f.create_dataset("index", data=np.array([r["index"] for r in rows]))
        f.create_dataset("replicate", data=np.array([r["replicate"] for r in rows]))
        f.create_dataset("ok", data=np.array([r["status"] == "ok" for r in rows]))
        for n in names:
            vals = [r[n] for r in rows]
            f.create_dataset(f"factors/{n}", data=np.array(vals, float) if all(isinstance(v, (int, float)) for v in vals)
                             else np.array([str(v) for v in vals], dtype="S"))
        for j, resp in enumerate(study.responses):
            f.create_dataset(f"responses/{resp}", data=Y[:, j] if resp in numeric
                             else np.array([str(r[resp]) for r in rows], dtype="S"))
    analysis = StudyAnalysis(runs=len(rows), failed=sum(r["status"] != "ok" for r in rows),
                             main_effects=main_effects(study, rows), interactions=interactions(study, rows),
                             sobol=sobol_indices(study, runs, responses=numeric))
    atomic_write_text(out_dir / "analysis.json", json.dumps(to_json(analysis), indent=2) + "\n")
    write_plots(study, rows, analysis, out_dir, numeric)
    return analysis
