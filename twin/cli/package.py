"""``twin package``: the finite-element package / die / comb model's drift prediction."""

from __future__ import annotations

import dataclasses
from pathlib import Path
from typing import Annotated

import typer

from twin.cli.common import JsonOpt, app, emit_json, guard
from twin.results import to_json


@app.command()
def package(
    scenario: Annotated[Path, typer.Argument(help="scenario YAML (its package_fem effect, else the defaults)")],
    json_out: JsonOpt = None,
) -> None:
    """Die warpage, TCOff [mg/°C] and TCSo [ppm/°C] of the FE package model, split by material,
    beside the datasheet figures.
    \f

    Parameters
    ----------
    scenario : Path
        Scenario YAML (its ``package_fem`` effect, else the defaults).
    json_out : str, optional
        ``--json``: where the result goes (``-``: stdout).
    """
    from twin.model.scenario import load_scenario
    from twin.model.package import package_effect, package_prediction
    from twin.reporting.package_report import text_lines

    with guard(inputs=[scenario], outputs=[None if json_out in (None, "-") else json_out]):
        loaded = load_scenario(scenario)
        effect, source = package_effect(loaded)
        result = dataclasses.replace(package_prediction(effect, loaded.part), effect_source=source)
    if json_out != "-":
        typer.echo("\n".join(text_lines(result, source)))
    emit_json(to_json(result), json_out)
