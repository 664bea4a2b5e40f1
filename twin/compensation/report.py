"""Plots and an HTML page for ``twin benchmark --report`` (matplotlib, imported here only)."""

from __future__ import annotations

import html
import json
from pathlib import Path

from twin.io import atomic_write_text
from twin.reporting.plots import png_base64


def write_benchmark_report(directory: Path, result: dict) -> Path:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    directory.mkdir(parents=True, exist_ok=True)
    figs = []
    fig, ax = plt.subplots(figsize=(8, 3.8))
    rows = result["table1"]
    ax.bar([r["model"] for r in rows], [r["ratio_mean"] for r in rows], yerr=[0 for _ in rows], color="C0")
    ax.axhline(1.0, color="k", ls=":", label="noise floor")
    ax.set_ylabel("MSE / noise floor")
    ax.tick_params(axis="x", rotation=30)
    ax.set_ylim(min(0.98, min(r["ratio_mean"] for r in rows) * 0.99), None)
    ax.legend()
    figs.append(("Table 1 as a ratio to the noise floor (mean over tests)", png_base64(fig)))
    fig, ax = plt.subplots(figsize=(7, 3.8))
    for name, t in result["table2"].items():
        its = sorted(int(k) for k in t["mse_g2_at_iteration"])
        ax.plot(its, [t["mse_g2_at_iteration"][str(i)]["mean"] for i in its], "o-", label=name)
    ax.axhline(result["noise_floor_mse"], color="k", ls=":", label="noise floor")
    ax.set_yscale("log")
    ax.set_xlabel("iteration (GA generation / PSO-GA step)")
    ax.set_ylabel("training MSE of the search winner [g²]")
    ax.legend(fontsize=8)
    figs.append(("Table 2: MSE vs iteration before back-propagation", png_base64(fig)))
    for label, split in (("extrapolation split (train ≤ 30 °C, test > 30 °C)", result.get("extrapolation_split")),
                         ("ramp-rate split (test at twice the ramp rate)", result.get("ramp_rate_split"))):
        if not split:
            continue
        fig, ax = plt.subplots(figsize=(8, 3.5))
        names = [k for k in split if k != "noise_floor"]
        ax.bar(names, [split[k] / split["noise_floor"] for k in names], color="C1")
        ax.axhline(1.0, color="k", ls=":")
        ax.set_yscale("log")
        ax.set_ylabel("MSE / noise floor")
        ax.tick_params(axis="x", rotation=30)
        figs.append((label, png_base64(fig)))
    body = "".join(f"<h3>{html.escape(t)}</h3><img src='data:image/png;base64,{b}'>" for t, b in figs)
    verdicts = "".join(f"<li>{html.escape(v)}</li>" for v in result["verdicts"])
    page = (f"<!doctype html><html><head><meta charset='utf-8'><title>twin benchmark</title></head><body "
            f"style='font-family:sans-serif;max-width:1000px;margin:auto'><h1>Compensation benchmark</h1><ul>{verdicts}</ul>"
            f"{body}<h2>Data</h2><pre>{html.escape(json.dumps(result, indent=1)[:20000])}</pre></body></html>")
    return atomic_write_text(directory / "report.html", page)
