"""Cost of the effect library on the paper scenario (583.5k samples): every drift effect on versus
the minimal drift law, in one run, and each effect alone (hysteresis included). Writes JSON.

Target (issue 4): every effect on adds under 1 s to the minimal law's simulation time.
Side by side: the play operator by parallel prefix scan versus the plain Python recursion a user
would write (timed on a slice and scaled).

Usage: python benchmarks/bench_effects.py [--json out/bench_effects.json] [--repeat 3]
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np
import yaml

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(Path(__file__).resolve().parent))

from _common import write_json  # noqa: E402

from sim.play import play_operator  # noqa: E402
from twin.effects import REGISTRY, EffectInputs  # noqa: E402
from twin.model.scenario import parse_scenario  # noqa: E402
from twin.model.simulate import simulate, simulate_thermal, time_base  # noqa: E402

PAPER = ROOT / "scenarios" / "paper_iis328dq.yaml"


def best(fn, repeat):
    out = float("inf")
    for _ in range(repeat):
        t0 = time.perf_counter()
        fn()
        out = min(out, time.perf_counter() - t0)
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--json", default="out/bench_effects.json")
    ap.add_argument("--repeat", type=int, default=3)
    args = ap.parse_args()
    data = yaml.safe_load(PAPER.read_text())
    minimal = parse_scenario(PAPER.read_text(), "paper")
    all_effects = sorted(n for n, c in REGISTRY.items() if c.slot == "drift" and n != "null")
    data["device"]["effects"] = {n: {} for n in all_effects}
    full = parse_scenario(yaml.safe_dump(data), "paper-all-effects")

    t_min = best(lambda: simulate(minimal), args.repeat)
    t_all = best(lambda: simulate(full), args.repeat)

    t = time_base(minimal)
    th = simulate_thermal(minimal, t)
    n = t.size
    inputs = EffectInputs(time_s=t, die_c=th.die_c, thermometer_c=th.probe_c, applied_g=np.ones(n),
                          run_index=np.zeros(n, np.int16), time_since_power_on_s=t)
    per_effect = {}
    for name in all_effects + ["thermal_lag"]:
        eff = REGISTRY[name]()
        fn = (lambda e=eff: e.die_temperature(inputs)) if eff.slot == "temperature" else (lambda e=eff: e.contribution(inputs))
        per_effect[name] = best(fn, args.repeat)

    x = th.die_c
    t_scan = best(lambda: play_operator(x, 2.0), args.repeat)
    m = 100_000

    def loop():
        p, out = x[0], np.empty(m)
        for k in range(m):
            p = min(max(p, x[k] - 2.0), x[k] + 2.0)
            out[k] = p
        return out

    t_loop = best(loop, 1) * n / m
    result = {
        "samples": int(n),
        "simulate_minimal_law_s": t_min,
        "simulate_every_effect_s": t_all,
        "added_by_every_effect_s": t_all - t_min,
        "effects_on": all_effects,
        "per_effect_s": per_effect,
        "play_operator_scan_s": t_scan,
        "play_operator_python_loop_s_extrapolated": t_loop,
        "play_speedup": t_loop / t_scan,
        "target_added_s": 1.0,
        "meets_target": (t_all - t_min) < 1.0,
    }
    write_json(args.json, result)


if __name__ == "__main__":
    main()
