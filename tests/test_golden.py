"""Behaviour unchanged: the JSON outputs of ``make run`` equal the recorded ones (``tests/golden``).

Recorded before the subsystems were moved into packages; two runs of the same code gave
byte-identical JSON, so the comparison is exact (a restructuring that reorders arithmetic fails).
"""

import json

import pytest

from golden import GOLDEN, make_run_outputs


@pytest.fixture(scope="module")
def outputs(tmp_path_factory):
    return make_run_outputs(tmp_path_factory.mktemp("make_run"))


@pytest.mark.parametrize("name", ["paper", "test_design", "paper_numbers", "comb", "base", "after", "benchmark_quick"])
def test_make_run_json_is_unchanged(outputs, name):
    expected = json.loads((GOLDEN / f"{name}.json").read_text())
    assert json.loads(json.dumps(outputs[name], sort_keys=True)) == expected
