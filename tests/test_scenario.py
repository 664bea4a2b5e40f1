"""Scenario validation: every file in scenarios/ runs; each bad scenario gets its own clear line."""

import json

import pytest

from conftest import SCENARIOS, coarse_text, run_cli
from twin.errors import ScenarioError
from twin.model.scenario import json_schema, load_scenario, parse_scenario
from twin.model.simulate import simulate

GOOD = """\
program:
  steps:
    - {type: hold, dwell_s: 60}
"""

# (scenario text, fragments the one-line message must contain)
BAD = [
    ("program:\n  steps:\n    - {type: ramp, target_c: 50, ramp_c_per_hr: 41}\n",
     ["<t>:3", "unknown key 'ramp_c_per_hr'", "did you mean 'ramp_c_per_h'"]),
    ("program:\n  steps:\n    - {type: hold, dwell_s: -5}\n", ["<t>:3", "program.steps[0].dwell_s", "greater than 0"]),
    ("program:\n  start_c: -20\n  steps:\n    - {type: ramp, target_c: 50, ramp_c_per_h: -41}\n",
     ["<t>:4", "never reaches target_c 50"]),
    ("program:\n  steps:\n    - {type: ramp, target_c: 50, ramp_c_per_h: 0}\n", ["never reaches"]),
    ("program:\n  steps: [{type: hold, dwell_s: 10}\n", ["<t>:3", "malformed YAML"]),
    ("- just\n- a list\n", ["a scenario is a YAML mapping"]),
    ("program:\n  steps: [{type: hlod, dwell_s: 10}]\n", ["unknown step type 'hlod'", "did you mean 'hold'"]),
    ("program:\n  steps: []\n", ["program.steps", "at least 1"]),
    (GOOD + "chamber:\n  modle: lumped\n", ["<t>:5", "unknown key 'modle' at chamber", "did you mean 'model'"]),
    (GOOD + "chamber:\n  model: fem\n", ["chamber.model", "'lumped' or 'conduction_1d'"]),
    (GOOD + "chamber:\n  thermometer: {attached_to: dye}\n", ["<t>:5", "not a node", "did you mean 'die'"]),
    (GOOD + "chamber:\n  air_tau_s: 0\n", ["chamber.air_tau_s", "greater than 0"]),
    (GOOD + "chamber:\n  model: conduction_1d\n  conduction_1d: {die_layer: chip}\n",
     ["die_layer 'chip' is not a layer name"]),
    (GOOD + "device:\n  sensor: {full_scale_g: 3}\n", ["device.sensor.full_scale_g", "2, 4 or 8"]),
    (GOOD + "device:\n  effects:\n    static_bias_t: {}\n", ["<t>:6", "unknown effect 'static_bias_t'", "static_bias_tc"]),
    (GOOD + "device:\n  effects:\n    static_bias_tc: {tc1_mg_per_c: 99}\n", ["outside its bounds"]),
    (GOOD + "device:\n  effects:\n    static_bias_tc: {tc1_mg_per_cc: 1}\n", ["no parameter 'tc1_mg_per_cc'", "did you mean"]),
    (GOOD + "test_plan:\n  logger_rate_hz: 100\n", ["exceeds the sensor ODR 50"]),
    (GOOD + "test_plan:\n  orientations: [{at_s: 10, applied_g: 1}, {at_s: 0, applied_g: -1}]\n", ["increasing at_s"]),
    (GOOD + "twin:\n  effects: [static_bias]\n", ["twin.effects[0]", "unknown effect 'static_bias'"]),
    (GOOD + "seed: -1\n", ["seed", "greater than or equal to 0"]),
    ("seed: 1\n", ["missing required key 'program'"]),
]


@pytest.mark.parametrize("text,fragments", BAD, ids=[f"bad{i}" for i in range(len(BAD))])
def test_bad_scenario_gets_its_own_clear_message(text, fragments):
    with pytest.raises(ScenarioError) as exc:
        parse_scenario(text, "<t>")
    message = str(exc.value)
    assert "\n" not in message
    for fragment in fragments:
        assert fragment in message, message


def test_bad_messages_are_distinct():
    messages = []
    for text, _ in BAD:
        with pytest.raises(ScenarioError) as exc:
            parse_scenario(text, "<t>")
        messages.append(str(exc.value))
    assert len(set(messages)) == len(messages)


@pytest.mark.parametrize("path", SCENARIOS, ids=[p.stem for p in SCENARIOS])
def test_every_scenario_loads_and_runs_on_a_coarse_grid(path):
    loaded = load_scenario(path)
    assert loaded.program.duration_s > 0
    ds = simulate(parse_scenario(coarse_text(path), str(path)))
    assert len(ds) > 10
    for values in ds.arrays.values():
        if values.dtype.kind == "f":
            assert values.size == len(ds) and bool(abs(values).max() < 1e6)


def test_json_schema_describes_the_sections(tmp_path):
    s = json_schema()
    assert set(s["properties"]) >= {"seed", "program", "chamber", "device", "test_plan", "twin", "output"}
    assert s["required"] == ["program"]
    r = run_cli("schema", "--json", str(tmp_path / "schema.json"))
    assert r.returncode == 0
    assert json.loads((tmp_path / "schema.json").read_text())["title"] == "tde-twin scenario"


def test_jsonschema_validates_the_shipped_scenarios():
    import jsonschema
    import yaml

    for path in SCENARIOS:
        jsonschema.validate(yaml.safe_load(path.read_text()), json_schema())


def _field_paths(model, prefix=""):
    import typing

    from pydantic import BaseModel

    for name, field in model.model_fields.items():
        yield prefix + name
        for t in [field.annotation, *typing.get_args(field.annotation)]:
            for tt in [t, *typing.get_args(t)]:
                if isinstance(tt, type) and issubclass(tt, BaseModel):
                    yield from _field_paths(tt, prefix + name + ".")


def test_every_scenario_key_is_documented():
    from conftest import ROOT
    from twin.model.scenario import HoldStep, RampStep, Scenario, StaircaseStep

    doc = (ROOT / "docs" / "scenario.md").read_text()
    missing = []
    for path in _field_paths(Scenario):
        if ".layers." in path or ".orientations." in path:  # keys of list items: by leaf name
            ok = f"`{path.split('.')[-1]}`" in doc
        else:  # a key, or a section named by the keys under it
            ok = f"`{path}`" in doc or f"`{path}." in doc
        if not ok:
            missing.append(path)
    for step in (HoldStep, RampStep, StaircaseStep):
        missing += [k for k in step.model_fields if f"`{k}`" not in doc]
    assert not missing, missing


def test_dataset_layout_is_documented():
    from conftest import ROOT
    from twin.model.dataset import LAYOUT

    doc = (ROOT / "docs" / "dataset.md").read_text()
    assert [p for p in LAYOUT if f"`{p}`" not in doc] == []
