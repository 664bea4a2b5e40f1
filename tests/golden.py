"""The JSON outputs of ``make run``, with volatile keys removed, for the behaviour-unchanged test.

``python tests/golden.py`` rewrites ``tests/golden/*.json`` from the current code: run it only
when a change of behaviour is intended, and say so in the commit.
"""

from __future__ import annotations

import json
import math
import re
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


NUMBER = re.compile(r"[-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?")


def cpu_kind() -> str:
    """The CPU vendor and widest vector unit, e.g. ``AuthenticAMD-avx512``, from /proc/cpuinfo.

    The compiled fitness kernel is built for the machine it runs on, so an AVX-512 and an AVX2 CPU
    sum a network's errors in lanes of different width; ``unknown`` when /proc/cpuinfo is absent.
    """
    try:
        text = Path("/proc/cpuinfo").read_text()
    except OSError:
        return "unknown"
    vendor = re.search(r"^vendor_id\s*:\s*(\S+)", text, re.M)
    found = re.search(r"^flags\s*:(.*)$", text, re.M)
    flags = set(found.group(1).split()) if found else set()
    isa = "avx512" if "avx512f" in flags else "avx2" if "avx2" in flags else "other"
    return f"{vendor.group(1) if vendor else 'unknown'}-{isa}"


def differences(new, old, rel: float, abs_: float, path: str = "") -> list[str]:
    """Where ``new`` and ``old`` differ: structure, keys and text exactly; numbers (also those inside
    text) within ``rel`` relative or ``abs_`` absolute. Empty when they agree."""
    if isinstance(new, dict) and isinstance(old, dict):
        if set(new) != set(old):
            return [f"{path}: keys differ: {sorted(set(new) ^ set(old))}"]
        return [d for k in sorted(new) for d in differences(new[k], old[k], rel, abs_, f"{path}.{k}")]
    if isinstance(new, list) and isinstance(old, list):
        if len(new) != len(old):
            return [f"{path}: {len(new)} items, recorded {len(old)}"]
        return [d for i, (a, b) in enumerate(zip(new, old)) for d in differences(a, b, rel, abs_, f"{path}[{i}]")]
    if isinstance(new, str) and isinstance(old, str):
        a, b = NUMBER.split(new), NUMBER.split(old)
        if a != b:
            return [f"{path}: {new!r} != {old!r}"]
        return differences([float(x) for x in NUMBER.findall(new)], [float(x) for x in NUMBER.findall(old)],
                           rel, abs_, path)
    numbers = (int, float)
    if (isinstance(new, numbers) and isinstance(old, numbers) and not isinstance(new, bool)
            and not isinstance(old, bool)):
        return [] if math.isclose(new, old, rel_tol=rel, abs_tol=abs_) else [f"{path}: {new!r} != {old!r}"]
    return [] if new == old else [f"{path}: {new!r} != {old!r}"]


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
    base = json.loads((tmp / "base.json").read_text())
    named = (base["selected"] + [c["effect"] for c in base["candidates"]])[0]
    cli("compare", "scenarios/hidden_thermal_lag.yaml", str(tmp / "hidden.csv"), "--json", str(tmp / "after.json"),
        "--with-effect", named)
    cli("benchmark", "scenarios/paper_iis328dq.yaml", "--quick", "--seeds", "1", "--json",
        str(tmp / "benchmark_quick.json"))
    names = ("paper", "test_design", "paper_numbers", "comb", "base", "after", "benchmark_quick")
    return {n: _json(tmp / f"{n}.json") for n in names}


# Outputs of trained neural networks: float32 searches and non-convex fits amplify last-bit
# differences between CPUs' SIMD paths, so they are recorded per CPU kind (tests/test_golden.py).
PER_CPU = ("benchmark_quick",)


def recorded_path(name: str, kind: str | None = None) -> Path:
    """Where ``name`` is recorded: per CPU kind (:func:`cpu_kind`) for :data:`PER_CPU`, else one file for all."""
    return GOLDEN / kind / f"{name}.json" if name in PER_CPU and kind else GOLDEN / f"{name}.json"


if __name__ == "__main__":
    import tempfile

    with tempfile.TemporaryDirectory() as d:
        for name, data in make_run_outputs(Path(d)).items():
            path = recorded_path(name, cpu_kind())
            path.parent.mkdir(parents=True, exist_ok=True)
            path.write_text(json.dumps(data, indent=1, sort_keys=True) + "\n")
            print("wrote", path)
