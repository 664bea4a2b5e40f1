"""Self-contained HTML report of a compare run (plots embedded as PNG): it renders, never computes.

matplotlib is imported here only, so ``import twin`` stays light. Plots follow
docs/diagnosis.md §1 step 2: measured vs twin, residual with its noise band, residual vs
temperature (heating/cooling), ±1 g half-sum/half-difference, dwell settling, ACF and Allan
deviation against a noise-only reference, the ranking, and the error falling over the ledger.
"""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path
from typing import TYPE_CHECKING

from twin.finding.fragment import CANDIDATE_HEADER, candidate_rows, mg, summary_sentences
from twin.finding.ledger import append_ledger
from twin.finding.result import CompareResult
from twin.html import DASH, number
from twin.reporting.page import Page

#: how each grouping of the residual reads in the report
GROUPINGS = {"segment": "segment", "orientation": "orientation", "run": "run", "temperature_bin_c": "temperature [°C]"}

if TYPE_CHECKING:
    from twin.diagnosis.diagnose import Diagnosis


def _figures(d: Diagnosis, ledger: list[dict]) -> list[tuple[str, str]]:
    """(title, base64 PNG) of every display of the report."""
    from twin.reporting.diagnosis_plots import diagnosis_displays
    from twin.reporting.plots import png_base64

    return [(disp.title, png_base64(disp.plot())) for disp in diagnosis_displays(d, ledger)]


def ledger_and_report(ledger_dir: Path, report_dir: Path | None, d: Diagnosis, result: CompareResult,
                      title: str) -> CompareResult:
    """Append this model to the ledger in ``ledger_dir`` and (``report_dir`` given) write the report.

    Parameters
    ----------
    ledger_dir : Path
    report_dir : Path, optional
    d : Diagnosis
    result : CompareResult
    title : str

    Returns
    -------
    CompareResult
        ``result`` with its ledger.
    """
    lines, entries = append_ledger(ledger_dir, d, result)
    result = replace(result, ledger=entries)
    if report_dir is not None:
        write_report(report_dir, d, result, lines, title=title)
    return result


def write_report(directory: Path, d: Diagnosis, result: CompareResult, ledger: list[dict],
                 title: str = "twin compare") -> Path:
    """Write ``report.html`` (self-contained) into ``directory``.

    Parameters
    ----------
    directory : Path
    d : Diagnosis
        For the plots.
    result : CompareResult
        What the page says.
    ledger : list of dict
        The ledger lines of this data, this model last.
    title : str

    Returns
    -------
    Path
        The page written.
    """
    page = Page(title, summary_sentences(result))
    _finding_sections(page, result)
    page.heading("Test-plan audit: what this data cannot tell apart")
    page.table([[", ".join(a.effects), a.aliased_with or "each other", a.remedy] for a in result.aliases]
               + [[u.effect, u.reason, u.remedy] for u in result.untestable],
               ["effects", "aliased with / why", "what would separate them"])
    page.heading("Candidates (best first)")
    page.table(candidate_rows(result), CANDIDATE_HEADER)
    params = []
    for eff, entry in result.parameters.items():
        for name, item in entry.items():
            if item.role == "fixed":
                continue
            ci = item.ci95
            flag = "on bound" if item.on_bound else "outside range" if item.outside_physical_range else item.pinned or ""
            params.append([eff, name, number(item.value, ".4g"), item.unit, f"[{ci[0]:.4g}, {ci[1]:.4g}]" if ci else DASH,
                           flag])
    page.heading("Parameters (95 % intervals)")
    page.table(params, ["effect", "parameter", "value", "unit", "95 % interval", "flag"], merge=1)
    page.heading("The calibrated twin").code(d.fit.equation(d.problem.nuisance_names))
    page.heading("Ledger: the error step by step")
    page.table([[e["time_utc"].replace("T", " ").removesuffix("+00:00"), " + ".join(e["model"]), mg(e["rms_residual_g"]),
                 mg(e["heldout_rms_g"]), mg(e["noise_floor_g"]), number(e.get("delta_bic"), ".1f")] for e in ledger],
               ["time (UTC)", "model", "RMS [mg]", "held-out [mg]", "floor [mg]", "ΔBIC vs previous"])
    seg = result.residual
    page.heading("Where it fails")
    page.table([[label, k.replace("..", " to "), mg(v)] for group, label in GROUPINGS.items()
                for k, v in (getattr(seg, group) or {}).items()], ["grouping", "value", "RMS [mg]"], merge=1)
    page.heading("Plots")
    for t, b in _figures(d, ledger):
        page.figure(b, t)
    return page.write(directory / "report.html")


def _finding_sections(page: Page, result: CompareResult) -> None:
    """Look-alike mechanisms, residual structure and the discovery, when the result has them."""
    if result.lookalikes:
        page.heading(f"Look-alike mechanisms (attribution to a {result.attribution or '-'})")
        page.table([[m.name, "yes" if m.in_library else "no", m.effect or "-", m.reason, m.test] for m in result.lookalikes],
                   ["mechanism", "in library", "effect", "why it makes this signature", "test that separates"])
    if result.structure:
        page.heading("Structure the model leaves (not white noise)")
        page.table([[s.grouping.replace("_", " "), f"{s.rms_g * 1e3:.3f}", s.where, f"{s.departure_g * 1e3:+.3f}",
                     f"{s.delta_bic:.1f}", f"{s.p_adjusted:.2g}"] for s in result.structure],
                   ["grouping", "RMS [mg]", "largest at", "departure [mg]", "ΔBIC", "p (Bonferroni)"])
    disc = result.discovery
    if disc:
        page.heading("Discovery: a term outside the library")
        page.code(disc.equation or "nothing proposed")
        page.text(f"{disc.reason}; {disc.features_tried} terms tried; held-out gain {100 * disc.heldout_gain:.1f} %; "
                  f"ΔBIC {disc.delta_bic:.1f}; RMS {disc.rms_before_g * 1e3:.3f} → {disc.rms_predicted_g * 1e3:.3f} mg; "
                  f"plugin: {disc.plugin or 'not written'}.")
        if disc.terms:
            page.table([[t.feature.label, f"{t.coefficient_mg:.4g} ± {t.ci95_half_width_mg:.2g}", t.feature.unit,
                         f"{t.delta_bic:.1f}", f"{t.p_adjusted:.2g}"] for t in disc.terms],
                       ["term", "coefficient [mg per unit]", "unit", "ΔBIC", "p (× terms tried)"])
        page.table([[b.feature, f"{b.delta_bic:.1f}"] for b in disc.beaten], ["feature it beat", "ΔBIC"])
