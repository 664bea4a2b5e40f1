"""Bad input never crashes, hangs or overwrites (issue 14, scenario / run / render / study side).

``tests/adversarial/model/`` holds one file per adversarial case; its header says the command
(``FILE`` = the file, ``OUT`` = a fresh output path, ``DIR`` = an existing folder) and the
contract: ``expect: 0`` (success, finite output) or ``expect: 2 FRAGMENT`` (exit 2, one line
``twin: error: ...`` holding FRAGMENT). Either way nothing is written outside the named output,
and on failure nothing at all.
"""

from __future__ import annotations

import hashlib
import json
import os
import resource
import shlex
import shutil
import subprocess
import sys
import time
from pathlib import Path

import h5py
import numpy as np
import pytest
from conftest import ROOT, coarse_text
from conftest import run_in_process as run_main

CORPUS = ROOT / "tests" / "adversarial" / "model"
CASES = sorted(p.name for p in CORPUS.glob("*.yaml"))




def snapshot(folder: Path) -> dict[str, str]:
    """Every file below ``folder`` (hidden ones included) with its content hash."""
    return {str(p.relative_to(folder)): hashlib.sha256(p.read_bytes()).hexdigest()
            for p in sorted(folder.rglob("*")) if p.is_file()}


def header(path: Path) -> dict[str, str]:
    fields = {}
    for line in path.read_bytes().decode("utf-8", "replace").splitlines()[:3]:
        key, _, value = line.lstrip("# ").partition(": ")
        fields[key] = value.strip()
    return fields


@pytest.fixture(scope="module")
def corpus(tmp_path_factory) -> Path:
    """The corpus copied once (plugins then resolve to one path, so each registers once)."""
    folder = tmp_path_factory.mktemp("corpus")
    for p in CORPUS.iterdir():
        shutil.copy(p, folder / p.name)
    return folder


@pytest.fixture(autouse=True)
def _registries_restored():
    """Effects registered by the corpus's plugins are removed again (other tests list the registry)."""
    from twin.effects import REGISTRY

    before = set(REGISTRY)
    yield
    for name in set(REGISTRY) - before:
        REGISTRY.pop(name)


def assert_finite_dataset(path: Path) -> None:
    with h5py.File(path, "r") as f:
        assert len(f["time_s"]) > 0
        bad = []
        f.visititems(lambda name, obj: bad.append(name) if isinstance(obj, h5py.Dataset)
                     and obj.dtype.kind == "f" and not np.all(np.isfinite(obj[()])) else None)
        assert not bad, bad


@pytest.mark.parametrize("name", CASES)
def test_adversarial_corpus(name, corpus, tmp_path):
    spec = header(corpus / name)
    out_dir = tmp_path / "out"
    out_dir.mkdir()
    out = out_dir / "result"
    args = [a.replace("FILE", str(corpus / name)).replace("OUT", str(out)).replace("DIR", str(out_dir))
            for a in shlex.split(spec["cmd"])]
    before_in, before_out = snapshot(corpus), snapshot(out_dir)
    t0 = time.perf_counter()
    code, stdout, stderr = run_main(args)
    elapsed = time.perf_counter() - t0
    assert elapsed < 20, f"{name}: {elapsed:.1f} s (a hang, or a limit checked too late)"
    assert "Traceback" not in stderr + stdout
    assert snapshot(corpus) == before_in, f"{name}: an input was changed"
    expect = spec["expect"].split(" ", 1)
    if expect[0] == "0":
        assert code == 0, f"{name}: {stderr}"
        written = [p for p in out_dir.rglob("*") if p.is_file()]
        assert written and not [p for p in written if p.name.startswith(".")], written  # no temporary left
        for p in written:
            if p.suffix == ".h5" and p.name != "table.h5":
                assert_finite_dataset(p)
        return
    assert code == 2, f"{name}: exit {code}: {stderr}"
    lines = stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("twin: error: "), stderr
    assert expect[1] in lines[0], lines[0]
    left = set(snapshot(out_dir)) - set(before_out)
    if spec["cmd"].startswith("doe") and "all" in expect[1]:
        left -= {"result/runs.jsonl"}  # the failed runs' durable record, kept for the user to read
    assert not left, f"{name}: left {sorted(left)}"


def test_corpus_covers_every_category():
    """The issue's categories each have a case (a guard against the corpus shrinking)."""
    names = " ".join(CASES)
    for fragment in ("nan_", "inf_", "zero_duration", "dwell_1e12", "staircase_step_1e-12", "runs_1e8", "cycles_1e9",
                     "cycles_1e30", "start_minus_300", "seed_2_70", "yaml_self_alias", "yaml_deep_nesting",
                     "yaml_billion_laughs", "plugin_raises", "plugin_basis_raises", "study_duplicate_responses",
                     "study_factorial_1e18", "out_is_input", "out_is_directory", "study_dead_scheduler",
                     "render_sweep_tiny_step", "render_temperature_2000", "two_orientations_same_instant",
                     "study_invalid_base"):
        assert fragment in names, fragment


# ------------------------------------------------------------------ outputs: size limit, temporaries


def _tiny(tmp_path: Path) -> Path:
    path = tmp_path / "s.yaml"
    path.write_text(coarse_text(ROOT / "scenarios" / "paper_iis328dq.yaml", rate_hz=2.0))
    return path


def test_file_size_limit_is_one_line_not_a_segfault(tmp_path):
    """``ulimit -f``: the HDF5 write used to segfault (exit 139) and leave a .tmp; now exit 2, one line, nothing left."""
    scenario = _tiny(tmp_path)
    out = tmp_path / "o" / "big.h5"

    def limit():  # 100 kB: far below the dataset (~2 MB)
        resource.setrlimit(resource.RLIMIT_FSIZE, (100_000, 100_000))

    proc = subprocess.run([sys.executable, "-m", "twin.cli", "run", str(scenario), "-o", str(out), "-q"],
                          capture_output=True, text=True, preexec_fn=limit, cwd=ROOT, timeout=120,
                          env={**os.environ, "PYTHONWARNINGS": "ignore"})
    assert proc.returncode == 2, (proc.returncode, proc.stderr[-2000:])
    assert proc.stderr.strip().count("\n") == 0 and "File too large" in proc.stderr, proc.stderr
    assert list((tmp_path / "o").iterdir()) == []  # neither the file nor a temporary


def test_full_disk_leaves_nothing(tmp_path, monkeypatch):
    """ENOSPC in the write (simulated): one line, exit 2, no partial and no temporary file."""
    import errno

    import twin.io

    scenario = _tiny(tmp_path)
    real_open = open

    class FullFile:
        def __init__(self, f):
            self.f = f

        def __enter__(self):
            return self

        def __exit__(self, *a):
            self.f.close()

        def write(self, data):
            self.f.write(data[: len(data) // 2])
            raise OSError(errno.ENOSPC, "No space left on device")

    def fake_open(path, mode="r", *a, **k):
        f = real_open(path, mode, *a, **k)
        return FullFile(f) if "w" in mode and "b" in mode else f

    monkeypatch.setattr(twin.io, "open", fake_open, raising=False)
    out_dir = tmp_path / "o"
    out_dir.mkdir()
    code, _, err = run_main(["run", str(scenario), "-o", str(out_dir / "x.h5"), "-q"])
    assert code == 2 and "No space left" in err and err.count("\n") == 1, err
    assert list(out_dir.iterdir()) == []


def test_export_refuses_to_overwrite_its_input(tmp_path):
    scenario = _tiny(tmp_path)
    h5 = tmp_path / "d.h5"
    assert run_main(["run", str(scenario), "-o", str(h5), "-q"])[0] == 0
    before = h5.read_bytes()
    code, _, err = run_main(["export", str(h5), "-o", str(h5)])
    assert code == 2 and "overwrite an input" in err
    assert h5.read_bytes() == before


def test_a_written_dataset_reads_back_identically(tmp_path):
    """The in-memory HDF5 image written by Python is the same dataset (round trip, every array)."""
    from twin.model.dataset import read_hdf5
    from twin.model.scenario import load_scenario
    from twin.model.simulate import simulate

    ds = simulate(load_scenario(_tiny(tmp_path)))
    from twin.model.dataset import write_hdf5

    for comp in ("lzf", "gzip", "none"):
        back = read_hdf5(write_hdf5(ds, tmp_path / f"{comp}.h5", compression=comp))
        assert set(back.arrays) == set(ds.arrays)
        for k, v in ds.arrays.items():
            np.testing.assert_array_equal(back[k], v)
            assert back.units[k] == ds.units[k]
        assert back.attrs["seed"] == ds.attrs["seed"]


# ------------------------------------------------------------------ durable studies


def _study(tmp_path: Path, levels=(0.0, 5.0)) -> Path:
    shutil.copy(CORPUS / "ok_tiny.yaml", tmp_path / "ok_tiny.yaml")
    study = tmp_path / "study.yaml"
    study.write_text(json.dumps({"base": "ok_tiny.yaml", "seed": 1, "responses": ["chamber_hours"],
                                 "factors": {"device.sensor.zero_g_offset_mg": {"levels": list(levels)}}}))
    return study


def test_a_torn_last_line_is_dropped_and_its_run_redone(tmp_path):
    study, out = _study(tmp_path, (0.0, 5.0, 10.0)), tmp_path / "out"
    assert run_main(["doe", str(study), "-o", str(out)])[0] == 0
    log = out / "runs.jsonl"
    records = log.read_text().splitlines()
    assert len(records) == 3
    torn = records[2][: len(records[2]) // 2]  # a kill during the third append
    log.write_text("\n".join(records[:2]) + "\n" + torn)
    code, _, err = run_main(["doe", str(study), "-o", str(out)])
    assert code == 0, err
    lines = log.read_text().splitlines()
    assert len(lines) == 3 and all(json.loads(line)["status"] == "ok" for line in lines)  # redone, nothing glued
    assert sorted(json.loads(line)["key"] for line in lines) == sorted(json.loads(r)["key"] for r in records)


def test_a_foreign_line_is_refused(tmp_path):
    study, out = _study(tmp_path), tmp_path / "out"
    out.mkdir()
    (out / "runs.jsonl").write_text("hello, this folder holds something else\n{}\n")
    code, _, err = run_main(["doe", str(study), "-o", str(out)])
    assert code == 2 and "runs.jsonl:1: not a run record" in err and err.count("\n") == 1, err


def test_stale_temporaries_of_a_killed_study_are_removed(tmp_path):
    study, out = _study(tmp_path), tmp_path / "out"
    out.mkdir()
    stale = [out / ".table.h5.abc123.tmp", out / ".analysis.json.x9.tmp", out / ".main_effects.png.q.tmp"]
    for p in stale:
        p.write_bytes(b"half")
    keep = out / "notes.txt"
    keep.write_text("mine")
    assert run_main(["doe", str(study), "-o", str(out)])[0] == 0
    assert not any(p.exists() for p in stale)
    assert keep.read_text() == "mine"
    assert not [p for p in out.iterdir() if p.name.startswith(".")]


def test_killing_the_parent_ends_its_pool_workers(tmp_path):
    """``kill -9`` of ``twin doe --workers 2``: the two pool workers end too (parent-death signal)."""
    import psutil

    yaml_text = (CORPUS / "ok_tiny.yaml").read_text()
    (tmp_path / "slow.yaml").write_text(yaml_text.replace("logger_rate_hz: 0.1", "logger_rate_hz: 5.0"))
    study = tmp_path / "study.yaml"
    study.write_text(json.dumps({"base": "slow.yaml", "seed": 1, "responses": ["residual_rms_mg"], "max_runs": 50,
                                 "factors": {"device.sensor.zero_g_offset_mg": {"range": [0, 5]}},
                                 "design": {"type": "latin_hypercube", "points": 40}}))
    proc = subprocess.Popen([sys.executable, "-m", "twin.cli", "doe", str(study), "-o", str(tmp_path / "out"),
                             "--workers", "2"], cwd=ROOT, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    try:
        deadline = time.time() + 60
        children = []
        while time.time() < deadline and len(children) < 2:
            time.sleep(0.5)
            children = psutil.Process(proc.pid).children(recursive=True)
        assert len(children) >= 2, "the pool never started"
        proc.kill()
        proc.wait()
        gone, alive = psutil.wait_procs(children, timeout=10)
        assert not alive, [c.pid for c in alive]
    finally:
        if proc.poll() is None:
            proc.kill()


@pytest.mark.parametrize("steps", [[("Hold", (float("nan"),))], [("Ramp", (float("inf"), 10.0))],
                                   [("Staircase", (30.0, 0.4, float("nan")))]])
def test_the_program_kernel_refuses_non_finite_numbers(steps):
    """sim.program on its own (no schema in front): NaN would pass its '> 0' tests the wrong way."""
    from sim import program as prog

    with pytest.raises(prog.ProgramError, match="finite"):
        prog.compile_program(-20.0, [getattr(prog, kind)(*args) for kind, args in steps])


def test_libyaml_reads_every_document_as_the_python_parser_does(monkeypatch):
    """Scenarios, parts and the adversarial corpus are parsed with libyaml's parser where PyYAML has
    it: the same data, key lines and messages (refusals, malformed YAML) as with the pure-Python
    SafeLoader alone."""
    import yaml

    import twin.text
    from twin.errors import ScenarioError

    def outcome(text):
        try:
            return twin.text.load_yaml_mapping(text, "f", "a mapping")
        except ScenarioError as exc:
            return str(exc)

    files = sorted(ROOT.glob("scenarios/*.yaml")) + sorted(ROOT.glob("twin/parts/*.yaml")) + sorted(CORPUS.glob("*.yaml"))
    assert len(files) > 30 and twin.text.LOADER is getattr(yaml, "CSafeLoader", yaml.SafeLoader)
    texts = [f.read_text(encoding="utf-8", errors="replace") for f in files]
    fast = [outcome(t) for t in texts]
    monkeypatch.setattr(twin.text, "LOADER", yaml.SafeLoader)
    python = [outcome(t) for t in texts]
    for f, a, b in zip(files, fast, python):
        assert repr(a) == repr(b), f.name
    messages = " ".join(x for x in python if isinstance(x, str))
    assert "malformed YAML" in messages and "nested deeper" in messages and "got list" in messages
