"""Scenario validation: every file in scenarios/ runs; each bad scenario gets its own clear line."""

import json

import pytest

from conftest import SCENARIOS, assert_one_clear_line, coarse_text, run_cli
from twin.errors import ScenarioError
from twin.model.scenario import load_scenario, parse_scenario, scenario_json_schema
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
    (GOOD + "device:\n  sensor:\n    odr_hz: 60\n", ["<t>:6", "device.sensor.odr_hz 60 is not a setting of part 'IIS328DQ'",
                                                    "50, 100, 400 or 1000"]),
    (GOOD + "device:\n  sensor: {part: IIS328DX}\n", ["<t>:5", "device.sensor.part: unknown part 'IIS328DX'",
                                                      "did you mean 'IIS328DQ'"]),
    (GOOD + "device:\n  sensor: {model: IIS328DX}\n", ["device.sensor.model: unknown part 'IIS328DX'"]),
    (GOOD + "device:\n  sensor: {model: IIS328DQ, part: generic}\n", ["model 'IIS328DQ' and part 'generic' disagree"]),
    (GOOD + "device:\n  sensor: {part: generic, full_scale_g: 2, odr_hz: 50}\n",
     ["<t>:5", "device.sensor: part 'generic' has no sensitivity_mg_per_digit, resolution_bits"]),
    (GOOD + "device:\n  sensor: {part: missing.yaml}\n", ["device.sensor.part", "missing.yaml: part file not found"]),
    (GOOD + "device:\n  sensor: {resolution_bits: 20}\n", ["device.sensor.resolution_bits", "less than or equal to 16"]),
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
    assert_one_clear_line(text, fragments)


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
    s = scenario_json_schema()
    assert set(s["properties"]) >= {"seed", "program", "chamber", "device", "test_plan", "twin", "output"}
    assert s["required"] == ["program"]
    r = run_cli("schema", "--json", str(tmp_path / "schema.json"))
    assert r.returncode == 0
    assert json.loads((tmp_path / "schema.json").read_text())["title"] == "tde-twin scenario"


def test_jsonschema_validates_the_shipped_scenarios():
    import jsonschema
    import yaml

    for path in SCENARIOS:
        jsonschema.validate(yaml.safe_load(path.read_text()), scenario_json_schema())


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


# Each scenario section that mirrors a sim dataclass, and that dataclass: one source of defaults.
def _default_pairs():
    from sim import program, thermal
    from sim.microstructure import CombGeometry
    from twin.model import sections as sec

    return [(sec.ThermometerSection, thermal.Thermometer), (sec.LumpedSection, thermal.LumpedChain),
            (sec.LayerSection, thermal.Layer), (sec.Conduction1DSection, thermal.ConductionStack),
            (sec.GeometrySection, CombGeometry), (sec.HoldStep, program.Hold)]


@pytest.mark.parametrize("pair", range(6), ids=["thermometer", "lumped", "layer", "conduction", "geometry", "hold"])
def test_section_defaults_agree_with_their_sim_dataclass(pair):
    import dataclasses

    section, cls = _default_pairs()[pair]
    shared = [f for f in dataclasses.fields(cls) if f.name in section.model_fields]
    assert shared
    for f in shared:
        if f.default is dataclasses.MISSING:  # required in the dataclass: required (or scenario-only) in the section
            continue
        assert section.model_fields[f.name].default == f.default, f"{section.__name__}.{f.name}"
        assert type(section.model_fields[f.name].default) is type(f.default), f"{section.__name__}.{f.name}"


def test_sensor_defaults_are_the_part_figures_only():
    """The sensor section writes no figure of its own: every default is None (= the part's), and the
    default scenario resolves to the default part's figures at its lowest full scale and ODR."""
    import dataclasses

    from sim.sensor import AccelerometerConfig
    from twin.model.sections import SensorSection
    from twin.parts import DEFAULT_PART, PARTS

    for f in dataclasses.fields(AccelerometerConfig):
        assert f.default is dataclasses.MISSING and SensorSection.model_fields[f.name].default is None, f.name
    part = PARTS[DEFAULT_PART]
    s = parse_scenario(GOOD).sensor()
    assert s.full_scale_g == min(part.value("sensitivity_mg_per_digit")) and s.odr_hz == min(part.value("lowpass_hz"))
    assert s.sensitivity_mg_per_digit == part.value("sensitivity_mg_per_digit")[s.full_scale_g]
    for name in ("noise_density_ug_per_sqrt_hz", "bias_instability_mg", "bias_instability_tau_s", "resolution_bits"):
        assert getattr(s, name) == part.value(name), name


def test_builders_pass_keywords():
    """The builders call the sim dataclasses with keywords only: a field added in the middle of a
    dataclass must not shift what they pass."""
    import ast
    import inspect
    import textwrap

    from twin.model.scenario import LoadedScenario

    built = {"AccelerometerConfig", "Thermometer", "LumpedChain", "Layer", "ConductionStack", "CombGeometry"}
    seen = set()
    for name in ("sensor", "thermometer", "thermal_device", "geometry"):
        tree = ast.parse(textwrap.dedent(inspect.getsource(getattr(LoadedScenario, name))))
        for call in (n for n in ast.walk(tree) if isinstance(n, ast.Call)):
            callee = call.func.attr if isinstance(call.func, ast.Attribute) else getattr(call.func, "id", "")
            if callee in built:
                seen.add(callee)
                assert not call.args, f"LoadedScenario.{name} passes {callee} arguments by position"
    assert seen == built


def test_dataset_layout_is_documented():
    from conftest import ROOT
    from twin.model.dataset import LAYOUT

    doc = (ROOT / "docs" / "dataset.md").read_text()
    assert [p for p in LAYOUT if f"`{p}`" not in doc] == []


@pytest.mark.parametrize("text,expected", [
    ("a: &a [*a]\n", "alias *a refers to the collection that contains it"),
    ("a: " + "[" * 2000 + "]" * 2000 + "\n", "nested deeper than 64 levels"),
    ("\n".join(["a0: &a0 [x, x, x, x, x, x, x, x, x, x]"] + [f"a{i}: &a{i} [" + ", ".join([f"*a{i - 1}"] * 10) + "]"
                                                          for i in range(1, 9)]) + "\n",
     "more than 200000 values once its aliases are expanded"),
])
def test_hostile_yaml_is_refused_before_it_is_built(tmp_path, text, expected):
    """A self-referencing anchor, 2,000-deep nesting and a billion-laughs file: one line, exit 2, fast."""
    s = tmp_path / "s.yaml"
    s.write_text(text)
    r = run_cli("run", str(s), "-o", str(tmp_path / "x.h5"), timeout=60)
    assert r.returncode == 2 and expected in r.stderr and r.stderr.count("\n") == 1, r.stderr
