"""One home per concept: the rate of change of temperature, held-out folds, the noise floor and
the face of a static stretch are each implemented once (and grep-able); no public name is defined
twice across twin/, sim/ and fitting/. Pure ast, plus a few fast numbers on the homes themselves."""

import ast
from collections import defaultdict
from functools import cache

import numpy as np
import pytest

from conftest import ROOT
from twin.arrays import interleaved_folds, temperature_rate_c_per_s

TWIN = sorted((ROOT / "twin").rglob("*.py"))
LIBRARY = sorted(p for d in ("twin", "sim", "fitting") for p in (ROOT / d).rglob("*.py"))
RATE_HOME = "twin/arrays.py"
NOISE_HOME = "twin/estimation/noise.py"
FACE_HOME = "twin/measurement/quality.py"

#: public names defined in two modules on purpose, with the reason (a new collision fails)
SHARED_NAMES: dict[str, set[str]] = {}
#: noise-floor functions outside the home, with why they are not a second estimator
NOISE_FLOOR_ELSEWHERE = {
    # a study response reading the diagnosis's floor, not an estimator
    ("twin/studies/standard_responses.py", "noise_floor_mg"),
    # the sensor model's σ from its datasheet figures, quoted beside the floor from the data
    ("twin/diagnosis/compare.py", "sensor_noise_floor_g"),
}


def _rel(path) -> str:
    return path.relative_to(ROOT).as_posix()


@cache
def _tree(path) -> ast.Module:
    return ast.parse(path.read_text(), filename=str(path))


def _calls(tree, attr: str):
    for node in ast.walk(tree):
        if isinstance(node, ast.Call) and isinstance(node.func, (ast.Attribute, ast.Name)):
            if (node.func.attr if isinstance(node.func, ast.Attribute) else node.func.id) == attr:
                yield node


def _defs(tree):
    """Top-level functions and classes: name → line."""
    return {n.name: n.lineno for n in tree.body if isinstance(n, (ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef))}


# ------------------------------------------------------------------------------ rate of change

def test_dT_dt_is_computed_only_by_temperature_rate_c_per_s():
    """``np.gradient`` in twin/ only in the home, or as a slope against temperature (d/dT, whose
    spacing argument is a temperature), never a rate over time or rows."""
    offenders = []
    for path in TWIN:
        if _rel(path) == RATE_HOME:
            continue
        for call in _calls(_tree(path), "gradient"):
            spacing = ast.unparse(call.args[1]) if len(call.args) > 1 else ""
            if "temperature" not in spacing:
                offenders.append(f"{_rel(path)}:{call.lineno}: {ast.unparse(call)}")
    assert not offenders, "use twin.arrays.temperature_rate_c_per_s:\n" + "\n".join(offenders)


def test_rate_functions_are_the_home_or_call_it():
    offenders = []
    for path in TWIN:
        for node in ast.walk(_tree(path)):
            if isinstance(node, ast.FunctionDef) and node.name.endswith(("rate_c_per_s", "rate_c_per_min")):
                home = _rel(path) == RATE_HOME and node.name == "temperature_rate_c_per_s"
                if not home and not any(_calls(node, "temperature_rate_c_per_s")):
                    offenders.append(f"{_rel(path)}:{node.lineno}: {node.name}")
    assert not offenders, offenders


def test_the_rate_methods_on_a_known_temperature():
    t = np.arange(0.0, 600.0, 2.0)
    T = 20 + 0.05 * t  # 0.05 °C/s
    run = np.repeat([0, 1], t.size // 2)
    assert np.allclose(temperature_rate_c_per_s(t, T), 0.05)
    assert np.allclose(temperature_rate_c_per_s(2.0, T, smooth_s=60.0)[20:-20], 0.05)
    assert np.allclose(temperature_rate_c_per_s(t, T, method="forward")[:-1], 0.05)
    assert np.allclose(temperature_rate_c_per_s(t, T, smooth_s=60.0, method="half_windows"), 0.05)
    # runs never mix: a step between runs is no rate
    stepped = T + 30 * run
    assert np.allclose(temperature_rate_c_per_s(t, stepped, run), 0.05)
    assert temperature_rate_c_per_s(t[:1], T[:1]).tolist() == [0.0]
    with pytest.raises(ValueError):
        temperature_rate_c_per_s(t, T, method="spline")


# ------------------------------------------------------------------------------ held-out folds

def _cuts_blocks(func) -> bool:
    """Whether ``func`` cuts rows into blocks itself (integer division, a modulus, ``array_split``)."""
    return any(isinstance(n, ast.BinOp) and isinstance(n.op, (ast.FloorDiv, ast.Mod)) for n in ast.walk(func)) \
        or any(_calls(func, "array_split"))


def test_interleaved_folds_are_built_once():
    found = [f"{_rel(p)}:{line}" for p in TWIN for name, line in _defs(_tree(p)).items() if name == "interleaved_folds"]
    assert found == [f"{RATE_HOME}:{_defs(_tree(ROOT / RATE_HOME))['interleaved_folds']}"], found
    offenders = []
    for path in TWIN:
        if _rel(path) == RATE_HOME:
            continue
        for node in ast.walk(_tree(path)):  # blocks dealt round-robin: ``block % folds``
            if isinstance(node, ast.BinOp) and isinstance(node.op, ast.Mod) and "fold" in ast.unparse(node.right):
                offenders.append(f"{_rel(path)}:{node.lineno}: {ast.unparse(node)}")
            if isinstance(node, ast.FunctionDef) and node.name.endswith("folds") and _cuts_blocks(node) \
                    and not any(_calls(node, "interleaved_folds")):
                offenders.append(f"{_rel(path)}:{node.lineno}: {node.name} builds folds of its own")
    assert not offenders, "use twin.arrays.interleaved_folds:\n" + "\n".join(offenders)


def test_fitting_holds_out_rows_with_its_one_split():
    """fitting/ imports nothing from twin: its own interleaved blocks live in fitting/splits.py."""
    offenders = [f"{_rel(p)}:{n.lineno}: {ast.unparse(n)}" for p in sorted((ROOT / "fitting").rglob("*.py"))
                 if _rel(p) != "fitting/splits.py" for n in ast.walk(_tree(p))
                 if isinstance(n, ast.BinOp) and isinstance(n.op, ast.Mod)
                 and isinstance(n.left, ast.BinOp) and isinstance(n.left.op, ast.FloorDiv)]
    assert not offenders, "use fitting.splits.interleaved_validation_mask:\n" + "\n".join(offenders)


def test_interleaved_folds_layouts():
    assert interleaved_folds(np.arange(13), 2, block_rows=3).tolist() == [0, 0, 0, 1, 1, 1, 0, 0, 0, 1, 1, 1, 0]
    fold = interleaved_folds(np.arange(200.0)[::-1], 5, 4)  # time order, not row order
    assert fold[::-1][:10].tolist() == [0] * 10 and np.bincount(fold).tolist() == [40] * 5
    with pytest.raises(ValueError):
        interleaved_folds(np.arange(10), 2)


# ------------------------------------------------------------------------------ noise floor

def _calls_home_estimator(func: ast.AST) -> bool:
    """A noise-floor function elsewhere is fine when it only applies the home's estimator."""
    return any(isinstance(n, ast.Call) and getattr(n.func, "id", getattr(n.func, "attr", "")) in
               ("white_sigma_of_differences", "white_noise_sigma_from_differences", "white_sigma_in_place")
               for n in ast.walk(func))


def test_the_noise_floor_has_one_estimator():
    offenders = []
    for path in TWIN:
        rel = _rel(path)
        tree = _tree(path)
        for node in ast.walk(tree):
            if rel != NOISE_HOME and isinstance(node, ast.Constant) and node.value == 0.6745:
                offenders.append(f"{rel}:{node.lineno}: a robust σ of differences (0.6745)")
        for node in tree.body:  # top-level functions: a method like above_noise_floor is a check
            if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)) and rel != NOISE_HOME \
                    and ("noise_floor" in node.name or "white_sigma" in node.name) \
                    and (rel, node.name) not in NOISE_FLOOR_ELSEWHERE and not _calls_home_estimator(node):
                offenders.append(f"{rel}:{node.lineno}: {node.name}")
    assert not offenders, "use twin.estimation.noise.white_sigma_of_differences:\n" + "\n".join(offenders)


# ------------------------------------------------------------------------------ faces

def test_faces_are_named_and_clustered_in_the_log_quality_stage():
    homes = defaultdict(list)
    for path in TWIN:
        for name in _defs(_tree(path)):
            if name in ("face_label", "face_gravity", "cluster_directions", "assess_log"):
                homes[name].append(_rel(path))
    assert dict(homes) == {"face_label": [FACE_HOME], "face_gravity": [FACE_HOME],
                           "cluster_directions": [FACE_HOME], "assess_log": [FACE_HOME]}
    offenders = [f"{_rel(p)}:{c.lineno}" for p in TWIN if _rel(p) != FACE_HOME
                 for c in _calls(_tree(p), "radians") if "tol" in ast.unparse(c)]
    assert not offenders, "a face tolerance outside the log-quality stage: " + ", ".join(offenders)


# ------------------------------------------------------------------------------ collisions

def test_no_public_name_is_defined_in_two_modules():
    where = defaultdict(set)
    for path in LIBRARY:
        for name in _defs(_tree(path)):
            if not name.startswith("_"):
                where[name].add(_rel(path))
    twice = {name: sorted(paths) for name, paths in where.items()
             if len(paths) > 1 and SHARED_NAMES.get(name) != paths}
    assert not twice, f"one name, two meanings (rename one): {twice}"
