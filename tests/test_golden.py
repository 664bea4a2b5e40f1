"""Behaviour unchanged: the JSON outputs of ``make run`` equal the recorded ones (``tests/golden``).

Recorded before the subsystems were moved into packages. On one CPU two runs give byte-identical
JSON, but another CPU's SIMD paths (OpenBLAS, NumPy, torch) sum in another order:

- physics, diagnosis and the paper's numbers are compared to 1e-8 relative (an Intel Xeon moved
  them by at most 1.8e-9 against the AMD EPYC recording; intended changes have moved them by 1e-7
  and more). Values that are rounding noise by nature — a novelty of 1e-31, a polynomial fit's
  error of 1e-15 /K — are equal below 1e-15 absolute. Numbers inside text are compared the same way.
- the quick compensation benchmark trains neural networks (float32 searches, non-convex fits) that
  amplify last-bit differences (up to 60 % on one extrapolation split between the two CPUs), so it
  is recorded per CPU vendor and vector width (the compiled fitness kernel is built for the CPU it
  runs on) and compared exactly; on a CPU kind with no recording it is skipped.
"""

import json

import pytest

from golden import PER_CPU, cpu_kind, differences, make_run_outputs, recorded_path

REL, ABS = 1e-8, 1e-15


@pytest.fixture(scope="module")
def outputs(tmp_path_factory):
    return make_run_outputs(tmp_path_factory.mktemp("make_run"))


@pytest.mark.parametrize("name", ["paper", "test_design", "paper_numbers", "comb", "base", "after"])
def test_make_run_json_is_unchanged(outputs, name):
    expected = json.loads(recorded_path(name).read_text())
    found = differences(json.loads(json.dumps(outputs[name], sort_keys=True)), expected, REL, ABS, name)
    assert not found, "\n".join(found[:20])


@pytest.mark.parametrize("name", PER_CPU)
def test_trained_networks_are_unchanged_on_this_cpu_kind(outputs, name):
    path = recorded_path(name, cpu_kind())
    if not path.is_file():
        pytest.skip(f"no recording of {name} for CPU {cpu_kind()} (python tests/golden.py records one)")
    assert json.loads(json.dumps(outputs[name], sort_keys=True)) == json.loads(path.read_text())


def test_the_comparison_can_fail():
    old = {"a": [1.0, "gain 0.7 % lower"], "b": 1e-31}
    assert not differences({"a": [1.0 + 1e-10, "gain 0.7 % lower"], "b": 9e-31}, old, REL, ABS)
    assert differences({"a": [1.0 + 1e-7, "gain 0.7 % lower"], "b": 1e-31}, old, REL, ABS)
    assert differences({"a": [1.0, "gain 0.6 % lower"], "b": 1e-31}, old, REL, ABS)
    assert differences({"a": [1.0], "b": 1e-31}, old, REL, ABS)
    assert differences({"a": [1.0, "gain 0.7 % lower"]}, old, REL, ABS)
