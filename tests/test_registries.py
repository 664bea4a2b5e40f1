"""The DOE response and compensator registries: every entry conforms, and one new file is enough
to add a response (study ``plugins:``) or a compensator (``twin benchmark --plugin``)."""

import json

import numpy as np
import pytest
from sklearn.base import clone

from conftest import ROOT, coarse_text, run_cli
from fitting import FeatureSet
from twin.compensation.benchmark import evaluate_split
from twin.compensation.registry import COMPENSATORS, CompensatorError, get_compensator, load_plugin
from twin.compensation.splits import last_cycle_test, subset
from twin.measurement import from_dataset
from twin.model.scenario import parse_scenario
from twin.model.simulate import simulate
from twin.studies.doe import RESPONSES, ResponseError, evaluate_run, get_response, load_study, plan

BUILTIN_RESPONSES = list(RESPONSES)
BUILTIN_COMPENSATORS = list(COMPENSATORS)

TINY_STUDY = """\
name: tiny
base: {base}
seed: 1
logger_rate_hz: 0.2
factors:
  program.cycles: {{levels: [1, 2]}}
responses: {responses}
"""


def _tiny_study(tmp_path, responses, extra=""):
    f = tmp_path / "study.yaml"
    f.write_text(TINY_STUDY.format(base=ROOT / "scenarios" / "hidden_aging.yaml", responses=responses) + extra)
    return f


# ------------------------------------------------------------------------------------ responses


@pytest.fixture(scope="module")
def one_run(tmp_path_factory):
    """Every built-in response evaluated on the first run of a tiny study."""
    study, base, _ = load_study(_tiny_study(tmp_path_factory.mktemp("tiny"), json.dumps(BUILTIN_RESPONSES)))
    return evaluate_run(plan(study, base)[0], study.responses)


@pytest.mark.parametrize("name", BUILTIN_RESPONSES)
def test_every_registered_response_conforms(name, one_run):
    r = get_response(name)
    assert r.name == name and name.isidentifier()
    assert isinstance(r.description, str) and len(r.description) > 10
    assert isinstance(r.unit, str)
    assert set(r.describe()) == {"name", "description", "unit", "module"}
    assert one_run["status"] == "ok", one_run.get("error")
    value = one_run["responses"][name]
    assert isinstance(value, str) or (isinstance(value, float) and np.isfinite(value))


def test_unknown_response_names_the_closest():
    with pytest.raises(ResponseError, match=r"unknown response 'drift_pp'; did you mean 'drift_pp_mg'\?"):
        get_response("drift_pp")


RESPONSE_PLUGIN = '''\
from twin.studies.responses import register_response


@register_response("thermometer_span_c", description="span of the logged temperature", unit="°C")
def thermometer_span_c(run):
    t = run.measurement.temperature_c
    return float(t.max() - t.min())


@register_response("longest_program", description="'long' for two cycles or more, else 'short'")
def longest_program(run):
    return "long" if run.scenario.program.cycles >= 2 else "short"
'''


def test_a_response_plugin_is_one_file(tmp_path):
    (tmp_path / "my_responses.py").write_text(RESPONSE_PLUGIN)
    study = _tiny_study(tmp_path, "[thermometer_span_c, longest_program, chamber_hours]",
                        "plugins: [my_responses.py]\n")
    out = tmp_path / "doe"
    r = run_cli("doe", str(study), "-o", str(out), "--json", "-")
    assert r.returncode == 0, r.stderr
    res = json.loads(r.stdout)
    assert res["runs"] == 2 and res["failed"] == 0
    rows = (out / "table.csv").read_text().splitlines()
    assert rows[0] == "index,replicate,status,program.cycles,thermometer_span_c,longest_program,chamber_hours,error"
    spans = [float(line.split(",")[4]) for line in rows[1:]]
    assert [line.split(",")[5] for line in rows[1:]] == ['"short"', '"long"']
    assert all(s > 10 for s in spans)  # hidden_aging's program spans 0..50 °C
    effects = res["main_effects"]["program.cycles"]
    assert set(effects) == {"thermometer_span_c", "chamber_hours"}  # strings are tabulated, not averaged
    # a misspelt plugin response gets "did you mean" among the plugin's names
    bad = _tiny_study(tmp_path, "[thermometer_span]", "plugins: [my_responses.py]\n")
    r = run_cli("doe", str(bad), "-o", str(tmp_path / "bad"))
    assert r.returncode == 2 and "did you mean 'thermometer_span_c'" in r.stderr
    assert len(r.stderr.strip().splitlines()) == 1


def test_a_missing_response_plugin_is_one_line(tmp_path):
    study = _tiny_study(tmp_path, "[chamber_hours]", "plugins: [nowhere.py]\n")
    r = run_cli("doe", str(study), "-o", str(tmp_path / "o"))
    assert r.returncode == 2 and "plugins[0]" in r.stderr and "not found" in r.stderr
    assert len(r.stderr.strip().splitlines()) == 1


# --------------------------------------------------------------------------------- compensators


def _drift_data(n=400):
    t = np.arange(n) * 30.0
    temp = 20 + 25 * np.sin(t / 3000.0)
    y = 1e-3 * (0.8 * (temp - 20) + 0.01 * (temp - 20) ** 2) + np.random.default_rng(0).normal(0, 1e-4, n)
    return t, temp, y


@pytest.mark.parametrize("name", BUILTIN_COMPENSATORS)
def test_every_registered_compensator_conforms(name):
    entry = get_compensator(name)
    assert entry.name == name and entry.label and set(entry.describe()) == {"name", "label", "module"}
    features, model = entry.build(True, 0)
    assert isinstance(features, FeatureSet)
    params = model.get_params()
    assert clone(model).get_params() == params  # __init__ only stores
    t, temp, y = _drift_data()
    X = features.transform(temp, t)
    assert model.fit(X, y) is model  # fit returns self
    pred = model.predict(X)
    assert pred.shape == (len(X),) and np.all(np.isfinite(pred))
    assert np.mean((pred - y) ** 2) < np.var(y)  # it learnt something
    assert model.predict(X[:7]).shape == (7,)
    again = entry.build(True, 0)[1].fit(X, y).predict(X)
    np.testing.assert_array_equal(pred, again)  # the seed makes it reproducible


def test_builtin_compensators_keep_the_benchmark_order():
    assert BUILTIN_COMPENSATORS == ["conventional", "model1", "model2_ga", "model3_psoga", "polynomial_T",
                                    "extension_bpnn_dTdt"]


def test_unknown_compensator_names_the_closest():
    with pytest.raises(CompensatorError, match="did you mean 'model1'"):
        get_compensator("modle1")


COMPENSATOR_PLUGIN = '''\
import numpy as np
from sklearn.base import BaseEstimator, RegressorMixin

from fitting import FeatureSet
from twin.compensation.registry import register_compensator


class StraightLine(RegressorMixin, BaseEstimator):
    """Least-squares line in the features."""

    def fit(self, X, y):
        A = np.column_stack([np.ones(len(X)), X])
        self.coef_ = np.linalg.lstsq(A, y, rcond=None)[0]
        return self

    def predict(self, X):
        return np.column_stack([np.ones(len(X)), X]) @ self.coef_


@register_compensator("straight_line_T", "a straight line in T")
def straight_line_t(quick, seed):
    return FeatureSet(("T",)), StraightLine()
'''


@pytest.fixture
def compensator_plugin(tmp_path):
    path = tmp_path / "my_compensator.py"
    path.write_text(COMPENSATOR_PLUGIN)
    yield path
    COMPENSATORS.pop("straight_line_T", None)


def test_a_compensator_plugin_is_one_file(compensator_plugin, paper_path):
    assert load_plugin(str(compensator_plugin)) == ["straight_line_T"]  # what `twin benchmark --plugin` calls
    loaded = parse_scenario(coarse_text(paper_path, rate_hz=0.05, max_cycles=2), str(paper_path))
    ds = simulate(loaded)
    m = from_dataset(ds)
    test = last_cycle_test(loaded.program, m.time_s, m.run_index)
    noise = ds["truth/noise_white_g"] + ds["truth/noise_bias_instability_g"] + ds["truth/quantisation_g"]
    out, hist, timings = evaluate_split(loaded, True, loaded.scenario.seed, subset(m, ~test), subset(m, test),
                                        noise[test], record_history=True)
    assert list(out) == [*BUILTIN_COMPENSATORS, "straight_line_T", "physics_twin", "noise_floor"]
    assert set(hist) == {"model2_ga", "model3_psoga"} and "straight_line_T" in timings
    # a line in T cannot follow the quadratic part of the drift; the polynomial can
    assert out["straight_line_T"] > out["polynomial_T"] > 0.9 * out["noise_floor"]


def test_benchmark_plugin_errors_are_one_line(tmp_path):
    r = run_cli("benchmark", "scenarios/paper_iis328dq.yaml", "--plugin", str(tmp_path / "nowhere.py"))
    assert r.returncode == 2 and r.stderr.startswith("twin: error: plugin file not found")
    assert len(r.stderr.strip().splitlines()) == 1
    broken = tmp_path / "broken.py"
    broken.write_text("from twin.compensation.registry import register_compensator\n"
                      "register_compensator('physics_twin', 'clash')\n")
    r = run_cli("benchmark", "scenarios/paper_iis328dq.yaml", "--plugin", str(broken))
    assert r.returncode == 2 and "reserved" in r.stderr and "Traceback" not in r.stderr


# ------------------------------------------------------------------- render_sweep closes once


def _fake_render(monkeypatch, rd, plotter) -> None:
    """Render with a fake plotter and no meshes: only the sweep's file handling runs."""
    monkeypatch.setattr(rd, "_plotter", plotter)
    monkeypatch.setattr(rd, "_meshes", lambda geometry, fingers: [])
    monkeypatch.setattr(rd, "_deform", lambda *a: 1.0)
    monkeypatch.setattr(rd, "_draw", lambda *a: None)


def test_render_sweep_closes_the_plotter_once(tmp_path, monkeypatch):
    import twin.reporting.render as rd

    closes = []

    class FakePlotter:
        """Records close(); writes a file when the writer is opened."""

        def __getattr__(self, name):
            return lambda *a, **k: None

        def open_gif(self, path, fps):
            self.path = path
            open(path, "wb").close()

        def write_frame(self):
            with open(self.path, "ab") as f:
                f.write(b"frame")

        def close(self):
            closes.append(1)

    _fake_render(monkeypatch, rd, FakePlotter)
    out = rd.render_sweep(None, np.array([20.0, 30.0, 40.0]), tmp_path / "s.gif")
    assert out.read_bytes() == b"frame" * 3
    assert len(closes) == 1
    assert [p.name for p in tmp_path.iterdir()] == ["s.gif"]  # no temporary file left


def test_render_sweep_closes_once_when_a_frame_fails(tmp_path, monkeypatch):
    import twin.reporting.render as rd

    closes = []

    class FailingPlotter:
        def __getattr__(self, name):
            return lambda *a, **k: None

        def write_frame(self):
            raise RuntimeError("disk full")

        def close(self):
            closes.append(1)

    _fake_render(monkeypatch, rd, FailingPlotter)
    with pytest.raises(RuntimeError, match="disk full"):
        rd.render_sweep(None, np.array([20.0]), tmp_path / "s.gif")
    assert len(closes) == 1 and not (tmp_path / "s.gif").exists()

