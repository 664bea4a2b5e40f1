"""Time the FE package model and check its mesh convergence; write JSON.

Target (issue 17): a 15-temperature sweep of the default stack + comb in < 2 s on this machine with
one factorisation and load scaling (u(T) = Σ_k θ_k(T) U_k), side by side in one run with what one
would otherwise write: assemble, factorise and solve every temperature from scratch. Both give the
same offsets (checked). Also: the package_fem effect on 500k samples (interpolation, no solve), and
TCOff at three mesh sizes with Richardson extrapolation (docs/fem.md §D3 T8: < 1 % change required).

Usage: python benchmarks/bench_fem.py [--json out/bench_fem.json]
"""

from __future__ import annotations

import argparse
import sys
import time
from dataclasses import replace
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(Path(__file__).resolve().parent))

from _common import write_json

from sim.fem.comb_on_substrate import (
    AnchorLayout,
    comb_drift,
    package_drift,
    slope_per_c,
)
from sim.fem.elasticity import Factorized
from sim.fem.package_stack import (
    UM,
    PackageDesign,
    StackSolution,
    build_system,
    solve_stack,
)
from sim.microstructure import CombGeometry

TEMPS_C = np.linspace(-40.0, 85.0, 15)
LAYOUT = AnchorLayout(cell_x_um=300.0)


def one_factorisation(design: PackageDesign, geometry: CombGeometry) -> tuple[np.ndarray, dict]:
    t0 = time.perf_counter()
    system, material, die_top, fixed = build_system(design)
    t1 = time.perf_counter()
    fac = Factorized(system.K, fixed)
    t2 = time.perf_counter()
    U = fac.solve(system.F)
    t3 = time.perf_counter()
    c, h = design.die_offset_um * UM, design.die_width_um / 2 * UM
    sol = StackSolution(design, system, U, design.materials(), material, die_top, (c - h, c + h))
    offset = package_drift(sol, LAYOUT, geometry, TEMPS_C).offset_mg
    t4 = time.perf_counter()
    return offset, {"assemble_s": t1 - t0, "factorise_s": t2 - t1, "unit_solves_s": t3 - t2,
                    "sweep_and_comb_s": t4 - t3, "total_s": t4 - t0, "n_dofs": system.n_dofs,
                    "n_elements": int(material.size), "unit_loads": int(system.F.shape[1])}


def from_scratch(design: PackageDesign, geometry: CombGeometry) -> tuple[np.ndarray, float]:
    """Every temperature assembled, factorised and solved anew (the anchor field at T minus 25 °C)."""
    t0 = time.perf_counter()
    offsets = []
    for t in TEMPS_C:
        system, material, die_top, fixed = build_system(design)
        c, h = design.die_offset_um * UM, design.die_width_um / 2 * UM
        mats = design.materials()
        probe = StackSolution(design, system, np.zeros((system.n_dofs, 1)), mats, material, die_top, (c - h, c + h))
        theta = probe.thermal_strains([t], 25.0)[0]
        u = Factorized(system.K, fixed).solve(system.F @ theta)
        pos = LAYOUT.positions_um()
        x = np.array([c + pos[k] * UM for k in pos])
        P = system.basis.probes(np.vstack([x, np.full_like(x, die_top)]))
        ux = (P @ u[: system.n_field])[: x.size] - theta[0] * (x - c)  # minus free silicon dilation
        mass = 0.5 * (ux[0] + ux[1])
        offsets.append(comb_drift(geometry, np.array([t]), mass, ux[3], ux[2]).offset_g[0] * 1e3)
    return np.array(offsets), time.perf_counter() - t0


def convergence(geometry: CombGeometry) -> dict:
    rows = []
    for h in (100.0, 50.0, 25.0):  # the default mesh and two halvings (25 µm: ~130k dofs, ~30 s)
        sol = solve_stack(replace(PackageDesign(), element_um=h))
        d = package_drift(sol, LAYOUT, geometry, TEMPS_C)
        rows.append({"element_um": h, "n_dofs": sol.n_dofs, "tcoff_mg_per_c": slope_per_c(TEMPS_C, d.offset_mg),
                     "tcso_ppm_per_c": slope_per_c(TEMPS_C, d.scale_factor_ppm)})
    f = [r["tcoff_mg_per_c"] for r in rows]
    order = float(np.log(abs((f[0] - f[1]) / (f[1] - f[2]))) / np.log(2.0)) if f[1] != f[2] else float("nan")
    extrapolated = f[2] + (f[2] - f[1]) / (2.0 ** order - 1.0) if np.isfinite(order) and order > 0 else f[2]
    return {"meshes": rows, "observed_order": order, "richardson_tcoff_mg_per_c": float(extrapolated),
            "finest_vs_extrapolated_pct": float(100 * (f[2] / extrapolated - 1)),
            "default_vs_extrapolated_pct": float(100 * (f[0] / extrapolated - 1))}


def effect_on_samples(n: int = 500_000) -> dict:
    from twin.effects import EffectInputs
    from twin.effects.package_fem import PackageFem

    e = PackageFem()
    e.tables()  # the solve, cached
    t = np.linspace(-40, 85, n)
    inputs = EffectInputs(time_s=np.arange(n, dtype=float), die_c=t, applied_g=np.ones(n))
    t0 = time.perf_counter()
    e.contribution(inputs)
    return {"samples": n, "seconds": time.perf_counter() - t0}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--json", default="out/bench_fem.json")
    args = ap.parse_args()
    geometry, design = CombGeometry(), PackageDesign()
    solve_stack(PackageDesign(layout="bare_die"))  # warm the imports (scikit-fem, scipy) outside the timings
    ours, timing = one_factorisation(design, geometry)
    scratch, scratch_s = from_scratch(design, geometry)
    result = {
        "temperatures": int(TEMPS_C.size), "mesh": {"element": "Q2 9-node quadrilateral, generalised plane strain",
                                                     "n_dofs": timing["n_dofs"], "n_elements": timing["n_elements"]},
        "one_factorisation": timing, "from_scratch_s": scratch_s, "speed_up": scratch_s / timing["total_s"],
        "target_s": 2.0, "target_met": timing["total_s"] < 2.0,
        "max_offset_difference_mg": float(np.max(np.abs(ours - scratch))),
        "tcoff_mg_per_c": slope_per_c(TEMPS_C, ours),
        "effect_500k_samples": effect_on_samples(),
        "mesh_convergence": convergence(geometry),
        "note": "measured under load (shared machine)",
    }
    write_json(args.json, result)


if __name__ == "__main__":
    main()
