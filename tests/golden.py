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

from conftest import run_cli, run_quick_benchmark  # noqa: E402

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


def printed_unit(number: str) -> float:
    """One unit of the last digit ``number`` is printed to: ``1.873e-06`` → 1e-9, ``0.03`` → 0.01."""
    mantissa, _, exponent = number.lower().partition("e")
    decimals = len(mantissa.partition(".")[2])
    return 10.0 ** (int(exponent or 0) - decimals)


def differences(new, old, rel: float, abs_: float, path: str = "", tolerance=None) -> list[str]:
    """Where ``new`` and ``old`` differ: structure, keys and text exactly; numbers (also those inside
    text) within ``rel`` relative or ``abs_`` absolute. Empty when they agree.

    ``tolerance(path)``, when given, returns ``(relative, absolute, printed)`` for the value at
    ``path`` instead; with ``printed`` a number inside text may also be one unit of the recorded
    number's last printed digit off (a value that moved within its tolerance, rounded for print).
    """
    r, a, printed = tolerance(path) if tolerance else (rel, abs_, False)
    if isinstance(new, dict) and isinstance(old, dict):
        if set(new) != set(old):
            return [f"{path}: keys differ: {sorted(set(new) ^ set(old))}"]
        return [d for k in sorted(new) for d in differences(new[k], old[k], rel, abs_, f"{path}.{k}", tolerance)]
    if isinstance(new, list) and isinstance(old, list):
        if len(new) != len(old):
            return [f"{path}: {len(new)} items, recorded {len(old)}"]
        return [d for i, (x, y) in enumerate(zip(new, old))
                for d in differences(x, y, rel, abs_, f"{path}[{i}]", tolerance)]
    if isinstance(new, str) and isinstance(old, str):
        if NUMBER.split(new) != NUMBER.split(old):
            return [f"{path}: {new!r} != {old!r}"]
        for x, y in zip(NUMBER.findall(new), NUMBER.findall(old)):
            slack = printed_unit(y) if printed else 0.0
            if not math.isclose(float(x), float(y), rel_tol=r, abs_tol=a + slack):
                return [f"{path}: {new!r} != {old!r}"]
        return []
    numbers = (int, float)
    if (isinstance(new, numbers) and isinstance(old, numbers) and not isinstance(new, bool)
            and not isinstance(old, bool)):
        return [] if math.isclose(new, old, rel_tol=r, abs_tol=a) else [f"{path}: {new!r} != {old!r}"]
    return [] if new == old else [f"{path}: {new!r} != {old!r}"]


def _json(path: Path) -> dict:
    return normalise(json.loads(path.read_text()))


def make_run_outputs(tmp: Path, benchmark_dir: Path) -> dict[str, dict]:
    """Run the Makefile's ``run`` steps whose results are JSON, into ``tmp``; the normalised results
    (the quick benchmark's from ``benchmark_dir``, where the session ran it once)."""
    def cli(*args):
        r = run_cli(*args, timeout=1200)
        assert r.returncode == 0, f"twin {' '.join(args)}: {r.stderr}"

    cli("run", "scenarios/paper_iis328dq.yaml", "-o", str(tmp / "paper.h5"), "--json", str(tmp / "paper.json"), "-q")
    cli("test-design", "--json", str(tmp / "test_design.json"))
    cli("paper", "--json", str(tmp / "paper_numbers.json"))
    cli("comb", "scenarios/paper_iis328dq.yaml", "--json", str(tmp / "comb.json"))
    cli("run", "scenarios/hidden_thermal_lag.yaml", "-o", str(tmp / "hidden.h5"), "-q")
    cli("export", str(tmp / "hidden.h5"), "-o", str(tmp / "hidden.csv"), "--json", str(tmp / "export.json"))
    cli("compare", "scenarios/hidden_thermal_lag.yaml", str(tmp / "hidden.csv"), "--json", str(tmp / "base.json"))
    base = json.loads((tmp / "base.json").read_text())
    named = (base["selected"] + [c["effect"] for c in base["candidates"]])[0]
    cli("compare", "scenarios/hidden_thermal_lag.yaml", str(tmp / "hidden.csv"), "--json", str(tmp / "after.json"),
        "--with-effect", named)
    from schemas import check_schema

    for result, file in (("run", "paper"), ("test-design", "test_design"), ("comb", "comb"), ("export", "export"),
                         ("paper", "paper_numbers")):
        check_schema(json.loads((tmp / f"{file}.json").read_text()), result)
    names = ("paper", "test_design", "paper_numbers", "comb", "base", "after")
    return {**{n: _json(tmp / f"{n}.json") for n in names},
            "benchmark_quick": _json(benchmark_dir / "benchmark_quick.json")}


def recorded_path(name: str) -> Path:
    """Where ``name`` is recorded: one file for every CPU."""
    return GOLDEN / f"{name}.json"


# ----------------------------------------------------------------------------------------------
# The quick compensation benchmark: trained neural networks, compared at derived tolerances
# ----------------------------------------------------------------------------------------------
# Every figure below was measured by running `twin benchmark --quick --seeds 1` on one AMD EPYC
# (AVX2) five ways that change only round-off: as is, on one thread (OMP, MKL, OpenBLAS and numba),
# with MKL's AVX and SSE code paths (MKL_CBWR=AVX / COMPATIBLE) together with torch's and OpenBLAS's
# generic kernels and numba built for a Sandy Bridge / generic CPU, and against the recording made
# on an AVX-512 AMD EPYC (tests/golden/benchmark_quick.json). Two runs as is gave identical JSON.
# The spread over network seeds was measured on Test 1's data, seeds 20221-20230 (the recording's
# is 20221).

#: the benchmark's keys whose MSE involves no training (closed-form fits, the physics twin, the
#: floor): round-off only, compared at :data:`REL` / :data:`ABS` like the other goldens (measured:
#: at most 5.2e-13 relative apart)
UNTRAINED = ("polynomial_T", "physics_twin", "noise_floor")
#: the golden tolerances of deterministic figures (tests/test_golden.py explains them)
REL, ABS = 1e-8, 1e-15
#: A trained network scored on data like its training data (the cycle split; the ramp-rate split
#: for networks without a dT/dt input): relative tolerance of its MSE. Round-off moved these by at
#: most 6.7e-5 (Model 1's cycle split under MKL's AVX path; 1.7e-5 between the two CPUs and on
#: one thread); another network seed moves them by 2.9e-4 (Model 1, ramp split) to 1.6e-3 (the
#: conventional model, cycle split), the extension by 9.5e-3. 2e-4: three times the round-off
#: measured, and under what re-seeding the networks changes, which it therefore still catches.
TRAINED_REL = 2e-4
#: The population searches' fitness history (table 2): float32 sums over 1024-sample chunks
#: (fitting.kernels) are off by at most 1024 · 2⁻²⁴ = 6.1e-5 relative in any summation order;
#: measured at most 1.9e-7 apart.
FITNESS_REL = 1024 * 2.0**-24
#: A trained network scored where it extrapolates (above its training temperatures; the extension's
#: dT/dt at twice the ramp rate of its training): round-off sends its weights elsewhere and the
#: extrapolation amplifies the difference (measured up to 64 % apart: GA-BPNN on one thread;
#: 31 %: the conventional model between the two CPUs), as another seed does. Relative tolerance:
#: 1 − smallest/largest MSE over the 10 network seeds (rounded up), so that any two results
#: within the seeds' range pass: a factor of 16 for the conventional model, 1.6 for the extension
#: at twice the ramp rate.
SEED_SPREAD = {
    "extrapolation_split": {"conventional": 0.94, "model1": 0.87, "model2_ga": 0.92, "model3_psoga": 0.96,
                            "extension_bpnn_dTdt": 0.71},
    "ramp_rate_split": {"extension_bpnn_dTdt": 0.39},
}


def _benchmark_tolerance(path: str) -> tuple[float, float, bool]:
    """(relative, absolute, to a printed digit) for the quick benchmark's value at ``path``."""
    parts = [p.split("[")[0] for p in path.split(".")]  # "table1.model1.mse[0]": no list indices
    section, model, field = (parts[1:] + ["", "", ""])[:3]
    trained_rel = lambda m: REL if m in UNTRAINED else TRAINED_REL  # noqa: E731
    if section == "table1" and field == "Q_percent":  # |MSE − conventional's| / conventional's, in %
        return 0.0, 100 * (trained_rel(model) + trained_rel("conventional")), False
    if section == "table1" and field.startswith(("mse", "ratio")):
        return trained_rel(model), ABS, False
    if section == "table2" and model and field == "mse_g2_at_iteration":
        return FITNESS_REL, ABS, False
    if section in SEED_SPREAD and model not in UNTRAINED:
        return SEED_SPREAD[section].get(model, TRAINED_REL), ABS, False
    if section == "verdicts":  # their numbers restate table 1's: its loosest tolerance, to a printed digit
        return 0.0, 100 * 2 * TRAINED_REL, True
    return REL, ABS, False


#: the two models each verdict compares, in the benchmark's order (its last verdict, the noise
#: floor's, compares none)
VERDICT_PAIRS = (("model3_psoga", "model2_ga"), ("model2_ga", "model1"), ("model1", "conventional"),
                 ("model3_psoga", "polynomial_T"), ("extension_bpnn_dTdt", "model3_psoga"))


def _undecided(doc: dict, recorded: dict) -> dict:
    """``doc`` with the conclusions the recording does not decide beyond the tolerances set to None:
    ``improves_on_conventional`` where the recorded Q_percent is within its tolerance of 0, a
    verdict where the recorded MSEs' relative difference is within its tolerance of the tie."""
    from twin.compensation.benchmark import TIE_PERCENT

    rel = lambda m: REL if m in UNTRAINED else TRAINED_REL  # noqa: E731
    mean = {r["model"]: r["mse_mean"] for r in recorded["table1"]}
    rows = []
    for row, rec in zip(doc["table1"], recorded["table1"]):
        row = dict(row)
        if "improves_on_conventional" in row and rec["model"] == row["model"]:
            tol = 100 * (rel(rec["model"]) + rel("conventional"))
            row["improves_on_conventional"] = [x if abs(q) > tol else None for x, q in
                                               zip(row["improves_on_conventional"], rec.get("Q_percent", []))]
        rows.append(row)
    verdicts = list(doc["verdicts"])
    for i, (a, b) in enumerate(VERDICT_PAIRS):
        if i < len(verdicts) and a in mean and b in mean:
            d = abs(mean[b] - mean[a]) / mean[b] * 100
            if abs(d - TIE_PERCENT) <= 100 * (rel(a) + rel(b)):
                verdicts[i] = None
    return {**doc, "table1": {r["model"]: r for r in rows}, "verdicts": verdicts}


def benchmark_differences(new: dict, old: dict) -> list[str]:
    """Where the quick benchmark ``new`` differs from the recording ``old`` beyond the tolerances
    above; the models, their order, the integers and the verdicts' words exactly.

    A conclusion the recording does not decide beyond the tolerances (a model level with the
    conventional one, a verdict at the tie) is not compared: round-off alone may turn it.
    """
    order = [[r["model"] for r in doc["table1"]] for doc in (new, old)]
    if order[0] != order[1]:
        return [f"benchmark_quick.table1: models {order[0]}, recorded {order[1]}"]
    return differences(_undecided(new, old), _undecided(old, old), REL, ABS, "benchmark_quick", _benchmark_tolerance)


if __name__ == "__main__":
    import tempfile

    with tempfile.TemporaryDirectory() as d:
        for name, data in make_run_outputs(Path(d), run_quick_benchmark(Path(d))).items():
            path = recorded_path(name)
            path.parent.mkdir(parents=True, exist_ok=True)
            path.write_text(json.dumps(data, indent=1, sort_keys=True) + "\n")
            print("wrote", path)
