"""A study's plots: main effects, the response surface of the first two numeric factors, Sobol
indices, as grids of display objects (:mod:`twin.reporting.study_plots`)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from twin.reporting.study_plots import MainEffectDisplay, ResponseSurfaceDisplay, SobolDisplay
from twin.studies.result import StudyAnalysis
from twin.studies.spec import Study


def _grid(displays: list[list], size: tuple[float, float], path: Path) -> None:
    """Draw rows of displays into one figure and save it as PNG."""
    from twin.reporting.plots import figure_grid

    rows, cols = len(displays), max(len(r) for r in displays)
    fig, axes = figure_grid((size[0] * cols, size[1] * rows), rows, cols)
    axes = np.atleast_2d(axes)
    for i, row in enumerate(displays):
        for j, disp in enumerate(row):
            disp.plot(ax=axes[i][j])
    fig.tight_layout()
    from twin.io import atomic_path

    with atomic_path(Path(path)) as tmp:  # a kill or a full disk leaves no half image
        fig.savefig(tmp, dpi=90, format="png")


def write_plots(study: Study, rows: list[dict], analysis: StudyAnalysis, out_dir: Path,
                responses: list[str] | None = None) -> None:
    """``main_effects.png``, ``response_surface.png``, ``sobol.png`` (the last two when they apply)
    of ``responses`` (default: all of the study's).

    Parameters
    ----------
    study : Study
    rows : list of dict
        The table's rows.
    analysis : StudyAnalysis
    out_dir : Path
        The study's output folder.
    responses : list of str, optional
        The numeric responses plotted.
    """
    responses = study.responses if responses is None else responses
    if not responses:
        return
    ok = [r for r in rows if r["status"] == "ok"]
    names = list(study.factors)
    main = [[MainEffectDisplay(f, resp, list(m := analysis.main_effects[f][resp].means), list(m.values()))
             for f in names] for resp in responses]
    _grid(main, (3.2, 2.6), out_dir / "main_effects.png")
    numeric = [f for f in names if all(isinstance(r[f], (int, float)) for r in ok)]
    if len(numeric) >= 2 and len(ok) >= 4:
        a, b = numeric[:2]
        surfaces = [[ResponseSurfaceDisplay(a, b, resp, [r[a] for r in ok], [r[b] for r in ok], [r[resp] for r in ok])
                     for resp in responses]]
        _grid(surfaces, (4.2, 3.6), out_dir / "response_surface.png")
    if analysis.sobol:
        sobol = [[SobolDisplay(resp, list(s := analysis.sobol[resp]), [v.S1 for v in s.values()],
                               [v.ST for v in s.values()]) for resp in responses]]
        _grid(sobol, (4, 3.4), out_dir / "sobol.png")
