"""A study in words and tables: what a notebook shows of ``twin doe`` (``_repr_html_`` of
:class:`~twin.studies.result.DoeResult`), written through :mod:`twin.html`."""

from __future__ import annotations

from typing import TYPE_CHECKING

from twin.html import fragment, heading, number, table_html

if TYPE_CHECKING:
    from twin.studies.result import DoeResult


def doe_html(result: DoeResult) -> str:
    """The notebook display of a study: its runs, each factor's main effect on each response, the
    interactions and (a Saltelli design) the Sobol indices.

    Figures are in each response's unit (``docs/doe.md`` lists them).

    Parameters
    ----------
    result : DoeResult

    Returns
    -------
    str
        An HTML fragment.
    """
    sentences = [f"{result.runs} of {result.planned} runs finished, {result.failed} failed; output in {result.output}. "
                 "Effects are in each response's unit."]
    effects = [[f, r, number(e.effect, ".4g"), ", ".join(f"{k}: {number(v, '.4g')}" for k, v in e.means.items())]
               for f, per in result.main_effects.items() for r, e in per.items()]
    pairs = [[ab, r, number(v, ".4g")] for ab, per in result.interactions.items() for r, v in per.items()]
    sobol = [[r, f, number(i.S1, ".2f"), f"[{i.S1_ci95[0]:.2f}, {i.S1_ci95[1]:.2f}]", number(i.ST, ".2f"),
              f"[{i.ST_ci95[0]:.2f}, {i.ST_ci95[1]:.2f}]"] for r, per in (result.sobol or {}).items() for f, i in per.items()]
    return fragment("twin doe", sentences,
                    table_html(effects, ["factor", "response", "main effect (largest − smallest mean)", "mean at each level"],
                          merge=1),
                    heading("Interactions (factors scaled to ±1)", 4) if pairs else "",
                    table_html(pairs, ["factors", "response", "coefficient"], merge=1),
                    heading("Sobol indices", 4) if sobol else "",
                    table_html(sobol, ["response", "factor", "S1 [1]", "S1 95 %", "ST [1]", "ST 95 %"], merge=1))
