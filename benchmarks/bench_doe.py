"""DOE throughput: runs per minute for paper-size scenarios (three cycles, 583.5k samples at
10 Hz; simulate + calibrate + diagnose blind), on 1 and 2 local workers, and on a dask
LocalCluster with 2 workers; the speed-up from 1 to 2. Writes JSON.

Usage: python benchmarks/bench_doe.py [--runs 6] [--json out/bench_doe.json]
"""

from __future__ import annotations

import argparse
import os
import sys
import tempfile
import time
from pathlib import Path

for _v in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_v, "1")  # one BLAS thread per worker process

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(Path(__file__).resolve().parent))

from _common import write_json  # noqa: E402

from twin.studies.doe import load_study, run_design_points  # noqa: E402

STUDY = """\
name: throughput
base: {base}
seed: 1
factors:
  device.effects.static_bias_tc.tc1_mg_per_c: {{range: [0.2, 1.0]}}
design: {{type: latin_hypercube, points: {n}}}
responses: [residual_rms_mg, hidden_detected, drift_pp_mg]
"""


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", type=int, default=6)
    ap.add_argument("--json", default="out/bench_doe.json")
    args = ap.parse_args()
    result = {"runs": args.runs, "samples_per_run": 583501}
    with tempfile.TemporaryDirectory() as d:
        f = Path(d) / "study.yaml"
        f.write_text(STUDY.format(base=ROOT / "scenarios/paper_iis328dq.yaml", n=args.runs))
        study, base, _ = load_study(f)
        for label, workers, executor in (("local_1_worker", 1, "local"), ("local_2_workers", 2, "local"),
                                         ("dask_2_workers", 2, "dask")):
            t0 = time.perf_counter()
            runs = run_design_points(study, base, Path(d) / label, workers, executor)
            dt = time.perf_counter() - t0
            result[label] = {"seconds": dt, "runs_per_minute": len(runs) * 60 / dt,
                             "failed": sum(r["status"] != "ok" for r in runs)}
    result["speedup_1_to_2_workers"] = result["local_1_worker"]["seconds"] / result["local_2_workers"]["seconds"]
    write_json(args.json, result)


if __name__ == "__main__":
    main()
