"""``twin package``: the FE package model's warpage, TCOff and TCSo beside the datasheet, split by
material (each material's thermal strain acting alone: the terms add up to the total to first order)."""

from __future__ import annotations

import numpy as np

from twin.errors import ModelError

SWEEP_C = np.arange(-40.0, 85.0 + 1e-9, 5.0)  # the datasheet's TCOff range, −40…85 °C (excursion from 25 °C)
WARPAGE_AT_C = (-40.0, 25.0, 85.0)


def package_effect(loaded):
    """The scenario's ``package_fem`` effect (device first, then the twin), else one at its defaults."""
    from twin.effects import get_effect

    for source, comp in (("device", loaded.device_composition()), ("twin", loaded.twin_composition())):
        for e in comp.effects:
            if e.name == "package_fem":
                return e, source
    return get_effect("package_fem")({"geometry": loaded.geometry()}), "defaults"


def _excursion_per_c(t: np.ndarray, y: np.ndarray, reference_c: float) -> float:
    """Largest |y(T) − y(T_ref)| / |T − T_ref| over the sweep (the datasheet's 'excursion from 25 °C')."""
    away = np.abs(t - reference_c) > 1.0
    y_ref = np.interp(reference_c, t, y)
    ratio = (y[away] - y_ref) / (t[away] - reference_c)
    return float(ratio[np.argmax(np.abs(ratio))])


def solve_checked(effect):
    """The package solved, with every check ``twin package`` applies (anchors on the die, a valid
    stack), so ``twin render --fem`` never draws a design ``twin package`` refuses."""
    from sim.fem.comb_on_substrate import anchor_motion
    from sim.fem.package_stack import solve_stack

    try:
        sol = solve_stack(effect.design())
        anchor_motion(sol, effect.layout())
    except ValueError as exc:
        raise ModelError(f"package_fem: {exc}") from None
    return sol


def package_prediction(effect, part=None) -> dict:
    """Warpage, curvature, TCOff [mg/°C], TCSo [ppm/°C] (least-squares slope over −40…85 °C and the
    largest excursion from the reference), the TCOff split by material, and the datasheet figures."""
    from sim.fem.comb_on_substrate import package_drift, slope_per_c
    from sim.fem.package_stack import die_surface

    ref = effect.values["reference_c"]
    sol = solve_checked(effect)
    try:
        drift = package_drift(sol, effect.layout(), effect.geometry(), SWEEP_C, "H", ref)
        surf = die_surface(sol, np.array(WARPAGE_AT_C))
    except ValueError as exc:
        raise ModelError(f"package_fem: {exc}") from None
    k_off, k_sf = effect.values["bias_scale"], effect.values["scale_factor_scale"]
    offset, sf = drift.offset_mg * k_off, drift.scale_factor_ppm * k_sf
    datasheet = {"tcoff_mg_per_c": 0.8, "tcso_ppm_per_c": 100.0,
                 "source": "IIS328DQ DS10757 Rev 4 Table 2 (typ ±, no min/max)"}
    if part is not None:
        datasheet["tcoff_mg_per_c"] = float(part.value("tcoff_mg_per_c"))
        datasheet["tcso_ppm_per_c"] = float(part.value("tcso_pct_per_c")) * 1e4
    tcoff = slope_per_c(SWEEP_C, offset)
    return {
        "design": {k: v for k, v in effect.values.items()},
        "mesh": {"elements": sol.n_elements, "dofs": sol.n_dofs, "element": "Q2 (9-node quadrilateral)",
                 "kinematics": sol.design.kinematics},
        "warpage": [{"temperature_c": float(t), "die_bow_um": float(w), "curvature_per_m": float(c)}
                    for t, c, w in zip(surf.temperature_c, surf.curvature_per_m, surf.warpage_um)],
        "curvature_per_m_per_k": slope_per_c(surf.temperature_c, surf.curvature_per_m),
        "tcoff_mg_per_c": tcoff,
        "tcoff_excursion_mg_per_c": _excursion_per_c(SWEEP_C, offset, ref),
        "tcso_ppm_per_c": slope_per_c(SWEEP_C, sf),
        "tcso_excursion_ppm_per_c": _excursion_per_c(SWEEP_C, sf, ref),
        "tcoff_by_material_mg_per_c": {m: slope_per_c(SWEEP_C, v * k_off) for m, v in drift.offset_by_material_mg.items()},
        "delta_pm_per_k": slope_per_c(SWEEP_C, drift.delta_pm * k_off),
        "anchor_motion_pm_per_k": {k: slope_per_c(SWEEP_C, v) for k, v in drift.motion_pm.items()},
        "gap_change_pm_per_k": {k: slope_per_c(SWEEP_C, v) for k, v in drift.gap_change_pm.items()},
        "anchors_um": effect.layout().positions_um(),
        "datasheet": datasheet,
        "sweep": {"temperature_c": SWEEP_C.tolist(), "offset_mg": offset.tolist(), "scale_factor_ppm": sf.tolist()},
    }


def text_lines(result: dict, source: str = "") -> list[str]:
    """The prediction as a few lines of text."""
    d, ds = result["design"], result["datasheet"]
    head = (f"package_fem ({source}): mould α1 {d['mould_cte_ppm_per_k']:g} ppm/K, attach {d['attach_modulus_gpa']:g} "
            f"GPa × {d['attach_thickness_um']:g} µm, die {d['die_thickness_um']:g} µm (offset {d['die_offset_um']:g} µm), "
            f"cell at {d['cell_offset_um']:g} µm")
    mesh = (f"mesh: {result['mesh']['elements']} {result['mesh']['element']} elements, {result['mesh']['dofs']} dofs "
            f"({result['mesh']['kinematics']})")
    lines = [head, mesh]
    lines += [f"  die bow at {w['temperature_c']:5.1f} °C: {w['die_bow_um']:.3f} µm (curvature {w['curvature_per_m']:+.4f} 1/m)"
              for w in result["warpage"]]
    lines.append(f"TCOff {result['tcoff_mg_per_c']:+.3f} mg/°C (largest excursion from 25 °C "
                 f"{result['tcoff_excursion_mg_per_c']:+.3f}); datasheet ±{ds['tcoff_mg_per_c']:g} mg/°C typ")
    lines.append(f"TCSo  {result['tcso_ppm_per_c']:+.1f} ppm/°C from the package (excursion "
                 f"{result['tcso_excursion_ppm_per_c']:+.1f}); datasheet ±{ds['tcso_ppm_per_c']:g} ppm/°C typ")
    gaps = result["gap_change_pm_per_k"]
    lines.append(f"gap change beyond dilation: right {gaps['right']:+.2f}, left {gaps['left']:+.2f} pm/K; "
                 f"input-equivalent δ {result['delta_pm_per_k']:+.2f} pm/K")
    lines.append("TCOff by material [mg/°C]: " + ", ".join(f"{m} {v:+.3f}" for m, v in
                                                         result["tcoff_by_material_mg_per_c"].items()))
    return lines


def tcoff_map_png(table_csv, path, x="device.effects.package_fem.mould_cte_ppm_per_k",
                  y="device.effects.package_fem.attach_modulus_gpa", response="package_tcoff_mg_per_c",
                  datasheet_mg_per_c: float = 0.8):
    """A full-factorial DOE table (``twin doe`` table.csv) as an annotated map of TCOff, with the
    datasheet's ±typ named in the title; written atomically."""
    import csv
    import os
    from pathlib import Path

    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    with open(table_csv, newline="") as f:
        rows = [r for r in csv.DictReader(f) if r.get("status", "ok").strip('"') == "ok"]
    if not rows or any(k not in rows[0] for k in (x, y, response)):
        raise ModelError(f"{table_csv}: expected columns {x}, {y} and {response}")
    xs, ys = sorted({float(r[x]) for r in rows}), sorted({float(r[y]) for r in rows})
    grid = np.full((len(ys), len(xs)), np.nan)
    for r in rows:
        grid[ys.index(float(r[y])), xs.index(float(r[x]))] = float(r[response])
    fig, ax = plt.subplots(figsize=(5.2, 3.6), dpi=90)
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
        plt.close(fig)
        tmp.unlink(missing_ok=True)
    return path
