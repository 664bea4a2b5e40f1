"""The comb cell carried by the solved substrate: anchor motion → gaps → offset [mg] and scale factor.

Anchors sit on the die's top surface (x relative to the die centre): the proof mass hangs on two
spring anchors at ``cell_x ± spring_half_span``, the right and left fixed electrodes on anchors at
``cell_x ± electrode_half_span`` (``electrode_shift`` moves the right one). The comb layer is
silicon and dilates freely with ε_Si(T) about its anchors, so what changes the gaps is each
anchor's displacement beyond the free-silicon dilation, ũ_A = u_A − ε_Si·x_A (docs/fem.md,
design notes §D1). The unstressed mass moves rigidly with the mean of its (equal-stiffness)
spring anchors, x̃_m; the gaps become g_R = u(1+ε) + ũ_R − x̃_m and g_L = u(1+ε) + x̃_m − ũ_L, and the
differential capacitance of :mod:`sim.microstructure` (eqs. 16–19, reading H or HE) gives
offset = ΔC(T, 0 g)/ΔC(T0, 1 g) and scale factor = [ΔC(T, +1 g) − ΔC(T, −1 g)]/[2 ΔC(T0, 1 g)] − 1.
Not modelled: the springs' axial stress (folded springs carry almost none, docs/fem.md §D1), anchor
tilt (−h ∂u_y/∂x, negligible for a few-µm anchor), rotation of the mass.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from sim.fem.package_stack import UM, StackSolution
from sim.microstructure import EPSILON_0_F_PER_M, CombGeometry, deformed, displacement_m


@dataclass(frozen=True)
class AnchorLayout:
    """Anchor positions on the die [µm]; the default is centred and symmetric (docs/fem.md §D1).

    Attributes
    ----------
    cell_x_um : float
        Cell centre relative to the die centre [µm].
    spring_half_span_um, electrode_half_span_um : float
        Half distance between the two spring anchors and between the two electrode anchors [µm].
    electrode_shift_um : float
        Extra shift of the right electrode anchor [µm].
    """

    cell_x_um: float = 0.0
    spring_half_span_um: float = 400.0
    electrode_half_span_um: float = 100.0
    electrode_shift_um: float = 0.0

    def positions_um(self) -> dict[str, float]:
        """Anchor positions relative to the die centre.

        Returns
        -------
        dict of str to float
            ``spring_left``, ``spring_right``, ``electrode_left``, ``electrode_right`` [µm].
        """
        c = self.cell_x_um
        return {"spring_left": c - self.spring_half_span_um, "spring_right": c + self.spring_half_span_um,
                "electrode_left": c - self.electrode_half_span_um,
                "electrode_right": c + self.electrode_half_span_um + self.electrode_shift_um}


@dataclass(frozen=True)
class AnchorMotion:
    """Per unit thermal strain of each material: ũ of the mass (spring mean) and of each electrode [m].

    Attributes
    ----------
    mass_m, right_m, left_m : ndarray
        ũ of the mass and of the right and left electrodes per unit θ, (n_materials,) [m].
    x_um : dict of str to float
        Anchor positions relative to the die centre [µm].
    """

    mass_m: np.ndarray
    right_m: np.ndarray
    left_m: np.ndarray
    x_um: dict


def anchor_motion(sol: StackSolution, layout: AnchorLayout) -> AnchorMotion:
    """Unit-load anchor displacements minus silicon's free dilation, ũ_A = u_A − ε_Si·x_A.

    x_A is taken in the die frame: a uniform shift of every ũ cancels in the gaps (docs/fem.md §D1).

    Parameters
    ----------
    sol : StackSolution
        Solved package.
    layout : AnchorLayout
        Anchor positions [µm]; all must lie on the die.

    Returns
    -------
    AnchorMotion
        ũ per unit thermal strain of each material [m].
    """
    pos = layout.positions_um()
    centre = 0.5 * (sol.die_x_m[0] + sol.die_x_m[1])
    x_m = np.array([centre + pos[k] * UM for k in pos])
    if np.any(x_m <= sol.die_x_m[0]) or np.any(x_m >= sol.die_x_m[1]):
        raise ValueError(f"anchors {sorted(pos.values())} µm must lie on the die (half width "
                         f"{(sol.die_x_m[1] - sol.die_x_m[0]) / 2 / UM:g} µm)")
    ux, _ = sol.surface_unit_displacements(x_m)  # (nmat, 4)
    free = np.zeros((len(sol.materials), 1))
    free[[m.name for m in sol.materials].index("silicon")] = 1.0
    rel = ux - free * (x_m - centre)[None, :]
    return AnchorMotion(0.5 * (rel[:, 0] + rel[:, 1]), rel[:, 3], rel[:, 2], pos)


@dataclass(frozen=True)
class CombDrift:
    """Offset [g] and relative scale-factor change [1] at each temperature.

    Attributes
    ----------
    offset_g : ndarray
        Offset [g].
    scale_factor : ndarray
        Relative scale-factor change [1].
    """

    offset_g: np.ndarray
    scale_factor: np.ndarray


def _signal(geometry: CombGeometry, d, acceleration_g, mass_m, right_m, left_m) -> np.ndarray:
    du = displacement_m(acceleration_g, geometry.resonance_hz, d.stiffness_ratio)
    g_right = d.u + right_m - mass_m - du
    g_left = d.u + mass_m - left_m + du
    return EPSILON_0_F_PER_M * d.b * d.j * (1.0 / g_right - 1.0 / g_left)


def comb_drift(geometry: CombGeometry, temperature_c, mass_m=0.0, right_m=0.0, left_m=0.0, reading: str = "H",
               reference_c: float = 25.0) -> CombDrift:
    """Offset and scale factor of the comb with anchor motions ũ [m] (zero at ``reference_c``).

    With ũ = 0 this is :func:`sim.microstructure.drift_g` under reading H or HE.

    Parameters
    ----------
    geometry : CombGeometry
        Comb dimensions [µm] and resonance [Hz].
    temperature_c : float or ndarray
        Temperature [°C].
    mass_m, right_m, left_m : float or ndarray
        ũ of the mass and of the right and left electrodes [m].
    reading : {"H", "HE"}
        Thermal reading of the comb.
    reference_c : float
        Calibration temperature [°C].

    Returns
    -------
    CombDrift
        Offset [g] and scale-factor change [1].

    References
    ----------
    Gaps of docs/fem.md §D1; capacitances of Qi et al. (2022), Micromachines 13, 2156, eqs. (16)–(19)
    via :mod:`sim.microstructure`.
    """
    if reading not in ("H", "HE"):
        raise ValueError(f"a comb on a substrate dilates with it: reading must be H or HE, got {reading!r}")
    t = np.asarray(temperature_c, float)
    d, d0 = deformed(geometry, t, reading, reference_c), deformed(geometry, reference_c, reading, reference_c)
    per_g0 = _signal(geometry, d0, 1.0, 0.0, 0.0, 0.0)
    offset = _signal(geometry, d, 0.0, mass_m, right_m, left_m) / per_g0
    span = _signal(geometry, d, 1.0, mass_m, right_m, left_m) - _signal(geometry, d, -1.0, mass_m, right_m, left_m)
    return CombDrift(offset * np.ones_like(t), span / (2 * per_g0) - 1.0)


@dataclass(frozen=True)
class PackageDrift:
    """Drift of the comb on the packaged die versus temperature, and its split by material.

    Attributes
    ----------
    temperature_c : ndarray
        Temperature [°C].
    offset_mg : ndarray
        Offset [mg].
    scale_factor_ppm : ndarray
        Package-induced scale-factor change [ppm] (total minus the free comb's).
    offset_by_material_mg : dict of str to ndarray
        Offset from each material's thermal strain alone [mg].
    delta_pm : ndarray
        Input-equivalent displacement x̃_m − ½(ũ_R + ũ_L) [pm].
    motion_pm : dict of str to ndarray
        ũ of the mass and of each electrode [pm].
    gap_change_pm : dict of str to ndarray
        Right and left sensing-gap change beyond the comb's own dilation [pm].
    """

    temperature_c: np.ndarray
    offset_mg: np.ndarray
    scale_factor_ppm: np.ndarray  # package-induced part only (total minus the free comb's)
    offset_by_material_mg: dict
    delta_pm: np.ndarray  # input-equivalent displacement x̃_m − ½(ũ_R + ũ_L) [pm]
    motion_pm: dict  # ũ of the mass and of each electrode [pm]
    gap_change_pm: dict  # right and left sensing-gap change beyond the comb's own dilation [pm]


def package_drift(sol: StackSolution, layout: AnchorLayout, geometry: CombGeometry, temperature_c,
                  reading: str = "H", reference_c: float = 25.0) -> PackageDrift:
    """Offset [mg] and package-induced scale-factor change [ppm] (both zero at ``reference_c``).

    Parameters
    ----------
    sol : StackSolution
        Solved package.
    layout : AnchorLayout
        Anchor positions [µm].
    geometry : CombGeometry
        Comb dimensions [µm] and resonance [Hz].
    temperature_c : float or ndarray
        Temperature [°C].
    reading : {"H", "HE"}
        Thermal reading of the comb.
    reference_c : float
        Trim temperature, where the anchors are placed [°C].

    Returns
    -------
    PackageDrift
        Offset [mg], scale factor [ppm] and their breakdown.
    """
    t = np.atleast_1d(np.asarray(temperature_c, float))
    am = anchor_motion(sol, layout)
    theta = sol.thermal_strains(t, reference_c)  # from the trim temperature: anchors placed there
    mass, right, left = theta @ am.mass_m, theta @ am.right_m, theta @ am.left_m
    full = comb_drift(geometry, t, mass, right, left, reading, reference_c)
    free = comb_drift(geometry, t, reading=reading, reference_c=reference_c)
    by_material = {}
    for k, m in enumerate(sol.materials):
        part = comb_drift(geometry, t, theta[:, k] * am.mass_m[k], theta[:, k] * am.right_m[k],
                          theta[:, k] * am.left_m[k], reading, reference_c)
        by_material[m.name] = part.offset_g * 1e3
    return PackageDrift(t, full.offset_g * 1e3, (full.scale_factor - free.scale_factor) * 1e6, by_material,
                        (mass - 0.5 * (right + left)) * 1e12,
                        {"mass": mass * 1e12, "electrode_right": right * 1e12, "electrode_left": left * 1e12},
                        {"right": (right - mass) * 1e12, "left": (mass - left) * 1e12})


def slope_per_c(temperature_c: np.ndarray, values: np.ndarray, low_c: float = -40.0, high_c: float = 85.0) -> float:
    """Least-squares slope of ``values`` over [low_c, high_c] (the datasheet's TCOff/TCSo range).

    Parameters
    ----------
    temperature_c : ndarray
        Temperature [°C].
    values : ndarray
        Drift [any unit, e.g. mg or ppm].
    low_c, high_c : float
        Fitted range [°C].

    Returns
    -------
    float
        Slope [unit of ``values`` per °C].
    """
    t = np.asarray(temperature_c, float)
    keep = (t >= low_c) & (t <= high_c)
    return float(np.polyfit(t[keep], np.asarray(values)[keep], 1)[0])
