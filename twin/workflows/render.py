"""``twin render --fem`` as a function: the scenario's package solved, then drawn by :mod:`twin.reporting`."""

from __future__ import annotations

from pathlib import Path


def render_package(loaded, output: str | Path, *, temperature_c: float | None = None, sweep_c=None,
                   exaggeration: float = 50.0, progress=None) -> dict:
    """``twin render --fem``: the scenario's package_fem design solved and drawn (PNG or sweep GIF).

    Parameters
    ----------
    loaded : LoadedScenario
    output : str or Path
        ``.png`` for one temperature, ``.gif`` for a sweep.
    temperature_c : float, optional
        The temperature drawn [°C] (one frame).
    sweep_c : sequence of float, optional
        The temperatures of a sweep [°C].
    exaggeration : float
        Displacement scale of the drawing [1].
    progress : callable, optional
        Called with each temperature drawn.

    Returns
    -------
    RenderResult
        What was written: output, temperatures, frames, exaggeration, degrees of freedom.
    """
    from twin.model.package import package_effect, solve_checked
    from twin.reporting.fem_render import render_fem_png, render_fem_sweep

    effect, _ = package_effect(loaded)
    sol = solve_checked(effect)
    if sweep_c is None:
        render_fem_png(sol, temperature_c, output, exaggeration=exaggeration)
        temps = [float(temperature_c)]
    else:
        render_fem_sweep(sol, sweep_c, output, exaggeration=exaggeration, progress=progress)
        temps = [float(t) for t in sweep_c]
    from twin.reporting.results import RenderResult

    return RenderResult(output=str(output), temperatures_c=temps, frames=len(temps), exaggeration=exaggeration,
                        dofs=sol.n_dofs, field="package_fem")
