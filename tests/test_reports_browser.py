"""The HTML reports as a person sees them: each page opened in headless Chromium at a 1280-px-wide
window, with a script run in the page that measures what the reader gets.

Checked on the compare, calibration, benchmark and fleet reports, on a page built to stress the
page builder (a table of 40 columns, unbroken tokens, long equations, a small plot) and on the
notebook displays (``_repr_html_``) of the results: nothing runs off the page sideways, no text
overflows its box unless a box that scrolls holds it, no value is written as Python prints it, and
every plot has loaded and is shown at least 600 px wide. A page made to fail shows the checks bite.
Screenshots of the compare and calibration reports are written for a person to look at (the path
is printed; ``TWIN_SCREENSHOTS=DIR`` keeps them). Skipped only when there is no Chromium binary.
"""

import html
import json
import os
import re
import shutil
import subprocess
import tempfile
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import pytest

from conftest import ROOT, coarse_text, run_in_process
from logfixtures import chamber_run, write_ulog

CHROMIUM = next((p for p in map(shutil.which, ("chromium", "chromium-browser")) if p), None)
pytestmark = pytest.mark.skipif(CHROMIUM is None, reason="no chromium binary on PATH (apt-get install chromium): "
                                                         "the reports cannot be opened in a browser")
WIDTH = 1280
MIN_PLOT_PX = 600
#: a value as Python prints it, in the text a person reads
PYTHON_REPR = re.compile(r"\b(True|False|None|nan|NaN)\b|\{'|\['|array\(|<twin\.|\bdict_")

#: run on load: what a reader gets, written as JSON into <pre id="check"> for --dump-dom
CHECK_JS = """
window.addEventListener('load', function () {
  function scrolls(el) {
    for (var a = el.parentElement; a; a = a.parentElement) {
      var ox = getComputedStyle(a).overflowX;
      if (ox === 'auto' || ox === 'scroll') return true;
    }
    return false;
  }
  var overflowing = [];
  document.querySelectorAll('body *').forEach(function (el) {
    if (el.clientWidth > 0 && el.scrollWidth > el.clientWidth + 1 && getComputedStyle(el).overflowX === 'visible'
        && !scrolls(el))
      overflowing.push(el.tagName.toLowerCase() + ' ' + el.scrollWidth + ' > ' + el.clientWidth + ': '
                       + (el.innerText || '').slice(0, 80));
  });
  var images = [];
  document.querySelectorAll('img').forEach(function (im) {
    images.push({alt: im.alt, loaded: im.complete && im.naturalWidth > 0, natural: im.naturalWidth,
                 shown: Math.round(im.getBoundingClientRect().width), room: im.parentElement.clientWidth});
  });
  var out = {scrollWidth: document.documentElement.scrollWidth, innerWidth: window.innerWidth,
             height: document.documentElement.scrollHeight, overflowing: overflowing, images: images,
             text: document.body.innerText};
  var pre = document.createElement('pre');
  pre.id = 'check';
  pre.textContent = JSON.stringify(out);
  document.body.appendChild(pre);
});
"""


def chromium(*args: str, timeout: float = 120) -> subprocess.CompletedProcess:
    """Headless Chromium with a fresh profile and no network chatter."""
    with tempfile.TemporaryDirectory(prefix="twin-chromium-") as profile:
        return subprocess.run([CHROMIUM, "--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
                               "--disable-background-networking", "--disable-component-update", "--disable-sync",
                               "--hide-scrollbars", f"--user-data-dir={profile}", *args],
                              capture_output=True, text=True, timeout=timeout)


def measure(page: Path, work: Path) -> dict:
    """Open a copy of ``page`` with :data:`CHECK_JS` added at a 1280-px window; what the script found."""
    copy = work / f"{page.parent.name}_{page.stem}_checked.html"
    copy.write_text(page.read_text().replace("</body>", f"<script>{CHECK_JS}</script></body>"))
    r = chromium(f"--window-size={WIDTH},2400", "--virtual-time-budget=10000", "--dump-dom", copy.as_uri())
    found = re.search(r'<pre id="check">(.*?)</pre>', r.stdout, re.S)
    assert found, f"{page}: the check did not run in Chromium (exit {r.returncode}): {r.stderr[-2000:]}"
    return json.loads(html.unescape(found.group(1)))


def problems(m: dict) -> list[str]:
    """Everything that reads badly in a page's measurement (empty: the page is fine)."""
    out = []
    if m["scrollWidth"] > m["innerWidth"]:
        out.append(f"the page is {m['scrollWidth']} px wide in a {m['innerWidth']}-px window")
    out += [f"text overflows its box: {o}" for o in m["overflowing"]]
    out += [f"Python representation in the text: …{m['text'][max(0, x.start() - 60):x.end() + 60]}…"
            for x in PYTHON_REPR.finditer(m["text"])]
    for im in m["images"]:
        if not im["loaded"]:
            out.append(f"plot not loaded: {im['alt']}")
        elif im["shown"] < min(MIN_PLOT_PX, im["room"]) - 1:
            out.append(f"plot shown {im['shown']} px wide with {im['room']} px of room: {im['alt']}")
    return out


def fleet_rows():
    """Eight analysed units and one that failed with a long one-line error."""
    from twin.fleet.result import FleetRow, ParameterValue, UnitReports

    rows = []
    for i in range(8):
        lag = i % 3 == 0
        named = ("thermal_lag",) if lag else ()
        params = {"static_bias_tc.tc1_mg_per_c": ParameterValue(0.5 + 0.02 * i + (0.6 if i == 7 else 0), "mg/degC",
                                                                (0.45, 0.6))}
        if lag:
            params["thermal_lag.tau_s"] = ParameterValue(200.0 + 10 * i, "s", (180.0, 260.0))
        rows.append(FleetRow(unit=f"unit{i:04d}", files=(f"logs/unit{i:04d}.csv",), command="compare", named=named,
                             families=("thermal_lag",) if lag else (), confidence="confident" if lag else "none",
                             detected=lag, finding="a finding", parameters=params, rms_residual_mg=1.4 + 0.1 * lag,
                             noise_floor_mg=1.37, residual_over_floor=(1.4 + 0.1 * lag) / 1.37, heldout_rms_mg=0.6,
                             samples=5000, reports=UnitReports(f"units/unit{i:04d}/compare.json"), status="ok",
                             seconds=2.0))
    rows.append(FleetRow(unit="unit0008", files=("logs/unit0008.csv",), command="compare", status="error", seconds=0.1,
                         error="logs/" + "a_very_long_folder_name_without_spaces/" * 6 + "unit0008.csv:12: temperature: "
                               "got 'abc', expected a number"))
    return rows


def notebook_cells(compare, calibration, fleet) -> str:
    """The results' notebook displays, as a notebook stacks them (no page stylesheet)."""
    from twin.studies.result import DoeResult, MainEffect, SobolIndex

    doe = DoeResult(output="out/study", runs=8, planned=8, failed=0,
                    main_effects={"ramp_c_per_h": {"rms_mg": MainEffect({"30": 1.2, "60": 1.9}, 0.7)}},
                    interactions={"ramp_c_per_h × die_tau_s": {"rms_mg": 0.11}},
                    sobol={"rms_mg": {"ramp_c_per_h": SobolIndex(0.6, (0.5, 0.7), 0.65, (0.55, 0.75))}})
    cells = [compare._repr_html_(), calibration._repr_html_(), fleet._repr_html_(), doe._repr_html_()]
    return ("<!doctype html><html><head><meta charset='utf-8'></head><body style='font-family:sans-serif'>"
            + "".join(f"<div style='margin:1em 0;padding:.5em;border:1px solid #eee'>{c}</div>" for c in cells)
            + "</body></html>")


def stress_page(folder: Path) -> Path:
    """A page holding what could run off a page: wide tables, unbroken tokens, long equations, small plots."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from twin.reporting.page import Page
    from twin.reporting.plots import png_base64

    token = "static_bias_tc.tc2_mg_per_c2" * 12
    page = Page(f"twin compare: {'/very/long/path' * 20}/log.csv", [f"The file {'/x' * 150}.csv was read.", "Second."])
    page.heading(f"Heading {token}").text(f"A sentence with {token} inside.")
    page.table([[f"{k * 1.234567:.6f}" for k in range(40)] for _ in range(3)], [f"column {k} [mg]" for k in range(40)])
    page.table([[token, "x" * 400, "1.0"]], ["name", "text", "value [mg]"], merge=1)
    page.code("bias = " + " + ".join(f"{k}.{k}e-05·(T − 35 °C)^{k}" for k in range(60)) + "\n" + token + "\n\n  indented")
    fig, ax = plt.subplots(figsize=(2.5, 2))
    ax.plot([0, 1], [0, 1])
    page.figure(png_base64(fig), "a small figure")
    return page.write(folder / "stress" / "report.html")


@pytest.fixture(scope="module")
def reports(tmp_path_factory, quick_benchmark):
    """Every report, written once: compare (twice, the named effect added), calibration, fleet, the
    stress page, the notebook displays, and a page made to fail."""
    from twin.fleet.population import population
    from twin.fleet.summary import write_summary
    from twin.workflows.calibrate import CalibrateOptions, run_calibrate
    from twin.workflows.compare import CompareOptions, run_compare

    d = tmp_path_factory.mktemp("browser")
    scn = d / "lag.yaml"
    scn.write_text(coarse_text(ROOT / "scenarios" / "hidden_thermal_lag.yaml", rate_hz=0.5))
    code, _, err = run_in_process(["run", scn, "-o", d / "lag.h5", "-q"])
    assert code == 0, err
    run_compare(CompareOptions(scenario=scn, measurements=[d / "lag.h5"], report=d / "compare"))
    compared = run_compare(CompareOptions(scenario=scn, measurements=[d / "lag.h5"], report=d / "compare",
                                          with_effects=["thermal_lag"]))
    log = write_ulog(d / "chamber.ulg", chamber_run(n=600, heater=1))
    cal = run_calibrate(CalibrateOptions(logs=[log], imu="0"))
    cal.write_report(d / "calibration")
    rows = fleet_rows()
    pop = population(rows)
    write_summary(d / "fleet", rows, pop, title="twin fleet: nine units")
    from twin.fleet.result import FleetResult

    fleet = FleetResult(output=str(d / "fleet"), units=len(rows), ran=len(rows), skipped=0, notes=(), ok=pop.ok,
                        errors=pop.errors, prevalence=pop.prevalence, prevalence_by_family=pop.prevalence_by_family,
                        prevalence_primary_family=pop.prevalence_primary_family, none_named=pop.none_named,
                        confidence=pop.confidence, parameters=pop.parameters, outlier_threshold=pop.outlier_threshold,
                        outliers=pop.outliers, failed=pop.failed)
    (d / "notebook").mkdir()
    (d / "notebook" / "cells.html").write_text(notebook_cells(compared, cal.document, fleet))
    (d / "bad").mkdir()
    (d / "bad" / "page.html").write_text(
        "<!doctype html><html><body><div style='width:2000px'>wide</div><p style='width:300px;white-space:nowrap'>"
        + "x" * 200 + "</p><p>value: None, [1, 2]</p><img src='data:image/png;base64,QUJD' alt='broken'></body></html>")
    return {"compare": d / "compare" / "report.html", "calibration": d / "calibration" / "report.html",
            "benchmark": quick_benchmark / "rep" / "report.html", "fleet": d / "fleet" / "summary.html",
            "stress": stress_page(d), "notebook": d / "notebook" / "cells.html", "bad": d / "bad" / "page.html"}


@pytest.fixture(scope="module")
def measured(reports, tmp_path_factory):
    """Every page measured in Chromium (three at a time)."""
    work = tmp_path_factory.mktemp("checked")
    with ThreadPoolExecutor(3) as pool:
        return dict(zip(reports, pool.map(lambda p: measure(p, work), reports.values())))


@pytest.mark.parametrize("name", ["compare", "calibration", "benchmark", "fleet", "stress", "notebook"])
def test_report_reads_well_at_page_width(measured, name):
    m = measured[name]
    assert m["innerWidth"] == WIDTH and m["text"].strip()
    assert not problems(m), "\n".join(problems(m))
    if name in ("compare", "calibration", "benchmark", "fleet", "stress"):
        assert m["images"], "the report has no plot"


def test_the_checks_catch_a_page_that_reads_badly(measured):
    found = "\n".join(problems(measured["bad"]))
    assert "px wide in a 1280-px window" in found and "text overflows its box: p" in found
    assert "Python representation" in found and "None" in found and "[1, 2]" in found
    assert "plot not loaded: broken" in found


def test_screenshots_of_the_compare_and_calibration_reports(reports, tmp_path_factory, capsys):
    folder = Path(os.environ.get("TWIN_SCREENSHOTS") or tmp_path_factory.mktemp("report_screenshots"))
    folder.mkdir(parents=True, exist_ok=True)
    with ThreadPoolExecutor(2) as pool:
        shots = list(pool.map(lambda name: (folder / f"{name}.png", chromium(
            f"--window-size={WIDTH},2400", f"--screenshot={folder / f'{name}.png'}", reports[name].as_uri())),
            ("compare", "calibration")))
    for path, r in shots:
        assert path.is_file(), r.stderr[-2000:]
        head = path.read_bytes()[:24]
        assert head.startswith(b"\x89PNG") and int.from_bytes(head[16:20], "big") == WIDTH
    with capsys.disabled():
        print(f"\nscreenshots of the compare and calibration reports: {folder}")
