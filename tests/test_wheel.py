"""The package as a user installs it: a built wheel (not the editable source tree) with its data files.

The wheel is built without build isolation (setuptools is in the venv; the CI machine may have no
index) and installed with ``--no-deps`` into a target directory placed first on ``PYTHONPATH``, so
the dependencies come from the venv but every ``twin``, ``sim`` and ``fitting`` module, and every
data file, comes from the wheel.
"""

from __future__ import annotations

import os
import subprocess
import sys
import zipfile
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


@pytest.fixture(scope="module")
def installed(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("wheel")
    build = subprocess.run([sys.executable, "-m", "pip", "wheel", "--no-deps", "--no-build-isolation", "-q",
                            "-w", str(tmp / "dist"), str(ROOT)], capture_output=True, text=True,
                           cwd=tmp, timeout=600)
    assert build.returncode == 0, build.stderr[-2000:]
    wheel = next((tmp / "dist").glob("tde_twin-*.whl"))
    target = tmp / "site"
    inst = subprocess.run([sys.executable, "-m", "pip", "install", "--no-deps", "-q", "--target", str(target),
                           str(wheel)], capture_output=True, text=True, timeout=600)
    assert inst.returncode == 0, inst.stderr[-2000:]
    return wheel, target


def _run(target: Path, *args: str) -> subprocess.CompletedProcess:
    env = {**os.environ, "PYTHONPATH": str(target)}
    # cwd away from the source tree, so `import twin` cannot find the checkout
    return subprocess.run([sys.executable, *args], capture_output=True, text=True, env=env,
                          cwd=target.parent, timeout=600)


def test_wheel_holds_every_module_and_data_file(installed):
    wheel, _ = installed
    names = set(zipfile.ZipFile(wheel).namelist())
    for package in ("twin", "sim", "fitting"):
        for src in (ROOT / package).rglob("*"):
            if src.suffix in (".py", ".yaml") and "__pycache__" not in src.parts:
                assert src.relative_to(ROOT).as_posix() in names, f"{src.relative_to(ROOT)} missing from {wheel.name}"
    assert not any(n.startswith(("tests/", "docs/", "benchmarks/")) for n in names)


def test_installed_wheel_runs_from_its_own_files(installed, tmp_path):
    _, target = installed
    code = ("import twin, sim, fitting, twin.parts as p; "
            "print(twin.__file__); print(twin.__version__); print(p.load_part('IIS328DQ').name)")
    r = _run(target, "-c", code)
    assert r.returncode == 0, r.stderr[-2000:]
    file, version, part = r.stdout.split("\n")[:3]
    assert Path(file).is_relative_to(target), file  # the wheel's copy, not the checkout
    assert version == "0.1.0" or version.startswith("0."), version
    assert part
    r = _run(target, "-m", "twin.cli", "--version")
    assert r.returncode == 0 and r.stdout.strip() == f"twin {version}", (r.stdout, r.stderr)
    # a real command from the wheel: simulate the paper scenario's chamber test into HDF5
    out = tmp_path / "paper.h5"
    r = _run(target, "-m", "twin.cli", "run", str(ROOT / "scenarios" / "paper_iis328dq.yaml"), "-o", str(out), "-q")
    assert r.returncode == 0, r.stderr[-2000:]
    assert out.stat().st_size > 10_000
