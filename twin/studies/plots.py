"""A study's plots: main effects, the response surface of the first two numeric factors, Sobol
indices (matplotlib, imported here only)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from twin.studies.spec import Study


def write_plots(study: Study, rows: list[dict], analysis: dict, out_dir: Path, responses: list[str] | None = None) -> None:
    """``main_effects.png``, ``response_surface.png``, ``sobol.png`` (the last two when they apply)
    of ``responses`` (default: all of the study's)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    responses = study.responses if responses is None else responses
    if not responses:
        return
    ok = [r for r in rows if r["status"] == "ok"]
    names = list(study.factors)
    fig, axes = plt.subplots(len(responses), len(names), figsize=(3.2 * len(names), 2.6 * len(responses)),
                             squeeze=False)
    for i, resp in enumerate(responses):
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
        fig, axes = plt.subplots(1, len(responses), figsize=(4.2 * len(responses), 3.6), squeeze=False)
        for k, resp in enumerate(responses):
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
        fig, axes = plt.subplots(1, len(responses), figsize=(4 * len(responses), 3.4), squeeze=False)
        for k, resp in enumerate(responses):
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
