"""Plots and an HTML page for ``twin benchmark --report`` (matplotlib, imported here only)."""

from __future__ import annotations

import html
import json
from pathlib import Path

from twin.io import atomic_write_text
from twin.reporting.plots import png_base64
from twin.reporting.study_plots import benchmark_displays


def write_benchmark_report(directory: Path, result: dict) -> Path:
    import matplotlib

    matplotlib.use("Agg")

    directory.mkdir(parents=True, exist_ok=True)
    figs = [(disp.title, png_base64(disp.plot())) for disp in benchmark_displays(result)]
    body = "".join(f"<h3>{html.escape(t)}</h3><img src='data:image/png;base64,{b}'>" for t, b in figs)
    verdicts = "".join(f"<li>{html.escape(v)}</li>" for v in result["verdicts"])
    page = (f"<!doctype html><html><head><meta charset='utf-8'><title>twin benchmark</title></head><body "
            f"style='font-family:sans-serif;max-width:1000px;margin:auto'><h1>Compensation benchmark</h1><ul>{verdicts}</ul>"
            f"{body}<h2>Data</h2><pre>{html.escape(json.dumps(result, indent=1)[:20000])}</pre></body></html>")
    return atomic_write_text(directory / "report.html", page)
