"""Design-of-experiment studies: sweep scenario parameters, locally or on a dask cluster.

A study YAML names a base scenario, factors (dotted paths into it with a range or levels), a
design (full factorial, Latin hypercube, Sobol/Saltelli from ``scipy.stats.qmc``), replicates and
responses from :data:`RESPONSES`. Every run is seeded from the study seed and its index, so the
executor does not change the results; each finished run is appended durably (fsync) to
``runs.jsonl`` keyed by a hash of its resolved scenario, so a killed study resumes without losing
or duplicating runs; a failing run is recorded with its error and the others go on.
"""

from __future__ import annotations

import copy
import difflib
import hashlib
import itertools
import json
import os
import time
from pathlib import Path
from typing import Literal

import numpy as np
import yaml
from pydantic import BaseModel, ConfigDict, Field, ValidationError, model_validator

from twin.errors import ScenarioError, TwinError

#: response name → what it measures (documented in docs/doe.md)
RESPONSES = {
    "chamber_hours": "chamber time of the scenario: program duration × runs [h]",
    "drift_pp_mg": "peak-to-peak true drift in the output [mg]",
    "residual_rms_mg": "residual RMS of the calibrated twin on the blind measurement [mg]",
    "noise_floor_mg": "noise floor estimated from the measurement [mg]",
    "hidden_detected": "1 if the diagnosis detects a missing effect, else 0",
    "hidden_rank": "rank (1 = first) of the hidden effect's family in the diagnosis ranking; 0 if absent",
    "hidden_separated": "1 if the hidden effect's family is first and in no alias group with another family, else 0",
    "compensated_mse_ratio": "MSE of a polynomial-in-T compensation on the last cycle / noise-only MSE",
}


class FactorSpec(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True)
    range: list[float] | None = Field(None, min_length=2, max_length=2, description="[low, high]")
    levels: list[int | float | str] | None = Field(None, min_length=1, description="explicit levels")
    log: bool = Field(False, description="sample the range on a log scale")

    @model_validator(mode="after")
    def _one(self) -> FactorSpec:
        if (self.range is None) == (self.levels is None):
            raise ValueError("give either range: [low, high] or levels: [...]")
        if self.range is not None and not self.range[0] < self.range[1]:
            raise ValueError(f"empty range {self.range}: need low < high")
        if self.log and self.range is not None and self.range[0] <= 0:
            raise ValueError("a log range needs low > 0")
        return self


class DesignSpec(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True)
    type: Literal["full_factorial", "latin_hypercube", "sobol", "saltelli"] = "full_factorial"
    points: int = Field(8, ge=1, description="samples (LHS/Sobol) or base samples N (Saltelli: N(d+2) runs)")
    levels: int = Field(3, ge=2, description="levels per ranged factor in a full factorial")


class Study(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True)
    name: str = ""
    description: str = ""
    base: str = Field(description="base scenario YAML, relative to the study file")
    seed: int = Field(0, ge=0)
    factors: dict[str, FactorSpec] = Field(min_length=1)
    design: DesignSpec = DesignSpec()
    replicates: int = Field(1, ge=1)
    responses: list[str] = Field(min_length=1)
    max_runs: int = Field(500, ge=1, description="refuse designs larger than this")
    logger_rate_hz: float | None = Field(None, gt=0, description="override the base logger rate (faster studies)")


def _leaf_paths(data, prefix="") -> list[str]:
    out = []
    if isinstance(data, dict):
        for k, v in data.items():
            p = f"{prefix}.{k}" if prefix else str(k)
            out.append(p)
            out += _leaf_paths(v, p)
    elif isinstance(data, list):
        for i, v in enumerate(data):
            p = f"{prefix}.{i}"
            out.append(p)
            out += _leaf_paths(v, p)
    return out


def _schema_paths() -> list[str]:
    """Every settable dotted path of a scenario, from the schema (for "did you mean")."""
    from twin.model.scenario import Scenario

    paths = []

    def walk(model, prefix):
        import typing

        for name, f in model.model_fields.items():
            p = f"{prefix}.{name}" if prefix else name
            paths.append(p)
            for t in [f.annotation, *typing.get_args(f.annotation)]:
                for tt in [t, *typing.get_args(t)]:
                    if isinstance(tt, type) and issubclass(tt, BaseModel):
                        walk(tt, p)

    walk(Scenario, "")
    return paths


def set_path(data: dict, dotted: str, value) -> None:
    """Set ``a.b.c`` (list indices as numbers) in a nested scenario dict, creating mappings."""
    keys = dotted.split(".")
    node = data
    for k in keys[:-1]:
        if isinstance(node, list):
            node = node[int(k)]
        else:
            if not isinstance(node.get(k), (dict, list)):
                node[k] = {}
            node = node[k]
    if isinstance(node, list):
        node[int(keys[-1])] = value
    else:
        node[keys[-1]] = value


def _check_factor_path(path: str, base: dict) -> None:
    """A factor path must name something in the base scenario or the scenario schema; effect
    parameters (device.effects.<effect>.<param>) are checked against the registry."""
    from twin.effects import get_effect

    keys = path.split(".")
    if keys[:2] == ["device", "effects"] and len(keys) == 4:
        cls = get_effect(keys[2])  # raises with "did you mean"
        names = [p.name for p in cls.parameters]
        if keys[3] not in names:
            close = difflib.get_close_matches(keys[3], names, n=1)
            raise ScenarioError(f"factor {path!r}: effect {keys[2]!r} has no parameter {keys[3]!r}"
                                + (f"; did you mean {close[0]!r}?" if close else f"; parameters: {', '.join(names)}"))
        return
    known = set(_leaf_paths(base)) | set(_schema_paths())
    if path not in known:
        close = difflib.get_close_matches(path, sorted(known), n=1)
        raise ScenarioError(f"unknown factor path {path!r}" + (f"; did you mean {close[0]!r}?" if close else ""))


def load_study(path: str | Path) -> tuple[Study, dict, Path]:
    """Validate a study file; return it, the base scenario data, and the study's folder."""
    from twin.model.scenario import _format_path, _where, load_yaml_mapping

    p = Path(path)
    if not p.is_file():
        raise ScenarioError(f"{p}: study file not found")
    data, lines = load_yaml_mapping(p.read_text(), str(p), "a study is a YAML mapping")
    try:
        study = Study.model_validate(data)
    except ValidationError as exc:
        e = exc.errors(include_url=False)[0]
        loc = tuple(e["loc"])
        if e["type"] == "extra_forbidden":
            valid = list(Study.model_fields) if len(loc) == 1 else list(DesignSpec.model_fields) if loc[0] == "design" \
                else list(FactorSpec.model_fields)
            close = difflib.get_close_matches(str(loc[-1]), valid, n=1)
            hint = f"; did you mean {close[0]!r}?" if close else ""
            raise ScenarioError(f"{_where(str(p), lines, loc)}: unknown key {loc[-1]!r}{hint}") from None
        raise ScenarioError(f"{_where(str(p), lines, loc)}: {_format_path(loc)}: {e['msg']}") from None
    for r in study.responses:
        if r not in RESPONSES:
            close = difflib.get_close_matches(r, RESPONSES, n=1)
            raise ScenarioError(f"{p}: unknown response {r!r}" + (f"; did you mean {close[0]!r}?" if close else
                                                                   f"; responses: {', '.join(RESPONSES)}"))
    base_path = (p.parent / study.base).resolve()
    if not base_path.is_file():
        raise ScenarioError(f"{p}: base scenario {study.base!r} not found (looked in {base_path})")
    base = yaml.safe_load(base_path.read_text())
    for name in study.factors:
        try:
            _check_factor_path(name, base)
        except TwinError as exc:
            raise ScenarioError(f"{_where(str(p), lines, ('factors', name))}: {exc}") from None
    n = len(design_points(study))
    if n * study.replicates > study.max_runs:
        raise ScenarioError(f"{p}: the {study.design.type} design needs {n} points × {study.replicates} replicates = "
                            f"{n * study.replicates} runs, more than max_runs {study.max_runs}")
    return study, base, p.parent


def design_points(study: Study) -> list[dict]:
    """Factor settings of every design point (replicates not included)."""
    names = list(study.factors)
    specs = [study.factors[n] for n in names]
    d = len(names)

    def scale(u, spec):
        if spec.levels is not None:
            return spec.levels[min(int(u * len(spec.levels)), len(spec.levels) - 1)]
        lo, hi = spec.range
        return float(np.exp(np.log(lo) + u * (np.log(hi) - np.log(lo)))) if spec.log else float(lo + u * (hi - lo))

    t = study.design.type
    if t == "full_factorial":
        axes = []
        for spec in specs:
            if spec.levels is not None:
                axes.append(list(spec.levels))
            else:
                axes.append([scale(u, spec) for u in np.linspace(0, 1, study.design.levels)])
        return [dict(zip(names, combo)) for combo in itertools.product(*axes)]
    from scipy.stats import qmc

    if t == "latin_hypercube":
        U = qmc.LatinHypercube(d=d, seed=study.seed).random(study.design.points)
    elif t == "sobol":
        U = qmc.Sobol(d=d, scramble=True, seed=study.seed).random(study.design.points)
    else:  # Saltelli: A, B and the d matrices AB_i (A with column i from B): N (d + 2) runs
        AB = qmc.Sobol(d=2 * d, scramble=True, seed=study.seed).random(study.design.points)
        A, B = AB[:, :d], AB[:, d:]
        blocks = [A, B] + [np.where(np.arange(d) == i, B, A) for i in range(d)]
        U = np.vstack(blocks)
    return [{n: scale(u, s) for n, u, s in zip(names, row, specs)} for row in U]


def resolve(study: Study, base: dict, point: dict, index: int, replicate: int) -> tuple[str, dict]:
    """The run's scenario YAML and its key (hash of the resolved scenario and replicate)."""
    data = copy.deepcopy(base)
    for path, value in point.items():
        set_path(data, path, value)
    if study.logger_rate_hz:
        data.setdefault("test_plan", {})["logger_rate_hz"] = study.logger_rate_hz
    seed = int(np.random.SeedSequence([study.seed, index, replicate]).generate_state(1)[0])
    data["seed"] = seed
    text = yaml.safe_dump(data, sort_keys=True)
    key = hashlib.sha256(f"{text}\nreplicate={replicate}".encode()).hexdigest()[:16]
    return key, {"yaml": text, "index": index, "replicate": replicate, "point": point, "seed": seed}


def evaluate_run(job: dict, responses: list[str]) -> dict:
    """Simulate one resolved scenario and compute its responses (run in a worker process)."""
    from twin.diagnosis.compare import compare_measurement
    from twin.measurement import from_dataset
    from twin.model.scenario import parse_scenario
    from twin.model.simulate import simulate

    t0 = time.perf_counter()
    out = {"key": job["key"], "index": job["index"], "replicate": job["replicate"], "point": job["point"],
           "seed": job["seed"]}
    try:
        loaded = parse_scenario(job["yaml"], f"<run {job['index']}>")
        ds = simulate(loaded)
        scn = loaded.scenario
        values = {}
        values["chamber_hours"] = loaded.program.duration_s * scn.test_plan.runs / 3600
        drift = ds["truth/drift_g"]
        values["drift_pp_mg"] = float((drift.max() - drift.min()) * 1e3)
        noise = ds["truth/noise_white_g"] + ds["truth/noise_bias_instability_g"] + ds["truth/quantisation_g"]
        needs_diag = {"residual_rms_mg", "noise_floor_mg", "hidden_detected", "hidden_rank", "hidden_separated"}
        if needs_diag & set(responses):
            m = from_dataset(ds)  # blind: the logged columns only
            _, r = compare_measurement(loaded, m, [])
            values["residual_rms_mg"] = r["rms_residual_g"] * 1e3
            values["noise_floor_mg"] = r["noise_floor_g"] * 1e3
            values["hidden_detected"] = float(r["missing_effect_detected"])
            hidden = _hidden_family(loaded)
            fams = [c["family"] for c in r["candidates"]]
            values["hidden_rank"] = float(fams.index(hidden) + 1) if hidden in fams else 0.0
            # separated: named first, and in no alias group with an effect of another family
            mixed = any(hidden in fs and len(fs) > 1 for fs in
                        ({get_family(e) for e in a["effects"] if e in _registry()} for a in r["aliases"]))
            values["hidden_separated"] = float(bool(fams) and fams[0] == hidden and not mixed)
        if "compensated_mse_ratio" in responses:
            values["compensated_mse_ratio"] = _poly_compensation_ratio(loaded, ds, noise)
        out["responses"] = {k: float(values[k]) for k in responses}
        out["status"] = "ok"
    except Exception as exc:  # recorded, and the study goes on
        out["status"] = "error"
        out["error"] = f"{type(exc).__name__}: {exc}"
    out["seconds"] = time.perf_counter() - t0
    return out


def _registry():
    from twin.effects import REGISTRY

    return REGISTRY


def get_family(effect: str) -> str:
    return _registry()[effect].family


def _hidden_family(loaded) -> str | None:
    scn = loaded.scenario
    hidden = [n for n in scn.device.effects if n not in scn.twin.effects]
    if hidden:
        return get_family(hidden[0])
    th = scn.chamber.thermometer
    if (th.attached_to != "die" or th.tau_s > 0) and "thermal_lag" not in scn.twin.effects:
        return "thermal_lag"
    return None


def _poly_compensation_ratio(loaded, ds, noise) -> float:
    from fitting import FeatureSet, PolynomialCompensator

    t = ds["time_s"]
    cycle = np.array([s.cycle for s in loaded.program.segments])[loaded.program.segment_index(t)]
    test = cycle == cycle.max() if cycle.max() > 0 else np.arange(t.size) >= 2 * t.size // 3
    temp = ds["temperature/thermometer_c"]
    X = FeatureSet(("T",)).transform(temp, t)
    y = ds["output/output_g"] - ds["test/applied_g"]
    model = PolynomialCompensator(max_order=4).fit(X[~test], y[~test])
    err = y[test] - model.predict(X[test])
    return float(np.var(err) / np.mean(noise[test] ** 2))  # the mean (offset) is not drift


# ---------------------------------------------------------------------------------- execution


def _append(path: Path, record: dict) -> None:
    """Append one JSON line durably: a killed study never leaves a half record behind."""
    line = json.dumps(record) + "\n"
    with open(path, "a", encoding="utf-8") as f:
        f.write(line)
        f.flush()
        os.fsync(f.fileno())


def read_runs(path: Path) -> dict[str, dict]:
    """Finished runs by key (a torn last line from a kill is ignored)."""
    runs = {}
    if path.is_file():
        for line in path.read_text().splitlines():
            try:
                r = json.loads(line)
            except json.JSONDecodeError:
                continue
            runs[r["key"]] = r
    return runs


def plan(study: Study, base: dict) -> list[dict]:
    jobs = []
    for i, point in enumerate(design_points(study)):
        for rep in range(study.replicates):
            key, job = resolve(study, base, point, i, rep)
            jobs.append({"key": key, **job})
    return jobs


def run_study(study: Study, base: dict, out_dir: Path, workers: int = 1, executor: str = "local",
              scheduler: str | None = None, progress=None) -> list[dict]:
    """Run every pending job; return all finished runs in design order."""
    out_dir.mkdir(parents=True, exist_ok=True)
    log = out_dir / "runs.jsonl"
    done = read_runs(log)
    jobs = plan(study, base)
    pending = [j for j in jobs if j["key"] not in done]
    tick = progress or (lambda r: None)
    for _ in range(len(jobs) - len(pending)):
        tick(None)
    if pending:
        if executor == "dask":
            from dask.distributed import Client, as_completed

            client = Client(scheduler) if scheduler else Client(processes=True, n_workers=max(1, workers),
                                                                threads_per_worker=1)
            try:
                futures = [client.submit(evaluate_run, j, study.responses, pure=False) for j in pending]
                for fut in as_completed(futures):
                    rec = fut.result()
                    _append(log, rec)
                    tick(rec)
            finally:
                client.close()
        elif workers > 1:
            from concurrent.futures import ProcessPoolExecutor, as_completed

            with ProcessPoolExecutor(workers) as ex:
                futures = [ex.submit(evaluate_run, j, study.responses) for j in pending]
                for fut in as_completed(futures):
                    rec = fut.result()
                    _append(log, rec)
                    tick(rec)
        else:
            for j in pending:
                rec = evaluate_run(j, study.responses)
                _append(log, rec)
                tick(rec)
    done = read_runs(log)
    return [done[j["key"]] for j in jobs if j["key"] in done]


# ------------------------------------------------------------------------------------ analysis


def table(study: Study, runs: list[dict]) -> tuple[list[str], np.ndarray, list[dict]]:
    """Factor values (numeric where possible) and responses per run; rows in design order."""
    names = list(study.factors)
    rows = []
    for r in runs:
        row = {"index": r["index"], "replicate": r["replicate"], "status": r["status"], **r["point"]}
        row.update(r.get("responses", {k: np.nan for k in study.responses}))
        row["error"] = r.get("error", "")
        rows.append(row)
    Y = np.array([[row[k] for k in study.responses] for row in rows], float) if rows else np.zeros((0, len(study.responses)))
    return names, Y, rows


def main_effects(study: Study, rows: list[dict]) -> dict:
    """Mean response per factor level (ranged factors: per quartile bin) and the effect size
    (max − min of those means)."""
    out = {}
    ok = [r for r in rows if r["status"] == "ok"]
    for f in study.factors:
        vals = [r[f] for r in ok]
        numeric = all(isinstance(v, (int, float)) for v in vals)
        if numeric and len(set(vals)) > 6:
            edges = np.quantile(vals, [0, 0.25, 0.5, 0.75, 1.0])
            groups = {f"{edges[i]:.4g}..{edges[i + 1]:.4g}": [r for r in ok if edges[i] <= r[f] <= edges[i + 1]]
                      for i in range(4)}
        else:
            groups = {str(v): [r for r in ok if r[f] == v] for v in sorted(set(vals), key=str)}
        out[f] = {}
        for resp in study.responses:
            means = {g: float(np.mean([r[resp] for r in members])) for g, members in groups.items() if members}
            out[f][resp] = {"means": means, "effect": float(max(means.values()) - min(means.values())) if means else 0.0}
    return out


def interactions(study: Study, rows: list[dict]) -> dict:
    """Two-factor interactions: the coefficient of the product term in a linear model with main
    effects (factors scaled to [−1, 1]), per response."""
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
        for resp in study.responses:
            y = np.array([r[resp] for r in ok])
            coef = np.linalg.lstsq(A, y, rcond=None)[0]
            out[key][resp] = float(coef[-1])
    return out


def sobol_indices(study: Study, runs: list[dict], n_boot: int = 200) -> dict | None:
    """First-order and total Sobol indices from a Saltelli design (Jansen/Saltelli 2010 estimators)
    with bootstrap 95 % intervals; None for other designs."""
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
    for resp in study.responses:
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
            res[name] = {"S1": float(s1), "S1_ci95": np.percentile(boots[:, 0], [2.5, 97.5]).tolist(),
                         "ST": float(st), "ST_ci95": np.percentile(boots[:, 1], [2.5, 97.5]).tolist()}
        out[resp] = res
    return out


def write_outputs(study: Study, runs: list[dict], out_dir: Path) -> dict:
    """Table (CSV and HDF5), analysis JSON, plots."""
    import h5py

    from twin.io import atomic_path, atomic_write_text

    names, Y, rows = table(study, runs)
    cols = ["index", "replicate", "status", *names, *study.responses, "error"]
    lines = [",".join(cols)] + [",".join(json.dumps(r[c]) if isinstance(r[c], str) else f"{r[c]:.6g}"
                                         if isinstance(r[c], float) else str(r[c]) for c in cols) for r in rows]
    atomic_write_text(out_dir / "table.csv", "\n".join(lines) + "\n")
    with atomic_path(out_dir / "table.h5") as tmp, h5py.File(tmp, "w") as f:
        f.attrs["study"] = study.model_dump_json()
        f.create_dataset("index", data=np.array([r["index"] for r in rows]))
        f.create_dataset("replicate", data=np.array([r["replicate"] for r in rows]))
        f.create_dataset("ok", data=np.array([r["status"] == "ok" for r in rows]))
        for n in names:
            vals = [r[n] for r in rows]
            f.create_dataset(f"factors/{n}", data=np.array(vals, float) if all(isinstance(v, (int, float)) for v in vals)
                             else np.array([str(v) for v in vals], dtype="S"))
        for j, resp in enumerate(study.responses):
            f.create_dataset(f"responses/{resp}", data=Y[:, j])
    analysis = {"runs": len(rows), "failed": sum(r["status"] != "ok" for r in rows),
                "main_effects": main_effects(study, rows), "interactions": interactions(study, rows),
                "sobol": sobol_indices(study, runs)}
    atomic_write_text(out_dir / "analysis.json", json.dumps(analysis, indent=2) + "\n")
    _plots(study, rows, analysis, out_dir)
    return analysis


def _plots(study: Study, rows: list[dict], analysis: dict, out_dir: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    ok = [r for r in rows if r["status"] == "ok"]
    names = list(study.factors)
    fig, axes = plt.subplots(len(study.responses), len(names), figsize=(3.2 * len(names), 2.6 * len(study.responses)),
                             squeeze=False)
    for i, resp in enumerate(study.responses):
        for j, f in enumerate(names):
            ax = axes[i][j]
            means = analysis["main_effects"][f][resp]["means"]
            ax.plot(list(means), list(means.values()), "o-")
            ax.set_xlabel(f, fontsize=8)
            ax.set_ylabel(resp, fontsize=8)
            ax.tick_params(labelsize=7, axis="x", rotation=30)
    fig.tight_layout()
    fig.savefig(out_dir / "main_effects.png", dpi=90)
    plt.close(fig)
    numeric = [f for f in names if all(isinstance(r[f], (int, float)) for r in ok)]
    if len(numeric) >= 2 and len(ok) >= 4:
        a, b = numeric[:2]
        fig, axes = plt.subplots(1, len(study.responses), figsize=(4.2 * len(study.responses), 3.6), squeeze=False)
        for k, resp in enumerate(study.responses):
            ax = axes[0][k]
            sc = ax.scatter([r[a] for r in ok], [r[b] for r in ok], c=[r[resp] for r in ok], cmap="viridis", s=40)
            try:
                ax.tricontourf([r[a] for r in ok], [r[b] for r in ok], [r[resp] for r in ok], levels=10, alpha=0.5,
                               cmap="viridis")
            except Exception:  # too few distinct points for a triangulation: the scatter stays
                pass
            fig.colorbar(sc, ax=ax, label=resp)
            ax.set_xlabel(a, fontsize=8)
            ax.set_ylabel(b, fontsize=8)
        fig.tight_layout()
        fig.savefig(out_dir / "response_surface.png", dpi=90)
        plt.close(fig)
    if analysis.get("sobol"):
        fig, axes = plt.subplots(1, len(study.responses), figsize=(4 * len(study.responses), 3.4), squeeze=False)
        for k, resp in enumerate(study.responses):
            s = analysis["sobol"][resp]
            x = np.arange(len(s))
            axes[0][k].bar(x - 0.2, [v["S1"] for v in s.values()], 0.4, label="S1")
            axes[0][k].bar(x + 0.2, [v["ST"] for v in s.values()], 0.4, label="ST")
            axes[0][k].set_xticks(x, list(s), rotation=30, fontsize=7)
            axes[0][k].set_title(resp, fontsize=9)
            axes[0][k].legend(fontsize=7)
        fig.tight_layout()
        fig.savefig(out_dir / "sobol.png", dpi=90)
        plt.close(fig)
