"""A compare result in words and tables: the sentences and rows both the HTML report and a notebook
show (``_repr_html_`` of :class:`~twin.finding.result.CompareResult` and the per-IMU results).

Written once, here, through :mod:`twin.html`, so a figure reads the same on the page and in a cell:
in mg, with its unit in the column header, and never as Python prints it.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from twin.html import DASH, fragment, heading, number, table_html, yes_no

if TYPE_CHECKING:
    from twin.finding.result import AxesCompareResult, CompareResult, ImuCompareResult

#: the header of :func:`candidate_rows`
CANDIDATE_HEADER = ["effect", "family", "significant", "ΔBIC", "p (Bonferroni)", "held-out gain", "explained",
                    "RMS after [mg]", "best grid point"]
#: the header of :func:`ledger_rows`
LEDGER_HEADER = ["model", "RMS [mg]", "held-out [mg]", "floor [mg]", "ΔBIC vs previous"]


def mg(value_g: float | None) -> str:
    """A figure in g written in mg with three decimals (a dash when there is none).

    Parameters
    ----------
    value_g : float or None
        [g].

    Returns
    -------
    str
    """
    return number(value_g, ".3f", 1e3)


def named_sentence(result: CompareResult) -> str:
    """What is named missing, and how sure, in one sentence.

    Parameters
    ----------
    result : CompareResult

    Returns
    -------
    str
    """
    if not result.selected:
        return f"No missing effect is named (confidence: {result.confidence})."
    return f"Named missing: {', '.join(result.selected)} (confidence: {result.confidence})."


def summary_sentences(result: CompareResult) -> list[str]:
    """The result in plain sentences: the verdict, the errors and the model, then the finding in full.

    Parameters
    ----------
    result : CompareResult

    Returns
    -------
    list of str
    """
    floors = f"noise floor {mg(result.noise_floor_g)} mg from the data" + (
        "" if result.noise_floor_model_g is None else f", {mg(result.noise_floor_model_g)} mg from the sensor model")
    return [named_sentence(result),
            f"Residual RMS {mg(result.rms_residual_g)} mg at {result.sample_rate_hz:.3g} Hz; {floors}; held-out RMS "
            f"({result.noise_model.average_s:g}-s means) {mg(result.heldout_rms_g)} mg. Model: "
            f"{', '.join(result.effects) or 'offsets only'}; noise model AR({result.noise_model.ar_order}).",
            result.finding]


def candidate_rows(result: CompareResult, limit: int | None = None) -> list[list[str]]:
    """The screened effects, best first, as rows under :data:`CANDIDATE_HEADER`.

    Parameters
    ----------
    result : CompareResult
    limit : int, optional
        At most this many rows.

    Returns
    -------
    list of list of str
    """
    return [[c.effect, c.family, yes_no(c.significant), number(c.delta_bic, ".1f"), number(c.p_adjusted, ".2g"),
             number(c.heldout_gain, ".1f", 100, " %"), number(c.explained_fraction, ".1f", 100, " %"),
             mg(c.rms_residual_g), ", ".join(f"{k} = {v:.3g}" for k, v in c.parameters.items()) or DASH]
            for c in result.candidates[:limit]]


def ledger_rows(result: CompareResult) -> list[list[str]]:
    """Every model compared with this data (this one last), as rows under :data:`LEDGER_HEADER`.

    Parameters
    ----------
    result : CompareResult

    Returns
    -------
    list of list of str
        Empty when the result has no ledger.
    """
    return [[" + ".join(e.model), mg(e.rms_residual_g), mg(e.heldout_rms_g), mg(e.noise_floor_g),
             number(e.delta_bic, ".1f")] for e in result.ledger or ()]


def compare_html(result: CompareResult) -> str:
    """The notebook display of a compare result: its sentences, its errors, the best candidates
    and the ledger.

    Parameters
    ----------
    result : CompareResult

    Returns
    -------
    str
        An HTML fragment.
    """
    errors = table_html([["residual RMS", mg(result.rms_residual_g)], ["noise floor (data)", mg(result.noise_floor_g)],
                    ["noise floor (sensor model)", mg(result.noise_floor_model_g)],
                    ["held-out RMS", mg(result.heldout_rms_g)],
                    ["RMS with the named effects", mg(result.rms_after_selected_g) if result.selected else DASH]],
                   ["error", "value [mg]"])
    keep = [0, 1, 2, 3, 5, 7]  # effect, family, significant, ΔBIC, held-out gain, RMS after
    return fragment("twin compare", summary_sentences(result), errors, heading("Candidates (best first)", 4),
                    table_html([[row[k] for k in keep] for row in candidate_rows(result, 5)], [CANDIDATE_HEADER[k] for k in keep]),
                    heading("Ledger: the error step by step", 4) if result.ledger else "",
                    table_html(ledger_rows(result), LEDGER_HEADER))


def _axis_rows(imu: ImuCompareResult) -> list[list[str]]:
    return [[f"IMU {imu.instance}", axis, ", ".join(r.selected) or DASH, r.confidence, mg(r.rms_residual_g),
             mg(r.noise_floor_g), mg(r.heldout_rms_g)] for axis, r in imu.axes.items()]


_AXIS_HEADER = ["IMU", "axis", "named missing", "confidence", "RMS [mg]", "noise floor [mg]", "held-out [mg]"]


def imu_html(result: ImuCompareResult) -> str:
    """The notebook display of one IMU compared per axis: its joint finding and a row per axis.

    Parameters
    ----------
    result : ImuCompareResult

    Returns
    -------
    str
        An HTML fragment.
    """
    device = "device id not logged" if result.device_id is None else f"device id {result.device_id}"
    return fragment(f"twin compare: IMU {result.instance} ({device})", [result.finding],
                    table_html(_axis_rows(result), _AXIS_HEADER, merge=1))


def axes_html(result: AxesCompareResult) -> str:
    """The notebook display of ``twin compare --axes``: the finding and a row per IMU and axis.

    Parameters
    ----------
    result : AxesCompareResult

    Returns
    -------
    str
        An HTML fragment.
    """
    return fragment("twin compare --axes", [result.finding],  # it holds each IMU's finding
                    table_html([row for imu in result.imus for row in _axis_rows(imu)], _AXIS_HEADER, merge=1))
