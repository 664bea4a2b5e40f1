"""``summary.html``: one self-contained page of a fleet (plots embedded as PNG): prevalence of the
named effects with Wilson intervals, the confidence labels, the parameter distributions with
their outliers, the residual over the noise floor per unit, and the failed units."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from twin.fleet.fragment import DISTRIBUTION_HEADER, PREVALENCE_HEADER, distribution_rows, prevalence_rows
from twin.fleet.population import unit_values
from twin.fleet.result import FleetRow, Population
from twin.reporting.page import Page

MAX_HISTOGRAMS = 12


def _fig(figsize=(7, 3.4), rows: int = 1, cols: int = 1):
    from twin.reporting.plots import figure_grid

    return figure_grid(figsize, rows, cols)


def _prevalence_png(pop: Population) -> str | None:
    from twin.reporting.plots import png_base64

    items = list(pop.prevalence.items())
    if not items and pop.none_named.share is None:
        return None
    fig, ax = _fig()
    names = [k for k, _ in items] + ["(none named)"]
    shares = [100 * v.share for _, v in items] + [100 * (pop.none_named.share or 0.0)]
    lo = [100 * (v.share - v.ci95[0]) for _, v in items] + [0.0]
    hi = [100 * (v.ci95[1] - v.share) for _, v in items] + [0.0]
    ax.barh(names, shares, xerr=[lo, hi], color="#4a78c2", capsize=3)
    ax.set_xlabel("share of units [%] (Wilson 95 % interval)")
    ax.set_title(f"named effects over {pop.ok} analysed units")
    return png_base64(fig)


def _histograms_png(pop: Population, per_unit: dict[str, dict[str, float]]) -> str | None:
    """One figure of small histograms, a panel per quantity held by at least three units (the most
    widely held first, at most :data:`MAX_HISTOGRAMS`): median line, outliers of their group in red."""
    from twin.reporting.plots import png_base64

    names = [k for k in sorted(pop.parameters, key=lambda k: (-pop.parameters[k].units, k))
             if sum(k in v for v in per_unit.values()) >= 3][:MAX_HISTOGRAMS]
    if not names:
        return None
    cols = min(3, len(names))
    rows = -(-len(names) // cols)
    fig, axes = _fig((11, 2.7 * rows), rows, cols)
    for ax in np.ravel(axes)[len(names):]:
        ax.set_visible(False)
    for ax, name in zip(np.ravel(axes), names):
        units = [u for u in per_unit if name in per_unit[u]]
        x = np.array([per_unit[u][name] for u in units])
        flagged = {o.unit for o in pop.outliers if o.quantity == name}
        ax.hist(x, bins=min(30, max(5, len(x) // 4)), color="#8aa9d6")
        out = np.array([u in flagged for u in units])
        if out.any():
            ax.plot(x[out], np.zeros(out.sum()), "rv", label=f"outlier (|robust z| > {pop.outlier_threshold:g})")
            ax.legend(fontsize=7)
        ax.axvline(np.median(x), color="k", lw=1)
        unit = pop.parameters[name].unit
        ax.set_title(f"{name} [{unit}]" if unit else name, fontsize=9)
        ax.set_ylabel("units", fontsize=8)
        ax.yaxis.get_major_locator().set_params(integer=True)
        ax.tick_params(labelsize=8)
    fig.tight_layout()
    return png_base64(fig)


def _ratio_png(records: list[FleetRow]) -> str | None:
    from twin.reporting.plots import png_base64

    pts = [(r.unit, r.residual_over_floor, bool(r.named)) for r in records
           if r.ok and r.residual_over_floor is not None]
    if not pts:
        return None
    fig, ax = _fig()
    i = np.arange(len(pts))
    ratio = np.array([p[1] for p in pts])
    named = np.array([p[2] for p in pts])
    ax.plot(i[~named], ratio[~named], "o", ms=3, color="#777", label="nothing named")
    ax.plot(i[named], ratio[named], "o", ms=3, color="#c23", label="an effect named")
    ax.axhline(1.0, color="k", lw=0.8)
    ax.set_xlabel("unit (sorted by id)")
    ax.xaxis.get_major_locator().set_params(integer=True)
    ax.set_ylabel("residual RMS / noise floor")
    ax.legend(fontsize=7)
    return png_base64(fig)


def write_summary(out_dir: Path, records: list[FleetRow], pop: Population, title: str = "twin fleet") -> Path:
    """Write ``out_dir/summary.html`` (self-contained).

    Parameters
    ----------
    out_dir : Path
        The fleet's output folder.
    records : list of FleetRow
        Every finished unit's row.
    pop : Population
        Their population view.
    title : str

    Returns
    -------
    Path
    """
    ok = [r for r in records if r.ok]
    per_unit = {r.unit: unit_values(r) for r in ok}
    confidence = ", ".join(f"{k} {v}" for k, v in pop.confidence.items()) or "none"
    page = Page(title, [f"{pop.units} units: {pop.ok} analysed, {pop.errors} failed. Confidence labels: {confidence}."])
    page.heading("Named effects")
    page.table(prevalence_rows(pop), PREVALENCE_HEADER, merge=1)
    page.figure(_prevalence_png(pop), "prevalence of each named effect")
    page.heading("Residual over the noise floor").figure(_ratio_png(records), "per unit; 1 = nothing left but noise")
    page.heading("Parameter distributions")
    page.table(distribution_rows(pop), DISTRIBUTION_HEADER)
    page.figure(_histograms_png(pop, per_unit), "each quantity over the units that have it (black line: the median)")
    page.heading("Outliers")
    page.text(f"Units whose |robust z| > {pop.outlier_threshold:g}, z = (x − median) / (1.4826 MAD) among the units "
              "of the same finding.")
    page.table([[o.unit, o.quantity, o.group, f"{o.value:.4g}", f"{o.robust_z:+.1f}"] for o in pop.outliers],
               ["unit", "quantity", "among units of finding", "value", "robust z"])
    page.heading("Failed units").table([[f.unit, f.error] for f in pop.failed], ["unit", "error"])
    page.heading("Units")
    page.table([[r.unit, r.status, ", ".join(r.named or ()) or "-", r.confidence or "-",
                 "-" if r.residual_over_floor is None else f"{r.residual_over_floor:.3f}", r.report or r.error or ""]
                for r in sorted(records, key=lambda r: r.unit)],
               ["unit", "status", "named", "confidence", "RMS / floor", "report or error"])
    return page.write(out_dir / "summary.html")
