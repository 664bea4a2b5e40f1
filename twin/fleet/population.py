"""The population view over a fleet's units: prevalence of each named effect, distributions of the
fitted parameters, robust outliers (median / MAD), and the per-unit table.

Robust z-score: z = (x − median) / (1.4826 · MAD), the MAD scaled to σ for normal data (Iglewicz &
Hoaglin, *How to Detect and Handle Outliers*, 1993, who flag |z| > 3.5), computed among the units
of the same finding (the family named first, or none).
"""

from __future__ import annotations

import csv
import io
import json
import math
from pathlib import Path

import numpy as np

from twin.io import atomic_path, atomic_write_text

#: per-unit scalars that join the parameters in the distributions and the outlier screen
SCALARS = ("rms_residual_mg", "noise_floor_mg", "residual_over_floor", "heldout_rms_mg")
MAD_TO_SIGMA = 1.4826


def wilson_ci95(k: int, n: int) -> list[float] | None:
    """Wilson score interval (95 %) of a proportion k/n (Wilson 1927)."""
    if n == 0:
        return None
    z, p = 1.96, k / n
    den = 1 + z * z / n
    centre = (p + z * z / (2 * n)) / den
    half = z * math.sqrt(p * (1 - p) / n + z * z / (4 * n * n)) / den
    return [max(0.0, centre - half), min(1.0, centre + half)]


def unit_values(record: dict) -> dict[str, float]:
    """``name`` → value of one ok unit: its fitted parameters and its scalars."""
    out = {k: float(v["value"]) for k, v in record.get("parameters", {}).items() if v.get("value") is not None}
    out.update({k: float(record[k]) for k in SCALARS if record.get(k) is not None})
    return out


def robust_z(values: np.ndarray) -> np.ndarray:
    """(x − median) / (1.4826 · MAD); zeros where the MAD is zero (no spread to measure against)."""
    med = np.median(values)
    mad = np.median(np.abs(values - med))
    if mad == 0:
        return np.zeros_like(values)
    return (values - med) / (MAD_TO_SIGMA * mad)


def finding_group(record: dict) -> str:
    """The family named first, or ``none``: units are compared with units of the same finding (a
    lag unit's residual before the lag is added is not an outlier among units with nothing to add)."""
    fams = record.get("families") or []
    return fams[0] if fams else "none"


def population(records: list[dict], threshold: float = 3.5) -> dict:
    """Prevalence, confidence counts, parameter distributions and robust outliers of a fleet."""
    ok = [r for r in records if r["status"] == "ok"]
    n = len(ok)
    prevalence, families = {}, {}
    for key, store in (("named", prevalence), ("families", families)):
        names = sorted({e for r in ok for e in r.get(key, [])})
        for e in names:
            k = sum(e in r.get(key, []) for r in ok)
            store[e] = {"units": k, "share": k / n, "ci95": wilson_ci95(k, n)}
    primary: dict[str, dict] = {}  # the first-named effect's family: the unit's main finding
    for fam in sorted({r["families"][0] for r in ok if r.get("families")}):
        k = sum(bool(r.get("families")) and r["families"][0] == fam for r in ok)
        primary[fam] = {"units": k, "share": k / n, "ci95": wilson_ci95(k, n)}
    confidence: dict[str, int] = {}
    for r in ok:
        c = str(r.get("confidence"))
        confidence[c] = confidence.get(c, 0) + 1
    per_unit = {r["unit"]: unit_values(r) for r in ok}
    group_of = {r["unit"]: finding_group(r) for r in ok}
    names = sorted({k for v in per_unit.values() for k in v})
    dists, outliers = {}, []
    for name in names:
        units = [u for u in per_unit if name in per_unit[u]]
        x = np.array([per_unit[u][name] for u in units])
        q = np.quantile(x, [0.05, 0.25, 0.5, 0.75, 0.95])
        mad = float(np.median(np.abs(x - q[2])))
        unit_of = next((r["parameters"][name]["unit"] for r in ok if name in r.get("parameters", {})), "")
        dists[name] = {"units": len(units), "unit": unit_of, "median": float(q[2]), "mad": mad,
                       "q05": float(q[0]), "q25": float(q[1]), "q75": float(q[3]), "q95": float(q[4]),
                       "mean": float(x.mean()), "std": float(x.std(ddof=1)) if len(x) > 1 else 0.0,
                       "min": float(x.min()), "max": float(x.max())}
        for group in sorted({group_of[u] for u in units}):  # judged among units with the same finding
            idx = [j for j, u in enumerate(units) if group_of[u] == group]
            if len(idx) >= 5:  # fewer units give no spread worth judging against
                z = robust_z(x[idx])
                outliers += [{"unit": units[j], "quantity": name, "group": group, "value": float(x[j]),
                              "robust_z": float(s)} for j, s in zip(idx, z) if abs(s) > threshold]
    outliers.sort(key=lambda o: (o["unit"], o["quantity"]))
    return {
        "units": len(records), "ok": n, "errors": len(records) - n,
        "prevalence": prevalence, "prevalence_by_family": families, "prevalence_primary_family": primary,
        "none_named": {"units": sum(not r.get("named") for r in ok),
                       "share": (sum(not r.get("named") for r in ok) / n) if n else None},
        "confidence": dict(sorted(confidence.items())),
        "parameters": dists, "outlier_threshold": threshold, "outliers": outliers,
        "failed": [{"unit": r["unit"], "error": r.get("error", "")} for r in records if r["status"] != "ok"],
    }


def table_rows(records: list[dict]) -> tuple[list[str], list[dict]]:
    """One flat row per unit, sorted by unit id; deterministic (no timings, paths relative to the
    output folder), so two executors give identical tables."""
    rows = []
    for r in sorted(records, key=lambda r: r["unit"]):
        row = {"unit": r["unit"], "status": r["status"], "error": r.get("error", ""),
               "named": ";".join(r.get("named", [])), "families": ";".join(r.get("families", [])),
               "confidence": r.get("confidence") or "", "files": ";".join(r.get("files", [])),
               "report": (r.get("reports") or {}).get("html", (r.get("reports") or {}).get("json", ""))}
        for k in SCALARS:
            row[k] = r.get(k)
        for name, p in sorted(r.get("parameters", {}).items()):
            row[name] = p["value"]
            ci = p.get("ci95")
            row[f"{name}.ci95_low"], row[f"{name}.ci95_high"] = (ci if ci else (None, None))
        rows.append(row)
    fixed = ["unit", "status", "error", "named", "families", "confidence", *SCALARS]
    params = sorted({k for row in rows for k in row} - set(fixed) - {"files", "report"})
    return fixed + params + ["files", "report"], rows


def write_table(out_dir: Path, records: list[dict]) -> list[Path]:
    """``table.csv`` (and ``table.parquet`` when pyarrow is installed), written atomically."""
    header, rows = table_rows(records)
    buf = io.StringIO()
    w = csv.DictWriter(buf, fieldnames=header, lineterminator="\n")
    w.writeheader()
    for row in rows:
        w.writerow({k: ("" if row.get(k) is None else repr(row[k]) if isinstance(row.get(k), float) else row[k])
                    for k in header})
    paths = [atomic_write_text(out_dir / "table.csv", buf.getvalue())]
    try:
        import pyarrow as pa
        import pyarrow.parquet as pq
    except ImportError:
        return paths
    cols = {k: [row.get(k) for row in rows] for k in header}
    with atomic_path(out_dir / "table.parquet") as tmp:
        pq.write_table(pa.table(cols), tmp)
    return paths + [out_dir / "table.parquet"]


def write_population(out_dir: Path, pop: dict) -> Path:
    return atomic_write_text(out_dir / "population.json", json.dumps(pop, indent=2, default=float) + "\n")
