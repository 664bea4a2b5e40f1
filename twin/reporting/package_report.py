"""``twin package`` as text and the TCOff map: the prediction of :mod:`twin.model.package`, rendered."""

from __future__ import annotations

import numpy as np

from twin.errors import ModelError


def text_lines(result, source: str = "") -> list[str]:
    """The prediction as a few lines of text.

    Parameters
    ----------
    result : PackagePrediction
        The prediction of :mod:`twin.model.package` (design, mesh, warpage [µm], TCOff [mg/°C],
        TCSo [ppm/°C], gap change [pm/K], datasheet values).
    source : str
        Where the design came from, quoted in the first line.

    Returns
    -------
    list of str
    """
    d, ds = result.design, result.datasheet
    head = (f"package_fem ({source}): mould α1 {d['mould_cte_ppm_per_k']:g} ppm/K, attach {d['attach_modulus_gpa']:g} "
            f"GPa × {d['attach_thickness_um']:g} µm, die {d['die_thickness_um']:g} µm (offset {d['die_offset_um']:g} µm), "
            f"cell at {d['cell_offset_um']:g} µm")
    mesh = (f"mesh: {result.mesh.elements} {result.mesh.element} elements, {result.mesh.dofs} dofs "
            f"({result.mesh.kinematics})")
    lines = [head, mesh]
    lines += [f"  die bow at {w.temperature_c:5.1f} °C: {w.die_bow_um:.3f} µm (curvature {w.curvature_per_m:+.4f} 1/m)"
              for w in result.warpage]
    lines.append(f"TCOff {result.tcoff_mg_per_c:+.3f} mg/°C (largest excursion from 25 °C "
                 f"{result.tcoff_excursion_mg_per_c:+.3f}); datasheet ±{ds.tcoff_mg_per_c:g} mg/°C typ")
    lines.append(f"TCSo  {result.tcso_ppm_per_c:+.1f} ppm/°C from the package (excursion "
                 f"{result.tcso_excursion_ppm_per_c:+.1f}); datasheet ±{ds.tcso_ppm_per_c:g} ppm/°C typ")
    gaps = result.gap_change_pm_per_k
    lines.append(f"gap change beyond dilation: right {gaps['right']:+.2f}, left {gaps['left']:+.2f} pm/K; "
                 f"input-equivalent δ {result.delta_pm_per_k:+.2f} pm/K")
    lines.append("TCOff by material [mg/°C]: " + ", ".join(f"{m} {v:+.3f}" for m, v in
                                                         result.tcoff_by_material_mg_per_c.items()))
    return lines


def tcoff_map_png(table_csv, path, x="device.effects.package_fem.mould_cte_ppm_per_k",
                  y="device.effects.package_fem.attach_modulus_gpa", response="package_tcoff_mg_per_c",
                  datasheet_mg_per_c: float = 0.8):
    """A full-factorial DOE table (``twin doe`` table.csv) as an annotated map of TCOff, with the
    datasheet's ±typ named in the title; written atomically.

    Parameters
    ----------
    table_csv : str or Path
        The DOE table.
    path : str or Path
        The PNG to write.
    x, y, response : str
        Columns of the two factors (mould CTE [ppm/K], die-attach modulus [GPa]) and of TCOff [mg/°C].
    datasheet_mg_per_c : float
        The datasheet's typical TCOff [mg/°C].

    Returns
    -------
    Path
        The file written.

    Raises
    ------
    ModelError
        No ``ok`` rows, or a column missing.
    """
    import csv
    import os
    from pathlib import Path

    from twin.reporting.plots import figure_grid

    with open(table_csv, newline="") as f:
        rows = [r for r in csv.DictReader(f) if r.get("status", "ok").strip('"') == "ok"]
    if not rows or any(k not in rows[0] for k in (x, y, response)):
        raise ModelError(f"{table_csv}: expected columns {x}, {y} and {response}")
    xs, ys = sorted({float(r[x]) for r in rows}), sorted({float(r[y]) for r in rows})
    grid = np.full((len(ys), len(xs)), np.nan)
    for r in rows:
        grid[ys.index(float(r[y])), xs.index(float(r[x]))] = float(r[response])
    fig, ax = figure_grid((5.2, 3.6))
    fig.set_dpi(90)
    im = ax.imshow(grid, origin="lower", cmap="viridis", aspect="auto")
    for (i, j), v in np.ndenumerate(grid):
        ax.text(j, i, f"{v:+.2f}", ha="center", va="center", fontsize=8, color="white" if v < np.nanmean(grid) else "black")
    ax.set_xticks(range(len(xs)), [f"{v:g}" for v in xs])
    ax.set_yticks(range(len(ys)), [f"{v:g}" for v in ys])
    ax.set_xlabel("mould CTE α1 [ppm/K]")
    ax.set_ylabel("die-attach modulus [GPa]")
    ax.set_title(f"TCOff [mg/°C], cell 300 µm off-centre (datasheet ±{datasheet_mg_per_c:g} typ)", fontsize=9)
    fig.colorbar(im, ax=ax, label="mg/°C")
    fig.tight_layout()
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(f".{path.name}.tmp.png")
    try:
        fig.savefig(tmp)
        os.replace(tmp, path)
    finally:
        tmp.unlink(missing_ok=True)
    return path
