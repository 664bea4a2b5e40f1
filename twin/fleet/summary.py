"""``summary.html``: one self-contained page of a fleet (plots embedded as PNG): prevalence of the
named effects with Wilson intervals, the confidence labels, the parameter distributions with
their outliers, the residual over the noise floor per unit, and the failed units."""

from __future__ import annotations

import html
from pathlib import Path

import numpy as np

from twin.fleet.population import unit_values
from twin.io import atomic_write_text

MAX_HISTOGRAMS = 12


def _fig(figsize=(7, 3.4)):
    import matplotlib

    if matplotlib.get_backend().lower() != "agg":
        matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt.subplots(figsize=figsize)


def _prevalence_png(pop: dict) -> str | None:
    from twin.reporting.plots import png_base64

    items = list(pop["prevalence"].items())
    if not items and pop["none_named"]["share"] is None:
        return None
    fig, ax = _fig()
    names = [k for k, _ in items] + ["(none named)"]
    shares = [100 * v["share"] for _, v in items] + [100 * (pop["none_named"]["share"] or 0.0)]
    lo = [100 * (v["share"] - v["ci95"][0]) for _, v in items] + [0.0]
    hi = [100 * (v["ci95"][1] - v["share"]) for _, v in items] + [0.0]
    ax.barh(names, shares, xerr=[lo, hi], color="#4a78c2", capsize=3)
    ax.set_xlabel("share of units [%] (Wilson 95 % interval)")
    ax.set_title(f"named effects over {pop['ok']} analysed units")
    return png_base64(fig)


def _histogram_png(name: str, units: list[str], x: np.ndarray, unit: str, flagged: set[str], threshold: float) -> str:
    from twin.reporting.plots import png_base64

    fig, ax = _fig((4.6, 3.0))
    ax.hist(x, bins=min(30, max(5, len(x) // 4)), color="#8aa9d6")
    out = np.array([u in flagged for u in units])
    if out.any():
        ax.plot(x[out], np.zeros(out.sum()), "rv", label=f"outlier in its group (|robust z| > {threshold:g})")
        ax.legend(fontsize=7)
    ax.axvline(np.median(x), color="k", lw=1)
    ax.set_xlabel(f"{name} [{unit}]" if unit else name, fontsize=8)
    ax.set_ylabel("units")
    return png_base64(fig)


def _ratio_png(records: list[dict]) -> str | None:
    from twin.reporting.plots import png_base64

    pts = [(r["unit"], r["residual_over_floor"], bool(r.get("named"))) for r in records
           if r["status"] == "ok" and r.get("residual_over_floor") is not None]
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
    ax.set_ylabel("residual RMS / noise floor")
    ax.legend(fontsize=7)
    return png_base64(fig)


def _table(rows: list[list], header: list[str]) -> str:
    head = "".join(f"<th>{html.escape(h)}</th>" for h in header)
    body = "".join("<tr>" + "".join(f"<td>{html.escape(str(c))}</td>" for c in r) + "</tr>" for r in rows)
    return f"<table><tr>{head}</tr>{body}</table>"


def write_summary(out_dir: Path, records: list[dict], pop: dict, title: str = "twin fleet") -> Path:
    """Write ``out_dir/summary.html`` (self-contained)."""
    ok = [r for r in records if r["status"] == "ok"]
    per_unit = {r["unit"]: unit_values(r) for r in ok}
    img = lambda b, t: "" if b is None else f"<figure><img src='data:image/png;base64,{b}'><figcaption>{html.escape(t)}</figcaption></figure>"  # noqa: E731
    hists = []
    ranked = sorted(pop["parameters"], key=lambda k: (-pop["parameters"][k]["units"], k))
    for name in ranked[:MAX_HISTOGRAMS]:
        units = [u for u in per_unit if name in per_unit[u]]
        if len(units) >= 3:
            x = np.array([per_unit[u][name] for u in units])
            flagged = {o["unit"] for o in pop["outliers"] if o["quantity"] == name}
            hists.append(img(_histogram_png(name, units, x, pop["parameters"][name]["unit"], flagged, pop["outlier_threshold"]),
                             f"{name}: {len(units)} units"))
    prev_rows = [[label, k, v["units"], f"{100 * v['share']:.1f} %", f"[{100 * v['ci95'][0]:.1f}, {100 * v['ci95'][1]:.1f}] %"]
                 for label, key in (("named", "prevalence"), ("family named", "prevalence_by_family"),
                                    ("family named first", "prevalence_primary_family"))
                 for k, v in pop[key].items()]
    dist_rows = [[k, v["unit"], v["units"], f"{v['median']:.4g}", f"{v['mad']:.3g}", f"{v['q05']:.4g}", f"{v['q95']:.4g}"]
                 for k, v in pop["parameters"].items()]
    out_rows = [[o["unit"], o["quantity"], o["group"], f"{o['value']:.4g}", f"{o['robust_z']:+.1f}"] for o in pop["outliers"]]
    fail_rows = [[f["unit"], f["error"]] for f in pop["failed"]]
    unit_rows = [[r["unit"], r["status"], ", ".join(r.get("named", [])) or "-", r.get("confidence") or "-",
                  "-" if r.get("residual_over_floor") is None else f"{r['residual_over_floor']:.3f}",
                  (r.get("reports") or {}).get("html", (r.get("reports") or {}).get("json", "")) or r.get("error", "")]
                 for r in sorted(records, key=lambda r: r["unit"])]
    page = f"""<!doctype html><html><head><meta charset="utf-8"><title>{html.escape(title)}</title>
<style>body{{font-family:sans-serif;max-width:1150px;margin:auto;padding:1em}} table{{border-collapse:collapse;margin:.5em 0}}
td,th{{border:1px solid #ccc;padding:2px 6px;font-size:13px}} figure{{display:inline-block;margin:4px}} img{{max-width:100%}}</style>
</head><body><h1>{html.escape(title)}</h1>
<p>{pop['units']} units: {pop['ok']} analysed, {pop['errors']} failed. Confidence labels: {html.escape(', '.join(f'{k} {v}' for k, v in pop['confidence'].items()) or '-')}.</p>
<h2>Named effects</h2>{_table(prev_rows, ['counted as', 'effect or family', 'units', 'share', 'Wilson 95 %'])}
{img(_prevalence_png(pop), 'prevalence of each named effect')}
<h2>Residual over the noise floor</h2>{img(_ratio_png(records), 'per unit; 1 = nothing left but noise')}
<h2>Parameter distributions</h2>{_table(dist_rows, ['quantity', 'unit', 'units', 'median', 'MAD', '5 %', '95 %'])}
{''.join(hists)}
<h2>Outliers (|robust z| &gt; {pop['outlier_threshold']:g}, z = (x − median) / (1.4826 MAD) among the units of the same finding)</h2>{_table(out_rows, ['unit', 'quantity', 'among units of finding', 'value', 'robust z'])}
<h2>Failed units</h2>{_table(fail_rows, ['unit', 'error'])}
<h2>Units</h2>{_table(unit_rows, ['unit', 'status', 'named', 'confidence', 'RMS / floor', 'report or error'])}
</body></html>"""
    return atomic_write_text(out_dir / "summary.html", page)
