"""A fleet's population view in words and tables: the rows ``summary.html`` and a notebook show
(``_repr_html_`` of :class:`~twin.fleet.result.FleetResult`), written through :mod:`twin.html`."""

from __future__ import annotations

from typing import TYPE_CHECKING

from twin.html import fragment, heading, number, table_html

if TYPE_CHECKING:
    from twin.fleet.result import FleetResult, Population

#: the header of :func:`prevalence_rows`
PREVALENCE_HEADER = ["counted as", "effect or family", "units", "share", "Wilson 95 %"]
#: the header of :func:`distribution_rows`
DISTRIBUTION_HEADER = ["quantity", "unit", "units", "median", "MAD", "5 %", "95 %"]


def prevalence_rows(view: Population | FleetResult) -> list[list[str]]:
    """How many units name each effect and family, with the share's Wilson interval.

    Parameters
    ----------
    view : Population or FleetResult

    Returns
    -------
    list of list of str
        Rows under :data:`PREVALENCE_HEADER`.
    """
    counts = (("named", view.prevalence), ("family named", view.prevalence_by_family),
              ("family named first", view.prevalence_primary_family))
    return [[label, k, str(v.units), number(v.share, ".1f", 100, " %"),
             f"[{100 * v.ci95[0]:.1f}, {100 * v.ci95[1]:.1f}] %"] for label, counted in counts for k, v in counted.items()]


def distribution_rows(view: Population | FleetResult) -> list[list[str]]:
    """Each quantity over the units that have it: median, MAD and the 5 % and 95 % quantiles.

    Parameters
    ----------
    view : Population or FleetResult

    Returns
    -------
    list of list of str
        Rows under :data:`DISTRIBUTION_HEADER`.
    """
    return [[k, v.unit, str(v.units), number(v.median, ".4g"), number(v.mad, ".3g"), number(v.q05, ".4g"),
             number(v.q95, ".4g")] for k, v in view.parameters.items()]


def fleet_html(result: FleetResult) -> str:
    """The notebook display of ``twin fleet``: what ran, how many units name each effect, the
    distributions, the outliers and the failed units.

    Parameters
    ----------
    result : FleetResult

    Returns
    -------
    str
        An HTML fragment.
    """
    confidence = ", ".join(f"{k} {v}" for k, v in result.confidence.items()) or "none"
    sentences = [f"{result.units} units: {result.ok} analysed, {result.errors} failed ({result.ran} analysed by this "
                 f"run, {result.skipped} finished before it). Confidence labels: {confidence}. Output: {result.output}.",
                 *result.notes]
    return fragment("twin fleet", sentences, heading("Named effects", 4), table_html(prevalence_rows(result), PREVALENCE_HEADER, merge=1),
                    heading("Distributions", 4), table_html(distribution_rows(result), DISTRIBUTION_HEADER),
                    heading(f"Outliers (|robust z| > {result.outlier_threshold:g})", 4) if result.outliers else "",
                    table_html([[o.unit, o.quantity, o.group, number(o.value, ".4g"), number(o.robust_z, "+.1f")]
                           for o in result.outliers], ["unit", "quantity", "among units of finding", "value", "robust z"]),
                    heading("Failed units", 4) if result.failed else "",
                    table_html([[f.unit, f.error] for f in result.failed], ["unit", "error"]))
