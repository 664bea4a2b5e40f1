"""The house keeps its shape: import direction between subsystems, no private cross-imports, a
light ``import twin``, modules of readable size."""

import ast
import subprocess
import sys

import pytest

from conftest import ROOT

# twin's subsystems, lowest first: a module may import only from its own layer or the ones below
# (docs/architecture.md draws the same picture).
LAYERS = [
    {"twin", "twin.errors", "twin.io", "twin.text", "twin.plugins", "twin.arrays"},
    {"twin.parts", "twin.firmware"},
    {"twin.effects"},
    {"twin.model"},
    {"twin.measurement"},
    {"twin.diagnosis"},
    {"twin.reporting"},
    {"twin.compensation", "twin.calibration"},
    {"twin.studies", "twin.fleet"},
    {"twin.cli"},
]
RANK = {name: i for i, layer in enumerate(LAYERS) for name in layer}
SOURCES = [p for d in ("twin", "sim", "fitting", "tests", "benchmarks") for p in (ROOT / d).rglob("*.py")]


def _imports(path):
    """(module imported, names imported) for every import in ``path``, nested ones included."""
    tree = ast.parse(path.read_text())
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            yield from ((a.name, []) for a in node.names)
        elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
            yield node.module, [a.name for a in node.names]


def _subsystem(module: str) -> str:
    """``twin.diagnosis.screen`` → ``twin.diagnosis``; ``twin.errors`` → ``twin.errors``."""
    parts = module.split(".")
    return ".".join(parts[:2]) if len(parts) > 1 else parts[0]


def _module_name(path) -> str:
    rel = path.relative_to(ROOT).with_suffix("")
    return ".".join(rel.parts[:-1] if rel.name == "__init__" else rel.parts)


@pytest.mark.parametrize("package,forbidden", [("sim", {"twin", "fitting"}), ("fitting", {"twin", "sim"})])
def test_sim_and_fitting_import_nothing_from_the_other_packages(package, forbidden):
    files = list((ROOT / package).rglob("*.py"))
    assert files
    for f in files:
        bad = {m.split(".")[0] for m, _ in _imports(f)} & forbidden
        assert not bad, f"{f.relative_to(ROOT)} imports {bad}"


def test_every_twin_subsystem_has_a_layer():
    found = {_subsystem(_module_name(p)) for p in (ROOT / "twin").rglob("*.py")}
    assert found <= set(RANK), f"subsystems without a layer in LAYERS: {sorted(found - set(RANK))}"


def test_twin_subsystems_import_only_downwards():
    """Acyclic by construction: every import goes to the same layer or a lower one, and within a
    layer no two subsystems import each other."""
    edges = set()
    for path in (ROOT / "twin").rglob("*.py"):
        src = _subsystem(_module_name(path))
        for module, _ in _imports(path):
            if module.split(".")[0] != "twin":
                continue
            dst = _subsystem(module)
            assert RANK[dst] <= RANK[src], f"{path.relative_to(ROOT)} ({src}) imports {module} from a higher layer"
            if dst != src:
                edges.add((src, dst))
    mutual = {(a, b) for a, b in edges if (b, a) in edges}
    assert not mutual, f"subsystems importing each other: {sorted(mutual)}"


def test_no_module_imports_a_private_name_from_another():
    offenders = []
    for path in SOURCES:
        for module, names in _imports(path):
            if module.split(".")[0] in ("twin", "sim", "fitting") and any(
                    n.startswith("_") and not n.startswith("__") for n in names):
                offenders.append(f"{path.relative_to(ROOT)}: from {module} import {', '.join(names)}")
    assert not offenders, "\n".join(offenders)


def test_library_modules_stay_readable():
    """No module in twin/, sim/, fitting/ over 450 lines (a subsystem grows by files, not by length)."""
    long = {str(p.relative_to(ROOT)): n for d in ("twin", "sim", "fitting") for p in (ROOT / d).rglob("*.py")
            if (n := len(p.read_text().splitlines())) > 450}
    assert not long, long


def test_import_twin_does_not_load_heavy_packages():
    code = ("import sys, twin, twin.cli, twin.model.scenario, twin.model.simulate, twin.model.dataset; "
            "print(sorted(m for m in ('torch', 'pyvista', 'matplotlib', 'vtk') if m in sys.modules))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert out.strip() == "[]"
