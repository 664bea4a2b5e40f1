"""Time ``twin calibrate`` on the TofuPilot log (three axes, 8,400 rows): the whole process, and
each method's fit in one process beside it; JSON out.

Target (issue 13): the whole ``twin calibrate`` process under 10 s on this machine. Side by side:
the PX4 method alone (what PX4's own script does) and the ArduPilot method alone, so the cost of
the validation and of the lag-aware twin is visible as a ratio.

Usage: python benchmarks/bench_calibrate.py [--runs 3] [--json out/bench_calibrate.json]
"""

from __future__ import annotations

import argparse
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
from sklearn.base import clone

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(Path(__file__).resolve().parent))

from _common import write_json  # noqa: E402

TOFU = ROOT.parent / "shared" / "data" / "real" / "tofupilot_imu_thermal" / "imu_raw_data.tsv"
OPTS = ["--time-col", "timestamp", "--time-unit", "us", "--temperature-col", "imu.temperature", "--x-col",
        "imu.acc.x", "--y-col", "imu.acc.y", "--z-col", "imu.acc.z", "--output-unit", "m/s^2"]


def whole_process(runs: int) -> list[float]:
    out = []
    with tempfile.TemporaryDirectory() as d:
        for _ in range(runs):
            start = time.perf_counter()
            subprocess.run([sys.executable, "-m", "twin.cli", "calibrate", str(TOFU), *OPTS, "-o",
                            str(Path(d) / "cal.json")], check=True, capture_output=True)
            out.append(time.perf_counter() - start)
    return out


def per_method(runs: int) -> dict:
    from twin.calibration.lag import make_X
    from twin.calibration.workflow import methods_for
    from twin.measurement import ColumnMap, read_imu_logs

    cmap = ColumnMap(time="timestamp", time_unit="us", temperature="imu.temperature", x="imu.acc.x",
                     y="imu.acc.y", z="imu.acc.z", output_unit="m/s^2")
    log = read_imu_logs(TOFU, cmap)[0]
    X = make_X(log.time_s, log.temperature_c)
    times = {}
    for name, est in methods_for(0, 0).items():
        ts = []
        for _ in range(runs):
            start = time.perf_counter()
            clone(est).fit(X, log.accel_g)
            ts.append(time.perf_counter() - start)
        times[name] = float(np.median(ts))
    return times


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", type=int, default=3)
    ap.add_argument("--json", default="out/bench_calibrate.json")
    args = ap.parse_args()
    wall = whole_process(args.runs)
    fits = per_method(args.runs)
    write_json(args.json, {
        "log": str(TOFU.name), "rows": 8400, "axes": 3, "runs": args.runs,
        "twin_calibrate_process_s": {"median": float(np.median(wall)), "min": float(min(wall)), "max": float(max(wall))},
        "target_s": 10.0, "meets_target": bool(np.median(wall) < 10.0),
        "fit_on_all_rows_s": fits,
        "ratio_twin_to_px4_fit": fits["twin"] / fits["px4"],
    })


if __name__ == "__main__":
    main()
