"""The FE package model's prediction: warpage, TCOff and TCSo over the datasheet's range, split by
material (each material's thermal strain acting alone: the terms add up to the total to first order).

``twin package`` prints it (:mod:`twin.reporting.package_report`), ``twin render --fem`` draws the
solved package, and the DOE's package responses read it.
"""

from __future__ import annotations

import numpy as np

from twin.errors import ModelError
from twin.model.results import PackagePrediction

SWEEP_C = np.arange(-40.0, 85.0 + 1e-9, 5.0)  # the datasheet's TCOff range, −40…85 °C (excursion from 25 °C)
WARPAGE_AT_C = (-40.0, 25.0, 85.0)


def package_effect(loaded):
    """The scenario's ``package_fem`` effect (device first, then the twin), else one at its defaults.

    Parameters
    ----------
    loaded : LoadedScenario

    Returns
    -------
    effect : Effect
        The ``package_fem`` effect.
    source : str
        ``device``, ``twin`` or ``defaults``.
    """
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
    stack), so ``twin render --fem`` never draws a design ``twin package`` refuses.

    Parameters
    ----------
    effect : Effect
        A ``package_fem`` effect (its design and anchor layout).

    Returns
    -------
    StackSolution
        The finite-element solution of the package stack (``sim.fem.package_stack``).
    """
    from sim.fem.comb_on_substrate import anchor_motion
    from sim.fem.package_stack import solve_stack

    try:
        sol = solve_stack(effect.design())
        anchor_motion(sol, effect.layout())
    except ValueError as exc:
        raise ModelError(f"package_fem: {exc}") from None
    return sol


def package_prediction(effect, part=None) -> PackagePrediction:
    """Warpage, curvature, TCOff [mg/°C], TCSo [ppm/°C] (least-squares slope over −40…85 °C and the
    largest excursion from the reference), the TCOff split by material, and the datasheet figures.

    Parameters
    ----------
    effect : Effect
        A ``package_fem`` effect.
    part : Part, optional
        The sensor part whose datasheet TCOff [mg/°C] and TCSo [%/°C] are quoted beside the model
        (default: the IIS328DQ datasheet's typical figures).

    Returns
    -------
    PackagePrediction
        ``twin package --json``: design, mesh, warpage [µm] and curvature [1/m] at −40, 25 and 85 °C,
        TCOff [mg/°C], TCSo [ppm/°C], their split by material, and the sweep.
    """
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
    from twin.model.results import DatasheetDrift, PackageMesh, PackageSweep, Warpage

    tcoff_ds, tcso_ds = 0.8, 100.0
    if part is not None:
        tcoff_ds = float(part.value("tcoff_mg_per_c"))
        tcso_ds = float(part.value("tcso_pct_per_c")) * 1e4
    datasheet = DatasheetDrift(tcoff_ds, tcso_ds, "IIS328DQ DS10757 Rev 4 Table 2 (typ ±, no min/max)")
    tcoff = slope_per_c(SWEEP_C, offset)
    return PackagePrediction(
        design={k: v for k, v in effect.values.items()},
        mesh=PackageMesh(elements=sol.n_elements, dofs=sol.n_dofs, element="Q2 (9-node quadrilateral)",
                         kinematics=sol.design.kinematics),
        warpage=[Warpage(temperature_c=float(t), die_bow_um=float(w), curvature_per_m=float(c))
                 for t, c, w in zip(surf.temperature_c, surf.curvature_per_m, surf.warpage_um)],
        curvature_per_m_per_k=slope_per_c(surf.temperature_c, surf.curvature_per_m),
        tcoff_mg_per_c=tcoff,
        tcoff_excursion_mg_per_c=_excursion_per_c(SWEEP_C, offset, ref),
        tcso_ppm_per_c=slope_per_c(SWEEP_C, sf),
        tcso_excursion_ppm_per_c=_excursion_per_c(SWEEP_C, sf, ref),
        tcoff_by_material_mg_per_c={m: slope_per_c(SWEEP_C, v * k_off) for m, v in drift.offset_by_material_mg.items()},
        delta_pm_per_k=slope_per_c(SWEEP_C, drift.delta_pm * k_off),
        anchor_motion_pm_per_k={k: slope_per_c(SWEEP_C, v) for k, v in drift.motion_pm.items()},
        gap_change_pm_per_k={k: slope_per_c(SWEEP_C, v) for k, v in drift.gap_change_pm.items()},
        anchors_um=effect.layout().positions_um(),
        datasheet=datasheet,
        sweep=PackageSweep(temperature_c=SWEEP_C.tolist(), offset_mg=offset.tolist(), scale_factor_ppm=sf.tolist()),
    )
