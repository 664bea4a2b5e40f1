"""Sensor part sets: every part file is complete data, the CLI lists it, a user part file named in a
scenario drives the simulation, and the generic part demands its figures from the scenario."""

import io
import json
import tokenize

import numpy as np
import pytest
import yaml

from conftest import ROOT, run_cli
from schemas import check_schema
from twin.errors import ScenarioError
from twin.model.dataset import read_hdf5
from twin.model.scenario import parse_scenario
from twin.parts import FIGURES, HERE, PARTS, SIMULATION_FIGURES, PartError, accelerometer_figures, load_part

PART_FILES = sorted(HERE.glob("*.yaml"))
PROGRAM = "program:\n  steps:\n    - {type: hold, dwell_s: 60}\n"


@pytest.mark.parametrize("path", PART_FILES, ids=[p.stem for p in PART_FILES])
def test_every_part_file_loads_and_every_figure_says_where_it_comes_from(path):
    raw = yaml.safe_load(path.read_text())
    part = load_part(path.name, HERE)
    assert PARTS[part.name].figures == part.figures
    assert set(part.figures) == set(raw["figures"] or {})
    for name, entry in (raw["figures"] or {}).items():
        assert {"value", "unit", "source", "verified"} <= set(entry), name  # in the file, not filled in by the loader
        assert isinstance(entry["verified"], bool) and entry["source"].strip(), name
        assert name in FIGURES


def test_iis328dq_holds_every_figure_with_its_provenance():
    part = PARTS["IIS328DQ"]
    assert set(part.figures) == set(FIGURES)
    assert part.value("sensitivity_mg_per_digit") == {2: 0.98, 4: 1.95, 8: 3.91}
    assert part.value("lowpass_hz") == {50: 37.0, 100: 74.0, 400: 292.0, 1000: 780.0}
    assert part.value("resolution_bits") == 12
    assert part.value("operating_temperature_c") == (-40.0, 105.0)
    # docs/physics.md §1.1: the datasheet's Table 2 was read in full (Rev 4); the bias instability is
    # a typical value, not a datasheet figure.
    assert not part.figures["bias_instability_mg"].verified and not part.figures["bias_instability_tau_s"].verified
    assert part.figures["noise_density_ug_per_sqrt_hz"].verified and part.figures["tcoff_mg_per_c"].verified
    assert part.choices("full_scale_g") == [2, 4, 8] and part.choices("odr_hz") == [50, 100, 400, 1000]


def test_generic_has_no_figures_and_takes_them_all_from_the_scenario():
    assert PARTS["generic"].figures == {}
    with pytest.raises(PartError, match="has no full_scale_g, odr_hz, sensitivity_mg_per_digit") as exc:
        accelerometer_figures(PARTS["generic"], {}, {})
    assert exc.value.key == "full_scale_g"
    given = dict(sensitivity_mg_per_digit=1.0, resolution_bits=14, lowpass_hz=20.0, noise_density_ug_per_sqrt_hz=50.0,
                 bias_instability_mg=0.0, bias_instability_tau_s=10.0)
    out = accelerometer_figures(PARTS["generic"], {"full_scale_g": 3, "odr_hz": 40}, given)
    assert out == {**given, "full_scale_g": 3, "odr_hz": 40}


def test_cli_parts_json_lists_the_figures_with_verified_flags():
    r = run_cli("parts", "--json", "-")
    assert r.returncode == 0, r.stderr
    check_schema(json.loads(r.stdout), "parts")
    parts = {p["name"]: p for p in json.loads(r.stdout)["parts"]}
    assert set(parts) >= {"IIS328DQ", "generic"}
    figures = {f["name"]: f for f in parts["IIS328DQ"]["figures"]}
    assert figures["sensitivity_mg_per_digit"]["value"] == {"2": 0.98, "4": 1.95, "8": 3.91}
    assert figures["noise_density_ug_per_sqrt_hz"]["unit"] == "µg/√Hz"
    assert figures["bias_instability_mg"]["verified"] is False and figures["lowpass_hz"]["verified"] is True
    assert all({"value", "unit", "source", "verified"} <= set(f) for f in figures.values())


def test_cli_parts_rejects_an_unknown_part_in_one_line():
    r = run_cli("parts", "IIS328DX")
    assert r.returncode == 2
    assert r.stderr.strip().count("\n") == 0 and "did you mean 'IIS328DQ'" in r.stderr


MY_PART = """\
name: MyAccel
description: a made-up part with a coarser digit
figures:
  sensitivity_mg_per_digit: {value: {2: 4.0, 4: 8.0}, unit: mg/digit, source: test, verified: false}
  resolution_bits: {value: 10, unit: bit, source: test, verified: false}
  lowpass_hz: {value: {100: 50}, unit: Hz, source: test, verified: false}
  noise_density_ug_per_sqrt_hz: {value: 200, unit: ug/sqrt(Hz), source: test, verified: false}
  bias_instability_mg: {value: 0.0, unit: mg, source: test, verified: false}
  bias_instability_tau_s: {value: 100, unit: s, source: test, verified: false}
"""


def test_user_part_file_named_in_a_scenario_drives_twin_run(tmp_path):
    (tmp_path / "parts").mkdir()
    (tmp_path / "parts" / "my_accel.yaml").write_text(MY_PART)
    scenario = tmp_path / "s.yaml"
    scenario.write_text(PROGRAM + "device:\n  sensor: {part: parts/my_accel.yaml}\n")
    out = tmp_path / "s.h5"
    r = run_cli("run", str(scenario), "-o", str(out), "-q", "--json", "-", cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    ds = read_hdf5(out)
    assert ds.attrs["sensor"] == "MyAccel" and ds.attrs["sensitivity_mg_per_digit"] == 4.0
    # the output moves in steps of the part's 4 mg digit (the IIS328DQ's would be 0.98 mg)
    np.testing.assert_allclose(ds["output/output_g"], ds["output/output_digits"] * 4.0e-3, atol=1e-12)
    assert np.max(np.abs(ds["truth/quantisation_g"])) <= 2.0e-3 + 1e-12
    assert np.max(np.abs(ds["truth/quantisation_g"])) > 0.98e-3 / 2  # coarser than the default part could give
    # 200 µg/√Hz over the part's 50 Hz low-pass at its only ODR (100 Hz), the default (lowest) one
    assert json.loads(r.stdout)["white_noise_sigma_mg"] == pytest.approx(0.2 * np.sqrt(50.0))


def test_scenario_overrides_a_figure_of_the_part():
    loaded = parse_scenario(PROGRAM + "device:\n  sensor: {noise_density_ug_per_sqrt_hz: 100, full_scale_g: 4}\n")
    s = loaded.sensor()
    assert s.noise_density_ug_per_sqrt_hz == 100.0 and s.sensitivity_mg_per_digit == 1.95
    assert loaded.scenario.device.sensor.lowpass_hz == 37.0  # resolved figures are visible in the section


def test_model_key_is_an_alias_of_part():
    a = parse_scenario(PROGRAM + "device:\n  sensor: {model: IIS328DQ}\n")
    b = parse_scenario(PROGRAM)
    assert a.part is b.part and a.sensor() == b.sensor()


def test_generic_without_figures_exits_2_naming_the_missing_key(tmp_path):
    scenario = tmp_path / "g.yaml"
    scenario.write_text(PROGRAM + "device:\n  sensor:\n    part: generic\n    full_scale_g: 2\n    odr_hz: 50\n"
                        "    sensitivity_mg_per_digit: 1.0\n    resolution_bits: 12\n    lowpass_hz: 20\n"
                        "    bias_instability_mg: 0\n    bias_instability_tau_s: 10\n")
    r = run_cli("run", str(scenario), "-o", str(tmp_path / "g.h5"), "-q")
    assert r.returncode == 2
    line = r.stderr.strip()
    assert "\n" not in line and f"{scenario}:5: device.sensor" in line
    assert "part 'generic' has no noise_density_ug_per_sqrt_hz" in line


@pytest.mark.parametrize("text,fragment", [
    ("name: X\nfigures:\n  noise_density: {value: 1, unit: mg, source: s, verified: true}\n",
     ":3: figures: unknown figure 'noise_density'; did you mean 'noise_density_ug_per_sqrt_hz'?"),
    ("name: X\nfigures:\n  tcoff_mg_per_c: {value: 1, unit: mg/°C, source: s}\n",
     ":3: figures.tcoff_mg_per_c: missing 'verified'"),
    ("name: X\nfigures:\n  tcoff_mg_per_c: {value: 1, unit: mg, source: s, verified: true}\n",
     ":3: figures.tcoff_mg_per_c.unit: tcoff_mg_per_c is in 'mg/°C', got 'mg'"),
    ("name: X\nfigures:\n  lowpass_hz: {value: 37, unit: Hz, source: s, verified: true}\n",
     ":3: figures.lowpass_hz.value: expected a mapping odr_hz → number > 0, got 37"),
    ("name: X\nfigures:\n  resolution_bits:\n    value: 12\n    unit: bit\n    source: s\n    verified: maybe\n",
     ":7: figures.resolution_bits.verified: true (read in a source) or false"),
    ("name: X\nfigure: {}\n", ":2: unknown key 'figure' in a part file; did you mean 'figures'?"),
    ("- a list\n", "a part file is a YAML mapping"),
])
def test_bad_part_file_gets_one_line_naming_file_line_and_key(tmp_path, text, fragment):
    (tmp_path / "bad.yaml").write_text(text)
    with pytest.raises(ScenarioError) as exc:
        parse_scenario(PROGRAM + "device:\n  sensor:\n    part: bad.yaml\n", str(tmp_path / "s.yaml"))
    message = str(exc.value)
    assert "\n" not in message
    assert message.startswith(f"{tmp_path / 's.yaml'}:6: device.sensor.part: {tmp_path / 'bad.yaml'}")
    assert fragment in message, message


def test_no_datasheet_number_in_the_sensor_path_code():
    """The part's figures live in its YAML file only: no numeric literal of them in the code that
    builds and runs the sensor (comments and docstrings may cite them)."""
    figures = {0.98, 1.95, 3.91, 218.0, 37.0, 74.0, 292.0, 780.0}
    files = [ROOT / "sim" / "sensor.py", *(ROOT / "twin" / "cli").glob("*.py"), *(ROOT / "twin" / "model").glob("*.py"),
             *(ROOT / "twin" / "parts").glob("*.py")]
    found = []
    for f in files:
        for tok in tokenize.generate_tokens(io.StringIO(f.read_text()).readline):
            if tok.type == tokenize.NUMBER and float(tok.string.rstrip("jJ")) in figures:
                found.append(f"{f.relative_to(ROOT)}:{tok.start[0]}: {tok.string}")
    assert not found, found
    assert set(SIMULATION_FIGURES) <= set(FIGURES)
