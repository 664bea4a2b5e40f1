"""Time the paper scenario (three cycles, 583.5k samples at 10 Hz) and write JSON.

Side by side in one run, on the same input (ratios: the machine is shared and noisy):

* lumped chain: our modal IIR solve vs ``scipy.signal.lsim`` (what a user would pick for an LTI
  system) and ``scipy.integrate.solve_ivp`` (LSODA, dense output), with their max difference;
* 1-D stack: our modal θ-method vs the hand-written alternative, a ``scipy.linalg.solve_banded``
  backward-Euler step per sample (timed on a slice and scaled, it is too slow for the whole run);
* the whole ``twin run`` process (start-up and HDF5 write included), lumped and 1-D;
* ``import twin`` must not load torch, pyvista or matplotlib.

Targets (issue 2): lumped simulation < 0.5 s, ``twin run`` < 3 s, 1-D chain < 5 s.

Usage: python benchmarks/bench_simulate.py [--json out/bench_simulate.json] [--repeat 3]
"""

from __future__ import annotations

import argparse
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import yaml

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(Path(__file__).resolve().parent))

from _common import write_json  # noqa: E402

from twin.model.scenario import load_scenario, parse_scenario  # noqa: E402
from twin.model.simulate import simulate, simulate_thermal, time_base  # noqa: E402

PAPER = ROOT / "scenarios" / "paper_iis328dq.yaml"


def best_of(fn, repeat):
    times = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        result = fn()
        times.append(time.perf_counter() - t0)
    return min(times), result


def with_chamber(path: Path, **chamber) -> str:
    data = yaml.safe_load(path.read_text())
    data["chamber"].update(chamber)
    return yaml.safe_dump(data, sort_keys=False)


def bench_lumped_vs_scipy(loaded, repeat):
    from scipy.integrate import solve_ivp
    from scipy.signal import lsim

    t = time_base(loaded)
    ours_s, th = best_of(lambda: simulate_thermal(loaded, t), repeat)
    device, _, _ = loaded.thermal_device()
    C, G, g = device.matrices()
    tau_air = loaded.scenario.chamber.air_tau_s
    # State [air, board, die], input set-point.
    A = np.zeros((3, 3))
    A[0, 0] = -1 / tau_air
    A[1:, 1:] = -G / C[:, None]
    A[1:, 0] = g / C
    B = np.array([1 / tau_air, 0, 0])
    sp = th.setpoint_c
    x0 = np.full(3, sp[0])

    def run_lsim():
        return lsim((A, B[:, None], np.eye(3), np.zeros((3, 1))), sp, t, X0=x0)[1]

    lsim_s, y_lsim = best_of(run_lsim, 1)
    prog = loaded.program

    def run_ivp():
        sol = solve_ivp(lambda tt, x: A @ x + B * prog.setpoint_c(np.array([tt]))[0], (t[0], t[-1]), x0,
                        method="LSODA", t_eval=t, max_step=17.5, rtol=1e-8, atol=1e-8)
        return sol.y.T

    ivp_s, y_ivp = best_of(run_ivp, 1)
    return {
        "ours_s": ours_s,
        "scipy_lsim_s": lsim_s,
        "scipy_solve_ivp_lsoda_s": ivp_s,
        "speedup_vs_lsim": lsim_s / ours_s,
        "speedup_vs_solve_ivp": ivp_s / ours_s,
        "max_abs_diff_die_vs_lsim_c": float(np.max(np.abs(y_lsim[:, 2] - th.die_c))),
        "max_abs_diff_die_vs_solve_ivp_c": float(np.max(np.abs(y_ivp[:, 2] - th.die_c))),
    }


def bench_1d_vs_banded(loaded_1d, repeat):
    from scipy.linalg import solve_banded

    from sim.thermal import first_order_lag

    t = time_base(loaded_1d)
    ours_s, th = best_of(lambda: simulate_thermal(loaded_1d, t), repeat)
    stack, _, die = loaded_1d.thermal_device()
    C, G, g = stack.matrices()
    dt = t[1] - t[0]
    n = C.size
    M = np.diag(C) + dt * G  # backward Euler: (C + dt G) T+ = C T + dt g u+
    ab = np.zeros((3, n))
    ab[0, 1:] = np.diag(M, 1)
    ab[1] = np.diag(M)
    ab[2, :-1] = np.diag(M, -1)
    air = first_order_lag(th.setpoint_c, dt, loaded_1d.scenario.chamber.air_tau_s)
    w = stack.layer_weights(die)
    n_slice = 20000

    def loop():
        T = np.full(n, air[0])
        out = np.empty(n_slice)
        for k in range(n_slice):
            T = solve_banded((1, 1), ab, C * T + dt * g * air[k])
            out[k] = w @ T
        return out

    loop_s, y = best_of(loop, 1)
    loop_full_s = loop_s * t.size / n_slice
    return {
        "ours_full_step_s": ours_s,
        "banded_loop_s_extrapolated": loop_full_s,
        "speedup_vs_banded_loop": loop_full_s / ours_s,
        "max_abs_diff_die_first_slice_c": float(np.max(np.abs(y - th.die_c[:n_slice]))),
        "cells": int(n),
    }


def run_process(scenario_text: str, repeat: int) -> float:
    with tempfile.TemporaryDirectory() as d:
        scn = Path(d) / "s.yaml"
        scn.write_text(scenario_text)
        out = Path(d) / "o.h5"
        cmd = [str(Path(sys.executable).parent / "twin"), "run", str(scn), "-o", str(out), "-q"]
        best = float("inf")
        for _ in range(repeat):
            t0 = time.perf_counter()
            subprocess.run(cmd, check=True)
            best = min(best, time.perf_counter() - t0)
        return best


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--json", default="out/bench_simulate.json")
    ap.add_argument("--repeat", type=int, default=3)
    args = ap.parse_args()

    loaded = load_scenario(PAPER)
    text_1d = with_chamber(PAPER, model="conduction_1d")
    text_1d_coarse = with_chamber(PAPER, model="conduction_1d", thermal_step_s=1.0)
    loaded_1d = parse_scenario(text_1d, "paper-1d")
    loaded_1d_coarse = parse_scenario(text_1d_coarse, "paper-1d-coarse")

    sim_lumped_s, ds = best_of(lambda: simulate(loaded), args.repeat)
    sim_1d_s, _ = best_of(lambda: simulate(loaded_1d), args.repeat)
    sim_1d_coarse_s, _ = best_of(lambda: simulate(loaded_1d_coarse), args.repeat)
    imports = subprocess.run(
        [sys.executable, "-c", "import sys, twin, twin.cli, twin.model.simulate; "
         "print(','.join(m for m in ('torch','pyvista','matplotlib') if m in sys.modules))"],
        capture_output=True, text=True, check=True).stdout.strip()
    result = {
        "samples": len(ds),
        "duration_h": float(ds["time_s"][-1] / 3600),
        "simulate_lumped_s": sim_lumped_s,
        "simulate_1d_full_step_s": sim_1d_s,
        "simulate_1d_thermal_step_1s_s": sim_1d_coarse_s,
        "twin_run_process_lumped_s": run_process(PAPER.read_text(), args.repeat),
        "twin_run_process_1d_s": run_process(text_1d, args.repeat),
        "import_twin_loads_heavy": imports or None,
        "lumped_vs_scipy": bench_lumped_vs_scipy(loaded, args.repeat),
        "conduction_1d_vs_banded_loop": bench_1d_vs_banded(loaded_1d, args.repeat),
        "targets": {"simulate_lumped_s": 0.5, "twin_run_process_lumped_s": 3.0, "simulate_1d_s": 5.0},
    }
    result["meets_targets"] = {
        "simulate_lumped": result["simulate_lumped_s"] < 0.5,
        "twin_run_process": result["twin_run_process_lumped_s"] < 3.0,
        "simulate_1d": result["simulate_1d_full_step_s"] < 5.0,
        "import_light": not imports,
    }
    write_json(args.json, result)


if __name__ == "__main__":
    main()
