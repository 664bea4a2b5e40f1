"""Behaviour unchanged: the JSON outputs of ``make run`` equal the recorded ones (``tests/golden``).

Recorded before the subsystems were moved into packages. On one CPU two runs give byte-identical
JSON, but another CPU's SIMD paths (OpenBLAS, NumPy, torch, numba) sum in another order:

- physics, diagnosis and the paper's numbers are compared to 1e-8 relative (an Intel Xeon moved
  them by at most 1.8e-9 against the AMD EPYC recording; intended changes have moved them by 1e-7
  and more). Values that are rounding noise by nature — a novelty of 1e-31, a polynomial fit's
  error of 1e-15 /K — are equal below 1e-15 absolute. Numbers inside text are compared the same way.
- the quick compensation benchmark trains neural networks (float32 searches, non-convex fits) that
  amplify last-bit differences. One recording serves every CPU: what involves no training at
  1e-8, integers and words exactly, and each trained figure at a tolerance derived from round-off
  measured five ways and from the spread over network seeds (``tests/golden.py`` gives the
  figures).
"""

import copy
import json

import pytest

from golden import (ABS, FITNESS_REL, REL, SEED_SPREAD, TRAINED_REL, benchmark_differences, differences,
                    make_run_outputs, recorded_path)


@pytest.fixture(scope="module")
def outputs(tmp_path_factory, quick_benchmark):
    return make_run_outputs(tmp_path_factory.mktemp("make_run"), quick_benchmark)


@pytest.mark.parametrize("name", ["paper", "test_design", "paper_numbers", "comb", "base", "after"])
def test_make_run_json_is_unchanged(outputs, name):
    expected = json.loads(recorded_path(name).read_text())
    found = differences(json.loads(json.dumps(outputs[name], sort_keys=True)), expected, REL, ABS, name)
    assert not found, "\n".join(found[:20])


def test_trained_networks_are_unchanged(outputs):
    expected = json.loads(recorded_path("benchmark_quick").read_text())
    found = benchmark_differences(json.loads(json.dumps(outputs["benchmark_quick"], sort_keys=True)), expected)
    assert not found, "\n".join(found[:20])


def test_the_comparison_can_fail():
    old = {"a": [1.0, "gain 0.7 % lower"], "b": 1e-31}
    assert not differences({"a": [1.0 + 1e-10, "gain 0.7 % lower"], "b": 9e-31}, old, REL, ABS)
    assert differences({"a": [1.0 + 1e-7, "gain 0.7 % lower"], "b": 1e-31}, old, REL, ABS)
    assert differences({"a": [1.0, "gain 0.6 % lower"], "b": 1e-31}, old, REL, ABS)
    assert differences({"a": [1.0], "b": 1e-31}, old, REL, ABS)
    assert differences({"a": [1.0, "gain 0.7 % lower"]}, old, REL, ABS)


def _row(doc, model):
    return next(r for r in doc["table1"] if r["model"] == model)


def _times(d: dict, key: str, by: float) -> None:
    d[key] = [v * by for v in d[key]] if isinstance(d[key], list) else d[key] * by


def test_the_trained_comparison_can_fail():
    old = json.loads(recorded_path("benchmark_quick").read_text())
    assert not benchmark_differences(copy.deepcopy(old), old)

    def changed(edit) -> list[str]:
        new = copy.deepcopy(old)
        edit(new)
        return benchmark_differences(new, old)

    # a trained network's in-sample MSE: within its tolerance passes, twice it fails
    assert not changed(lambda d: _times(_row(d, "model1"), "mse", 1 + TRAINED_REL / 2))
    assert changed(lambda d: _times(_row(d, "model1"), "mse", 1 + 2 * TRAINED_REL))
    # what needs no training is held to 1e-8, in every split
    assert changed(lambda d: _times(_row(d, "polynomial_T"), "mse", 1 + 1e-7))
    assert changed(lambda d: _times(d["extrapolation_split"], "physics_twin", 1 + 1e-7))
    assert changed(lambda d: _times(d, "noise_floor_mse", 1 + 1e-7))
    # the fitness history to float32's bound; the search's integers exactly
    history = lambda d: d["table2"]["model2_ga"]["mse_g2_at_iteration"]["14"]  # noqa: E731
    assert not changed(lambda d: _times(history(d), "mean", 1 + FITNESS_REL / 2))
    assert changed(lambda d: _times(history(d), "mean", 1 + 2 * FITNESS_REL))
    assert changed(lambda d: _times(d["table2"]["model3_psoga"], "fitness_evaluations", 2))
    assert changed(lambda d: _times(d["optimizers"]["GA"], "reached", 0.5))
    # an extrapolation within the networks' seed range passes, beyond it fails
    spread = SEED_SPREAD["extrapolation_split"]["model2_ga"]
    assert not changed(lambda d: _times(d["extrapolation_split"], "model2_ga", 1 - spread / 2))
    assert changed(lambda d: _times(d["extrapolation_split"], "model2_ga", (1 - spread) / 2))
    # a decided conclusion is compared exactly, and a verdict's words; the models and their order
    assert changed(lambda d: _row(d, "extension_bpnn_dTdt").__setitem__("improves_on_conventional", [False]))
    assert changed(lambda d: d["verdicts"].__setitem__(4, d["verdicts"][4].replace(" beats ", " does NOT beat ")))
    assert changed(lambda d: d["table1"].reverse())
