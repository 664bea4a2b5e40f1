"""Shared fixtures: paths, a coarse version of any scenario, a CLI runner."""

import atexit
import functools
import os
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

import pytest
import yaml

ROOT = Path(__file__).resolve().parents[1]
# studies (test_doe) and fleet specs (test_fleet) are not scenarios
SCENARIOS = sorted(p for p in (ROOT / "scenarios").glob("*.yaml")
                   if not p.stem.startswith("study_") and p.stem != "fleet_mixed")
SHARED = ROOT.parent / "shared"

try:  # property-based tests: a fixed, derandomised budget in CI; HYPOTHESIS_PROFILE=long locally
    from hypothesis import HealthCheck, settings

    _QUIET = [HealthCheck.too_slow, HealthCheck.data_too_large, HealthCheck.function_scoped_fixture]
    settings.register_profile("ci", derandomize=True, deadline=None, max_examples=60,
                              suppress_health_check=_QUIET, print_blob=True)
    settings.register_profile("long", deadline=None, max_examples=20_000, suppress_health_check=_QUIET,
                              print_blob=True)
    settings.load_profile(os.environ.get("HYPOTHESIS_PROFILE", "ci"))
except ImportError:  # hypothesis is a test extra; the property tests skip without it
    pass


def coarse_text(path: Path, rate_hz: float = 0.5, max_cycles: int = 1) -> str:
    """The scenario at a coarse logger rate and at most ``max_cycles`` cycles (for fast tests)."""
    data = yaml.safe_load(path.read_text())
    data.setdefault("test_plan", {})["logger_rate_hz"] = rate_hz
    data["program"]["cycles"] = min(data["program"].get("cycles", 1), max_cycles)
    return yaml.safe_dump(data, sort_keys=False)


@functools.cache
def log_corpus() -> Path:
    """The adversarial log corpus in a temporary folder, built once per test process: the committed
    text files of tests/adversarial/logs and the binary ones its ``make_corpus.write_binary`` writes."""
    source = ROOT / "tests" / "adversarial" / "logs"
    folder = Path(tempfile.mkdtemp(prefix="twin-log-corpus-"))
    atexit.register(shutil.rmtree, folder, True)
    for path in source.iterdir():
        if path.is_file() and path.name not in ("expect.yaml", "make_corpus.py"):
            shutil.copyfile(path, folder / path.name)
    sys.path.insert(0, str(source))
    try:
        import make_corpus
    finally:
        sys.path.remove(str(source))
    make_corpus.write_binary(folder)
    return folder


def record_results(monkeypatch, owner, name: str) -> list:
    """Replace ``owner.name`` by a wrapper that appends each result to the returned list."""
    original = getattr(owner, name)

    def spy(*args, **kwargs):
        result = original(*args, **kwargs)
        taken.append(result)
        return result

    taken: list = []
    monkeypatch.setattr(owner, name, spy)
    return taken


def run_in_process(argv) -> tuple[int, str, str]:
    """``twin argv`` in this process (fast; for many small cases): exit code, stdout, stderr."""
    import contextlib
    import io

    from twin.cli import main

    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        try:
            main([str(a) for a in argv])
            code = 0
        except SystemExit as exc:
            code = exc.code if isinstance(exc.code, int) else 1
    return code, out.getvalue(), err.getvalue()


def run_cli(*args: str, cwd: Path | None = None, timeout: float = 300,
            warnings: str = "default") -> subprocess.CompletedProcess:
    """Run ``twin`` as a user would (a fresh process), warnings shown as a user sees them: a warning
    line breaks the one-line promise of a refusal. ``warnings``: its PYTHONWARNINGS."""
    env = {**os.environ, "PYTHONWARNINGS": warnings}
    return subprocess.run([sys.executable, "-m", "twin.cli", *args], capture_output=True, text=True,
                          cwd=cwd or ROOT, env=env, timeout=timeout)


def assert_one_clear_line(text: str, fragments: list[str]) -> None:
    """Parsing ``text`` raises a one-line ScenarioError holding every fragment."""
    from twin.errors import ScenarioError
    from twin.model.scenario import parse_scenario

    with pytest.raises(ScenarioError) as exc:
        parse_scenario(text, "<t>")
    message = str(exc.value)
    assert "\n" not in message
    for fragment in fragments:
        assert fragment in message, message


@pytest.fixture(scope="session")
def paper_path() -> Path:
    return ROOT / "scenarios" / "paper_iis328dq.yaml"


def run_quick_benchmark(folder: Path) -> Path:
    """``twin benchmark --quick --seeds 1`` into ``folder`` (``benchmark_quick.json`` and ``rep/``)."""
    r = run_cli("benchmark", "scenarios/paper_iis328dq.yaml", "--quick", "--seeds", "1", "--json",
                str(folder / "benchmark_quick.json"), "--report", str(folder / "rep"), timeout=1200)
    assert r.returncode == 0, r.stderr
    return folder


@pytest.fixture(scope="session")
def quick_benchmark(tmp_path_factory):
    """The folder of one quick benchmark run, shared by the session (the golden check and the
    benchmark's own test read the same run: it trains six networks)."""
    return run_quick_benchmark(tmp_path_factory.mktemp("benchmark_quick"))

