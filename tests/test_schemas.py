"""``twin schema``: the JSON Schema each command's --json follows, generated from the result types."""

import json

import jsonschema

from conftest import run_in_process


def test_schema_command_prints_a_valid_schema_and_writes_it_with_json(tmp_path):
    code, out, err = run_in_process(["schema", "--result", "compare"])
    assert code == 0, err
    schema = json.loads(out)
    jsonschema.Draft202012Validator.check_schema(schema)
    assert {"CompareResult", "AxesCompareResult", "ParameterEstimate"} <= set(schema["$defs"])
    code, _, err = run_in_process(["schema", "--result", "compare", "--json", tmp_path / "s.json"])
    assert code == 0 and json.loads((tmp_path / "s.json").read_text()) == schema, err


def test_schema_refuses_an_unknown_result_in_one_line():
    code, _, err = run_in_process(["schema", "--result", "nonsense"])
    assert code == 2 and err.count("\n") == 1 and "--result" in err and "compare" in err, err


def test_schema_rejects_what_a_reader_would_misread():
    """The schema is strict where it matters: a missing required key or a wrong type fails."""
    from twin.workflows.schemas import result_schema

    validator = jsonschema.Draft202012Validator(result_schema("compare"))
    assert not validator.is_valid({"finding": "x"})
    assert not validator.is_valid({"imus": [], "finding": 3})
    assert validator.is_valid({"imus": [], "finding": "No effect is named on any axis."})
