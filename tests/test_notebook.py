"""Results in a notebook: the tutorial notebook runs (on this venv's kernel) and says what it should,
and every result's ``_repr_html_`` is a few plain sentences and tables a person reads: the finding
first, no value as Python prints it, well-formed HTML."""

import html
import re
import sys
from html.parser import HTMLParser

import pytest

from conftest import ROOT
from logfixtures import chamber_run, write_ulog

NOTEBOOK = ROOT / "docs" / "notebooks" / "compare_in_a_notebook.ipynb"
PYTHON_REPR = re.compile(r"\b(True|False|None|nan|NaN)\b|\{'|\['|array\(|<twin\.|\bdict_")
VOID = {"br", "img", "meta", "hr", "input", "link", "col", "wbr"}


class _Balance(HTMLParser):
    """Every tag opened is closed, in order; the text outside the <style> collected."""

    def __init__(self):
        super().__init__()
        self.stack, self.errors, self.text, self._style = [], [], [], False

    def handle_starttag(self, tag, attrs):
        if tag not in VOID:
            self.stack.append(tag)
        self._style = tag == "style"

    def handle_endtag(self, tag):
        if not self.stack or self.stack[-1] != tag:
            self.errors.append(f"</{tag}> closes {self.stack[-1:] or 'nothing'}")
        else:
            self.stack.pop()
        self._style = False

    def handle_data(self, data):
        if not self._style:
            self.text.append(data)


def read_fragment(fragment: str) -> str:
    """The text a person reads in an HTML fragment, after checking its tags balance."""
    parser = _Balance()
    parser.feed(fragment)
    parser.close()
    assert not parser.errors and not parser.stack, (parser.errors, parser.stack)
    return html.unescape(" ".join(parser.text))


def assert_reads_well(fragment: str, *sentences: str) -> str:
    """A result's display: balanced HTML, its sentences in it, no Python representation; its text."""
    assert fragment.startswith("<div class='twin-result'>") and "<table>" in fragment
    text = read_fragment(fragment)
    found = PYTHON_REPR.search(text)
    assert not found, text[max(0, found.start() - 80):found.end() + 80]
    for s in sentences:
        assert s in text, s
    return text


@pytest.fixture(scope="module")
def executed(tmp_path_factory):
    """The tutorial notebook executed by nbclient on the kernel ``python3`` (this venv's python)."""
    nbformat = pytest.importorskip("nbformat")
    nbclient = pytest.importorskip("nbclient")
    nb = nbformat.read(NOTEBOOK, as_version=4)
    assert all(c.get("outputs", []) == [] and c.get("execution_count") is None for c in nb.cells
               if c.cell_type == "code"), "the committed notebook holds outputs: clear them"
    folder = tmp_path_factory.mktemp("notebook")
    nbclient.NotebookClient(nb, kernel_name="python3", timeout=240,
                            resources={"metadata": {"path": str(folder)}}).execute()
    return nb


def _outputs(nb, kind=None):
    return [o for c in nb.cells if c.cell_type == "code" for o in c.outputs if kind is None or o.output_type == kind]


def _stdout(nb) -> str:
    return "".join(o.text for o in _outputs(nb, "stream") if o.name == "stdout")


def test_notebook_runs_on_this_venv_without_errors(executed):
    assert not _outputs(executed, "error"), [o.evalue for o in _outputs(executed, "error")]
    out = _stdout(executed)
    kernel_python = re.search(r"^python: (.+)$", out, re.M).group(1)
    kernel_prefix = re.search(r"^prefix: (.+)$", out, re.M).group(1)
    assert kernel_python == sys.executable and kernel_prefix == sys.prefix, (kernel_python, sys.executable)


def test_notebook_names_the_effect_and_the_error_falls(executed):
    shown = [o.data["text/html"] for o in _outputs(executed, "execute_result") if "text/html" in o.data]
    assert len(shown) == 2  # the result before and after, each shown as its HTML display
    before = assert_reads_well(shown[0], "Named missing: thermal_lag (confidence: confident).")
    assert "die lags the thermometer" in before  # the finding, first
    assert_reads_well(shown[1], "No missing effect is named")
    rms = re.search(r"residual RMS: ([\d.]+) mg -> ([\d.]+) mg \(noise floor ([\d.]+) mg\)", _stdout(executed))
    before_mg, after_mg, floor_mg = map(float, rms.groups())
    assert after_mg < 0.8 * before_mg and after_mg < 1.05 * floor_mg
    assert any("image/png" in o.data for o in _outputs(executed, "display_data"))  # the plot


def test_compare_display_tables_have_units_and_the_summary(executed):
    fragment = next(o.data["text/html"] for o in _outputs(executed, "execute_result") if "text/html" in o.data)
    assert "<th class='num'>value [mg]</th>" in fragment and "RMS after [mg]" in fragment
    assert "Residual RMS" in read_fragment(fragment)  # the summary sentence of the report


def test_calibration_fleet_and_study_displays(tmp_path):
    from twin.fleet.population import population
    from twin.fleet.result import FleetResult, FleetRow, ParameterValue
    from twin.studies.result import DoeResult, MainEffect
    from twin.workflows.calibrate import CalibrateOptions, run_calibrate

    doc = run_calibrate(CalibrateOptions(logs=[write_ulog(tmp_path / "c.ulg", chamber_run(n=300))], imu="0")).document
    text = assert_reads_well(doc._repr_html_(), "IMU 0 (device id ", "Recommended: PX4: ", "noise floor")
    assert "held-out x [mg]" in text

    rows = [FleetRow(unit=f"u{i}", files=(f"u{i}.csv",), command="compare", named=("thermal_lag",) if i % 2 else (),
                     families=("thermal_lag",) if i % 2 else (), confidence="confident" if i % 2 else "none",
                     parameters={"thermal_lag.tau_s": ParameterValue(200.0 + i, "s", None)}, rms_residual_mg=1.4,
                     noise_floor_mg=float("nan"), status="ok", seconds=1.0) for i in range(4)]
    rows.append(FleetRow(unit="u9", files=("u9.csv",), command="compare", status="error", error="bad file", seconds=0.1))
    pop = population(rows)
    fleet = FleetResult(output="out", units=5, ran=5, skipped=0, notes=(), ok=pop.ok, errors=pop.errors,
                        prevalence=pop.prevalence, prevalence_by_family=pop.prevalence_by_family,
                        prevalence_primary_family=pop.prevalence_primary_family, none_named=pop.none_named,
                        confidence=pop.confidence, parameters=pop.parameters, outlier_threshold=pop.outlier_threshold,
                        outliers=pop.outliers, failed=pop.failed)
    text = assert_reads_well(fleet._repr_html_(), "5 units: 4 analysed, 1 failed", "bad file")
    assert "thermal_lag.tau_s" in text and "50.0 %" in text

    doe = DoeResult(output="out", runs=4, planned=4, failed=0, main_effects={"ramp": {"rms_mg": MainEffect(
        {"30": 1.0, "60": float("nan")}, 0.5)}}, interactions={}, sobol=None)
    text = assert_reads_well(doe._repr_html_(), "4 of 4 runs finished, 0 failed")
    assert "60: –" in text  # a missing mean is a dash, never nan


def test_fragments_escape_and_align():
    from twin.html import fragment, number, table_html

    assert number(None) == number(float("nan")) == number(True) == "–" and number(0.5, ".1f", 100, " %") == "50.0 %"
    t = table_html([["a<b", "1.5", "–"], ["a<b", "-2e-05", "3 %"]], ["name", "x [mg]", "share"], merge=1)
    assert "a&lt;b" in t and "rowspan=2" in t and t.count("a&lt;b") == 1
    assert "<th class='num'>x [mg]</th>" in t and "<td class='num'>–</td>" in t and "<th>name</th>" in t
    assert table_html([], ["x"]) == "" and read_fragment(fragment("t <1>", ["s & t"], t)).count("s & t") == 1
