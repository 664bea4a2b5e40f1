"""Property-based tests of the CLI contract on generated scenarios and studies (issue 14).

For any scenario or study file, valid or broken, ``twin run`` / ``twin doe`` either succeed
(exit 0, every array finite, the named outputs written and nothing else) or refuse (exit 2, one
line ``twin: error: ...``, nothing written): never a traceback, an internal error, a hang, or a
write outside the named output. The budgets come from the hypothesis profile (tests/conftest.py:
``ci`` by default, ``HYPOTHESIS_PROFILE=long`` for 20,000 examples); the size limits are lowered
here so that a generated run stays small — the limit logic is the same, only its threshold moves.
"""

from __future__ import annotations

import copy
import json
import math
import os
import tempfile
from pathlib import Path

import numpy as np
import pytest
import yaml

hypothesis = pytest.importorskip("hypothesis")
from conftest import ROOT, run_in_process  # noqa: E402
from hypothesis import HealthCheck, event, given, settings  # noqa: E402
from hypothesis import strategies as st  # noqa: E402

BASE = yaml.safe_load((ROOT / "tests" / "adversarial" / "model" / "ok_tiny.yaml").read_text())


def ci_budget(n: int) -> int:
    """``n`` examples in the ci profile (these tests are slower per example); any other profile's own budget."""
    budget = settings().max_examples
    return min(budget, n) if os.environ.get("HYPOTHESIS_PROFILE", "ci") == "ci" else budget


def run_main(args: list[str]) -> tuple[int, str]:
    code, _, err = run_in_process(args)
    return code, err


@pytest.fixture(autouse=True)
def _small_limits(monkeypatch):
    """Generated runs stay at most a few thousand samples (the refusal above is what is tested)."""
    import twin.model.scenario as scenario

    monkeypatch.setattr(scenario, "MAX_SAMPLES", 5_000)
    monkeypatch.setattr(scenario, "MAX_SEGMENTS", 2_000)


# ------------------------------------------------------------------ strategies

SPECIAL = [math.nan, math.inf, -math.inf, 0.0, -0.0, 1e-300, -1e-300, 1e300, -1e300, 2.0**70, -1.0, 1e9, 1e12]
number = st.one_of(
    st.sampled_from(SPECIAL),
    st.floats(-200, 400),  # temperatures and small magnitudes, in and out of range
    st.floats(1e-6, 1e4),
    st.integers(-10, 10**6),
    st.floats(allow_nan=True, allow_infinity=True),
)
junk = st.one_of(st.none(), st.booleans(), st.text(max_size=8), st.lists(st.integers(), max_size=3),
                 st.dictionaries(st.text(max_size=4), st.integers(), max_size=2))
value = st.one_of(number, number, number, junk)

step = st.one_of(
    st.fixed_dictionaries({"type": st.just("hold"), "dwell_s": value}, optional={"target_c": value}),
    st.fixed_dictionaries({"type": st.just("ramp"), "target_c": value, "ramp_c_per_h": value}),
    st.fixed_dictionaries({"type": st.just("staircase"), "target_c": value, "step_c": value, "step_s": value}),
    st.fixed_dictionaries({"type": st.sampled_from(["hold", "ramp", "dwell", 3])}),
)

LEAVES = ["seed", "program.start_c", "program.cycles", "chamber.air_tau_s", "chamber.thermal_step_s",
          "chamber.lumped.board_tau_s", "chamber.lumped.die_tau_s", "chamber.lumped.die_to_board_capacity_ratio",
          "chamber.lumped.board_heat_capacity_j_per_k", "chamber.thermometer.tau_s", "chamber.thermometer.noise_c",
          "chamber.thermometer.offset_c", "chamber.thermometer.resolution_c", "chamber.thermometer.sample_rate_hz",
          "device.sensor.zero_g_offset_mg", "device.sensor.turn_on_bias_mg", "device.sensor.noise_density_ug_per_sqrt_hz",
          "device.sensor.bias_instability_mg", "device.sensor.bias_instability_tau_s", "device.sensor.full_scale_g",
          "device.sensor.odr_hz", "device.effects.static_bias_tc.tc1_mg_per_c", "device.effects.scale_factor_tc.tc1_ppm_per_c",
          "test_plan.logger_rate_hz", "test_plan.runs", "test_plan.orientations.0.applied_g",
          "test_plan.orientations.0.at_s", "test_plan.power_on_s", "device.geometry.g_um", "device.geometry.b_um"]


def _get(data, dotted: str):
    for k in dotted.split("."):
        try:
            data = data[int(k)] if isinstance(data, list) else data.get(k)
        except (AttributeError, IndexError, ValueError):
            return None
    return data


def _put(data: dict, dotted: str, v) -> None:
    keys = dotted.split(".")
    node = data
    for k in keys[:-1]:
        node = node[int(k)] if isinstance(node, list) else node.setdefault(k, {})
        if not isinstance(node, (dict, list)):
            return
    if isinstance(node, list):
        node[int(keys[-1])] = v
    else:
        node[keys[-1]] = v


@st.composite
def scenarios(draw) -> dict:
    data = copy.deepcopy(BASE)
    if draw(st.integers(0, 3)) == 0:
        data["program"]["steps"] = draw(st.lists(step, min_size=0, max_size=4))
    for path in draw(st.lists(st.sampled_from(LEAVES), max_size=4, unique=True)):
        old = _get(BASE, path)
        plausible = isinstance(old, (int, float)) and not isinstance(old, bool) and draw(st.booleans())
        _put(data, path, type(old)(old * draw(st.sampled_from([0.5, 0.9, 1.1, 2]))) if plausible else draw(value))
    if draw(st.integers(0, 9)) == 0:  # orientations, sometimes at one instant
        data["test_plan"]["orientations"] = draw(st.lists(
            st.fixed_dictionaries({"at_s": st.sampled_from([0, 0, 100, math.nan]), "applied_g": value}), max_size=3))
    if draw(st.integers(0, 9)) == 0:  # a three-axis device
        data["device"].pop("effects", None)
        data["device"]["axes"] = {a: {} for a in "xyz"}
        data["test_plan"]["orientations"] = [{"at_s": 0, "gravity_g": draw(st.lists(value, min_size=3, max_size=3))}]
    return data


# ------------------------------------------------------------------ the contract


def _files(folder: Path) -> set[str]:
    return {str(p.relative_to(folder)) for p in folder.rglob("*") if p.is_file()}


def _assert_finite_h5(path: Path) -> None:
    import h5py

    with h5py.File(path, "r") as f:
        bad = []
        f.visititems(lambda n, o: bad.append(n) if isinstance(o, h5py.Dataset) and o.dtype.kind == "f"
                     and not np.all(np.isfinite(o[()])) else None)
    assert not bad, bad


def check_contract(code: int, err: str, folder: Path, inputs: set[str], outputs: set[str],
                   may_remain: set[str] = frozenset()) -> None:
    event(f"exit {code}")
    assert code in (0, 2), f"exit {code}: {err}"
    assert "Traceback" not in err
    files = _files(folder)
    if code == 0:
        assert files == inputs | outputs, files ^ (inputs | outputs)
    else:
        lines = err.strip().splitlines()
        assert len(lines) == 1 and lines[0].startswith("twin: error: "), err
        assert files - inputs <= may_remain, files - inputs


@given(scenarios())
def test_run_contract(data):
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        (folder / "s.yaml").write_text(yaml.safe_dump(data, sort_keys=False, allow_unicode=True))
        code, err = run_main(["run", str(folder / "s.yaml"), "-o", str(folder / "o.h5"), "-q",
                              "--json", str(folder / "o.json")])
        check_contract(code, err, folder, {"s.yaml"}, {"o.h5", "o.json"})
        if code == 0:
            _assert_finite_h5(folder / "o.h5")
            summary = json.loads((folder / "o.json").read_text())
            assert summary["samples"] > 0 and all(math.isfinite(v) for v in summary["die_range_c"])


@settings(max_examples=ci_budget(40))
@given(st.one_of(st.text(max_size=200), st.binary(max_size=200).map(lambda b: b.decode("latin-1"))))
def test_any_text_is_refused_in_one_line(text):
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        (folder / "s.yaml").write_text(text, encoding="utf-8", errors="surrogateescape")
        code, err = run_main(["run", str(folder / "s.yaml"), "-o", str(folder / "o.h5"), "-q"])
        check_contract(code, err, folder, {"s.yaml"}, {"o.h5"})


FACTOR_PATHS = ["device.sensor.zero_g_offset_mg", "program.start_c", "chamber.air_tau_s", "test_plan.runs",
                "device.effects.static_bias_tc.tc1_mg_per_c", "device.effects.static_bias_tc.nope", "no.such.path",
                "program.steps.0.dwell_s"]
factor = st.one_of(
    st.fixed_dictionaries({"levels": st.lists(value, min_size=0, max_size=3)}),
    st.fixed_dictionaries({"range": st.lists(value, min_size=1, max_size=3)}, optional={"log": st.booleans()}),
    junk,
)


valid_study = st.fixed_dictionaries({
    "base": st.just("base.yaml"), "seed": st.integers(0, 2**32), "responses": st.just(["chamber_hours", "drift_pp_mg"]),
    "factors": st.fixed_dictionaries({"device.sensor.zero_g_offset_mg": st.one_of(
        st.fixed_dictionaries({"levels": st.lists(st.floats(-50, 50), min_size=1, max_size=2, unique=True)}),
        st.just({"range": [0.0, 5.0]}))}),
    "design": st.one_of(st.just({"type": "full_factorial", "levels": 2}),
                        st.builds(lambda n: {"type": "latin_hypercube", "points": n}, st.integers(1, 3))),
    "max_runs": st.just(4)})


@st.composite
def studies(draw) -> dict:
    if draw(st.booleans()):
        return draw(valid_study)
    study = {"base": draw(st.sampled_from(["base.yaml", "base.yaml", "base.yaml", "missing.yaml"])),
             "seed": draw(st.one_of(st.integers(0, 10), st.sampled_from([-1, 2**70]))),
             "factors": draw(st.dictionaries(st.sampled_from(FACTOR_PATHS), factor, min_size=0, max_size=2)),
             "responses": draw(st.lists(st.sampled_from(["chamber_hours", "drift_pp_mg", "chamber_hour"]),
                                        min_size=0, max_size=3)),
             "max_runs": draw(st.integers(0, 4))}
    if draw(st.booleans()):
        study["design"] = draw(st.fixed_dictionaries(
            {"type": st.sampled_from(["full_factorial", "latin_hypercube", "sobol", "saltelli", "magic"])},
            optional={"points": st.integers(-1, 4), "levels": st.integers(0, 3)}))
    if draw(st.booleans()):
        study["replicates"] = draw(st.integers(0, 2))
    return study


@settings(max_examples=ci_budget(25), suppress_health_check=list(HealthCheck))
@given(studies())
def test_doe_contract(study):
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        (folder / "base.yaml").write_text(yaml.safe_dump(BASE))
        (folder / "study.yaml").write_text(yaml.safe_dump(study, allow_unicode=True))
        code, err = run_main(["doe", str(folder / "study.yaml"), "-o", str(folder / "out")])
        outputs = {"out/runs.jsonl", "out/table.csv", "out/table.h5", "out/analysis.json"}
        event(f"exit {code}")
        assert code in (0, 2), f"exit {code}: {err}"
        if code == 0:
            assert outputs <= _files(folder)
            assert not [f for f in _files(folder) if Path(f).name.startswith(".")]
            assert _files(folder) - outputs - {"base.yaml", "study.yaml"} <= {f"out/{p}" for p in (
                "main_effects.png", "response_surface.png", "sobol.png")}
        else:
            check_contract(code, err, folder, {"base.yaml", "study.yaml"}, set(), may_remain={"out/runs.jsonl"})
