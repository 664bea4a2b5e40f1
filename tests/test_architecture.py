"""The house keeps its shape: import direction and a light ``import twin``."""

import ast
import subprocess
import sys

import pytest

from conftest import ROOT


def _imports(path):
    tree = ast.parse(path.read_text())
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            yield from (a.name.split(".")[0] for a in node.names)
        elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
            yield node.module.split(".")[0]


@pytest.mark.parametrize("package,forbidden", [("sim", {"twin", "fitting"}), ("fitting", {"twin", "sim"})])
def test_sim_and_fitting_import_nothing_from_the_other_packages(package, forbidden):
    files = list((ROOT / package).rglob("*.py"))
    assert files
    for f in files:
        bad = set(_imports(f)) & forbidden
        assert not bad, f"{f.relative_to(ROOT)} imports {bad}"


def test_import_twin_does_not_load_heavy_packages():
    code = ("import sys, twin, twin.cli, twin.model.scenario, twin.model.simulate, twin.model.dataset; "
            "print(sorted(m for m in ('torch', 'pyvista', 'matplotlib', 'vtk') if m in sys.modules))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert out.strip() == "[]"
