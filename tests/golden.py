"""The JSON outputs of ``make run``, with volatile keys removed, for the behaviour-unchanged test.

``python tests/golden.py`` rewrites ``tests/golden/*.json`` from the current code: run it only
when a change of behaviour is intended, and say so in the commit.
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))

from conftest import run_cli  # noqa: E402

GOLDEN = HERE / "golden"
# Keys whose values change from run to run by design: clocks, timings, versions, paths.
VOLATILE = {"created_utc", "created", "timestamp", "timings_s", "timing_s", "fit_seconds", "seconds",
            "software_version", "version", "versions", "output", "files", "report", "ledger", "wall_s",
            "elapsed_s", "data_fingerprint", "fit_time_s"}


def normalise(value):
    """``value`` without volatile keys (recursively)."""
    if isinstance(value, dict):
        return {k: normalise(v) for k, v in value.items() if k not in VOLATILE}
    if isinstance(value, list):
        return [normalise(v) for v in value]
    return value


def _json(path: Path) -> dict:
    return normalise(json.loads(path.read_text()))


def make_run_outputs(tmp: Path) -> dict[str, dict]:
    """Run the Makefile's ``run`` steps whose results are JSON, into ``tmp``; the normalised results."""
    def cli(*args):
        r = run_cli(*args, timeout=1200)
        assert r.returncode == 0, f"twin {' '.join(args)}: {r.stderr}"

    cli("run", "scenarios/paper_iis328dq.yaml", "-o", str(tmp / "paper.h5"), "--json", str(tmp / "paper.json"), "-q")
    cli("test-design", "--json", str(tmp / "test_design.json"))
    cli("paper", "--json", str(tmp / "paper_numbers.json"))
    cli("comb", "scenarios/paper_iis328dq.yaml", "--json", str(tmp / "comb.json"))
    cli("run", "scenarios/hidden_thermal_lag.yaml", "-o", str(tmp / "hidden.h5"), "-q")
    cli("export", str(tmp / "hidden.h5"), "-o", str(tmp / "hidden.csv"))
    cli("compare", "scenarios/hidden_thermal_lag.yaml", str(tmp / "hidden.csv"), "--json", str(tmp / "base.json"))
    named = json.loads((tmp / "base.json").read_text())["candidates"][0]["effect"]
    cli("compare", "scenarios/hidden_thermal_lag.yaml", str(tmp / "hidden.csv"), "--json", str(tmp / "after.json"),
        "--with-effect", named)
    cli("benchmark", "scenarios/paper_iis328dq.yaml", "--quick", "--seeds", "1", "--json",
        str(tmp / "benchmark_quick.json"))
    names = ("paper", "test_design", "paper_numbers", "comb", "base", "after", "benchmark_quick")
    return {n: _json(tmp / f"{n}.json") for n in names}


if __name__ == "__main__":
    import tempfile

    GOLDEN.mkdir(exist_ok=True)
    with tempfile.TemporaryDirectory() as d:
        for name, data in make_run_outputs(Path(d)).items():
            (GOLDEN / f"{name}.json").write_text(json.dumps(data, indent=1, sort_keys=True) + "\n")
            print("wrote", GOLDEN / f"{name}.json")
