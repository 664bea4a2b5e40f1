"""Plots and an HTML page for ``twin benchmark --report`` (matplotlib, imported here only)."""

from __future__ import annotations

from pathlib import Path

from twin.compensation.benchmark_result import BenchmarkResult
from twin.html import DASH
from twin.reporting.page import Page
from twin.reporting.plots import png_base64
from twin.reporting.study_plots import benchmark_displays


def write_benchmark_report(directory: Path, result: BenchmarkResult) -> Path:
    """Write ``report.html``: the verdicts first, then the paper's tables and the plots.

    Parameters
    ----------
    directory : Path
    result : BenchmarkResult
        The benchmark's result (``twin benchmark --json``).

    Returns
    -------
    Path
    """
    import matplotlib

    matplotlib.use("Agg")
    page = Page("Compensation benchmark", list(result.verdicts))
    page.text(f"{result.tests} test{'s' if result.tests != 1 else ''}{' (quick budget)' if result.quick else ''}; noise-only MSE "
              f"{result.noise_floor_mse:.3e} g² (what a perfect compensation leaves).")
    page.heading("Table 1: test MSE of each compensator")
    page.table([[r.model, f"{r.mse_mean:.3e}", f"{r.mse_std:.2e}" if result.tests > 1 else DASH, f"{r.ratio_mean:.3f}",
                 DASH if r.Q_percent is None else f"{sum(r.Q_percent) / len(r.Q_percent):.1f} %"]
                for r in result.table1],
               ["compensator", "MSE mean [g²]", "MSE std [g²]", "MSE / noise-only MSE", "Q vs conventional"])
    if result.table2:
        its = list(next(iter(result.table2.values())).mse_g2_at_iteration)
        page.heading("Table 2: MSE by iteration of the population search")
        page.table([[name] + [f"{t.mse_g2_at_iteration[i].mean:.3e}" for i in its]
                    for name, t in result.table2.items()], ["search"] + [f"iteration {i} [g²]" for i in its])
    page.heading("Plots")
    for disp in benchmark_displays(result.to_json()):  # the displays read the JSON document
        page.figure(png_base64(disp.plot()), disp.title)
    return page.write(directory / "report.html")
