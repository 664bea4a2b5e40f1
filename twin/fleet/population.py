"""The population view over a fleet's units: prevalence of each named effect, distributions of the
fitted parameters, robust outliers (median / MAD), and the per-unit table.

Robust z-score: z = (x − median) / (1.4826 · MAD), the MAD scaled to σ for normal data (Iglewicz &
Hoaglin, *How to Detect and Handle Outliers*, 1993, who flag abs(z) > 3.5), computed among the units
of the same finding (the family named first, or none).
"""

from __future__ import annotations

import csv
import io
import json
import math
from pathlib import Path

import numpy as np

from twin.fleet.result import Distribution, FailedUnit, FleetRow, NoneNamed, Outlier, Population, Prevalence
from twin.io import atomic_path, atomic_write_text

#: per-unit scalars that join the parameters in the distributions and the outlier screen
SCALARS = ("rms_residual_mg", "noise_floor_mg", "residual_over_floor", "heldout_rms_mg")
MAD_TO_SIGMA = 1.4826


def wilson_ci95(k: int, n: int) -> tuple[float, float] | None:
    """Wilson score interval (95 %) of a proportion k/n (Wilson 1927).

    Parameters
    ----------
    k, n : int
        Successes and trials.

    Returns
    -------
    tuple of float or None
        Lower and upper bound [1]; None for no trial.
    """
    if n == 0:
        return None
    z, p = 1.96, k / n
    den = 1 + z * z / n
    centre = (p + z * z / (2 * n)) / den
    half = z * math.sqrt(p * (1 - p) / n + z * z / (4 * n * n)) / den
    return max(0.0, centre - half), min(1.0, centre + half)


def unit_values(record: FleetRow) -> dict[str, float]:
    """``name`` → value of one ok unit: its fitted parameters and its scalars.

    Parameters
    ----------
    record : FleetRow

    Returns
    -------
    dict of str to float
        Each in its own unit (the parameter's, or the scalar's: mg or 1).
    """
    out = {k: float(v.value) for k, v in (record.parameters or {}).items()}
    out.update({k: float(getattr(record, k)) for k in SCALARS if getattr(record, k) is not None})
    return out


def robust_z(values: np.ndarray) -> np.ndarray:
    """(x − median) / (1.4826 · MAD); zeros where the MAD is zero (no spread to measure against).

    Parameters
    ----------
    values : ndarray
        In any one unit.

    Returns
    -------
    ndarray
        Robust z-scores [1].
    """
    med = np.median(values)
    mad = np.median(np.abs(values - med))
    if mad == 0:
        return np.zeros_like(values)
    return (values - med) / (MAD_TO_SIGMA * mad)


def finding_group(record: FleetRow) -> str:
    """The family named first, or ``none``: units are compared with units of the same finding (a
    lag unit's residual before the lag is added is not an outlier among units with nothing to add).

    Parameters
    ----------
    record : FleetRow

    Returns
    -------
    str
    """
    return record.families[0] if record.families else "none"


def _prevalence(k: int, n: int) -> Prevalence:
    return Prevalence(k, k / n, wilson_ci95(k, n))


def population(records: list[FleetRow], threshold: float = 3.5) -> Population:
    """Prevalence, confidence counts, parameter distributions and robust outliers of a fleet.

    Parameters
    ----------
    records : list of FleetRow
        Every finished unit's row.
    threshold : float
        |robust z| above which a unit is an outlier among the units of its finding [1].

    Returns
    -------
    Population
    """
    ok = [r for r in records if r.ok]
    n = len(ok)
    prevalence, families = {}, {}
    for key, store in (("named", prevalence), ("families", families)):
        names = sorted({e for r in ok for e in getattr(r, key) or ()})
        for e in names:
            store[e] = _prevalence(sum(e in (getattr(r, key) or ()) for r in ok), n)
    primary: dict[str, Prevalence] = {}  # the first-named effect's family: the unit's main finding
    for fam in sorted({r.families[0] for r in ok if r.families}):
        primary[fam] = _prevalence(sum(bool(r.families) and r.families[0] == fam for r in ok), n)
    confidence: dict[str, int] = {}
    for r in ok:
        c = str(r.confidence)
        confidence[c] = confidence.get(c, 0) + 1
    per_unit = {r.unit: unit_values(r) for r in ok}
    group_of = {r.unit: finding_group(r) for r in ok}
    names = sorted({k for v in per_unit.values() for k in v})
    dists, outliers = {}, []
    for name in names:
        units = [u for u in per_unit if name in per_unit[u]]
        x = np.array([per_unit[u][name] for u in units])
        q = np.quantile(x, [0.05, 0.25, 0.5, 0.75, 0.95])
        mad = float(np.median(np.abs(x - q[2])))
        unit_of = next((r.parameters[name].unit for r in ok if name in (r.parameters or {})), "")
        dists[name] = Distribution(units=len(units), unit=unit_of, median=float(q[2]), mad=mad,
                                   q05=float(q[0]), q25=float(q[1]), q75=float(q[3]), q95=float(q[4]),
                                   mean=float(x.mean()), std=float(x.std(ddof=1)) if len(x) > 1 else 0.0,
                                   min=float(x.min()), max=float(x.max()))
        for group in sorted({group_of[u] for u in units}):  # judged among units with the same finding
            idx = [j for j, u in enumerate(units) if group_of[u] == group]
            if len(idx) >= 5:  # fewer units give no spread worth judging against
                z = robust_z(x[idx])
                outliers += [Outlier(units[j], name, group, float(x[j]), float(s))
                             for j, s in zip(idx, z) if abs(s) > threshold]
    outliers.sort(key=lambda o: (o.unit, o.quantity))
    unnamed = sum(not r.named for r in ok)
    return Population(
        units=len(records), ok=n, errors=len(records) - n,
        prevalence=prevalence, prevalence_by_family=families, prevalence_primary_family=primary,
        none_named=NoneNamed(unnamed, unnamed / n if n else None),
        confidence=dict(sorted(confidence.items())),
        parameters=dists, outlier_threshold=threshold, outliers=tuple(outliers),
        failed=tuple(FailedUnit(r.unit, r.error or "") for r in records if not r.ok))


def table_rows(records: list[FleetRow]) -> tuple[list[str], list[dict]]:
    """One flat row per unit, sorted by unit id; deterministic (no timings, paths relative to the
    output folder), so two executors give identical tables.

    Parameters
    ----------
    records : list of FleetRow

    Returns
    -------
    header : list of str
        The columns: fixed ones, then every quantity and its 95 % bounds, then files and report.
    rows : list of dict
        Column → value (each quantity in its own unit; None: empty).
    """
    rows = []
    for r in sorted(records, key=lambda r: r.unit):
        row = {"unit": r.unit, "status": r.status, "error": r.error or "",
               "named": ";".join(r.named or ()), "families": ";".join(r.families or ()),
               "confidence": r.confidence or "", "files": ";".join(r.files), "report": r.report}
        for k in SCALARS:
            row[k] = getattr(r, k)
        for name, p in sorted((r.parameters or {}).items()):
            row[name] = p.value
            row[f"{name}.ci95_low"], row[f"{name}.ci95_high"] = (p.ci95 if p.ci95 else (None, None))
        rows.append(row)
    fixed = ["unit", "status", "error", "named", "families", "confidence", *SCALARS]
    params = sorted({k for row in rows for k in row} - set(fixed) - {"files", "report"})
    return fixed + params + ["files", "report"], rows


def write_table(out_dir: Path, records: list[FleetRow]) -> list[Path]:
    """``table.csv`` (and ``table.parquet`` when pyarrow is installed), written atomically.

    Parameters
    ----------
    out_dir : Path
        The fleet's output folder.
    records : list of FleetRow

    Returns
    -------
    list of Path
        The files written.
    """
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


def write_population(out_dir: Path, pop: Population) -> Path:
    """``population.json``, written atomically (:func:`twin.results.to_json`).

    Parameters
    ----------
    out_dir : Path
        The fleet's output folder.
    pop : Population

    Returns
    -------
    Path
    """
    from twin.results import to_json

    return atomic_write_text(out_dir / "population.json", json.dumps(to_json(pop), indent=2, allow_nan=False) + "\n")
