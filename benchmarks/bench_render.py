"""Time the comb rendering and write JSON. Target (issue 3): one image under 5 s on this machine.

Side by side in one run: the whole ``twin render`` process (start-up included), one image in a
warm process, and the same boxes drawn with matplotlib's mplot3d (what one would otherwise pick
for a quick 3-D picture), as a ratio.

Usage: python benchmarks/bench_render.py [--json out/bench_render.json] [--repeat 3]
"""

from __future__ import annotations

import argparse
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(Path(__file__).resolve().parent))

from _common import write_json  # noqa: E402

from sim.comb_mesh import comb_parts, displacement_field_um  # noqa: E402
from sim.microstructure import CombGeometry  # noqa: E402
from twin.reporting.render import render_png  # noqa: E402


def matplotlib_png(geometry: CombGeometry, temperature_c: float, path: Path, exaggeration: float = 2000.0) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from mpl_toolkits.mplot3d.art3d import Poly3DCollection

    fig = plt.figure(figsize=(10, 7))
    ax = fig.add_subplot(projection="3d")
    faces = [(0, 1, 3, 2), (4, 5, 7, 6), (0, 1, 5, 4), (2, 3, 7, 6), (0, 2, 6, 4), (1, 3, 7, 5)]
    for part in comb_parts(geometry, 6):
        x0, x1, y0, y1, z0, z1 = part.bounds
        corners = np.array([[x, y, z] for z in (z0, z1) for y in (y0, y1) for x in (x0, x1)], float)
        d = displacement_field_um(corners, np.array(part.origin), part.moving, geometry, temperature_c,
                                  is_anchor=part.kind == "anchor")
        pts = corners + exaggeration * d
        mag = np.linalg.norm(d, axis=1).mean() * 1e3
        ax.add_collection3d(Poly3DCollection([pts[list(f)] for f in faces], facecolor=plt.cm.viridis(min(mag / 12, 1))))
    ax.set_xlim(-30, 110)
    ax.set_ylim(-20, 170)
    ax.set_zlim(0, 20)
    fig.savefig(path)
    plt.close(fig)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--json", default="out/bench_render.json")
    ap.add_argument("--repeat", type=int, default=3)
    args = ap.parse_args()
    g = CombGeometry()
    twin = str(Path(sys.executable).parent / "twin")
    with tempfile.TemporaryDirectory() as d:
        proc = []
        for _ in range(args.repeat):
            t0 = time.perf_counter()
            subprocess.run([twin, "render", str(ROOT / "scenarios/paper_iis328dq.yaml"), "--temperature", "50",
                            "-o", f"{d}/p.png"], check=True, capture_output=True)
            proc.append(time.perf_counter() - t0)
        render_png(g, 50.0, f"{d}/warmup.png")
        warm, mpl = [], []
        for _ in range(args.repeat):
            t0 = time.perf_counter()
            render_png(g, 50.0, f"{d}/w.png")
            warm.append(time.perf_counter() - t0)
            t0 = time.perf_counter()
            matplotlib_png(g, 50.0, Path(d) / "m.png")
            mpl.append(time.perf_counter() - t0)
    result = {
        "twin_render_process_s": min(proc),
        "render_png_warm_s": min(warm),
        "matplotlib_mplot3d_warm_s": min(mpl),
        "ratio_matplotlib_over_pyvista": min(mpl) / min(warm),
        "target_s": 5.0,
        "meets_target": min(proc) < 5.0,
    }
    write_json(args.json, result)


if __name__ == "__main__":
    main()
