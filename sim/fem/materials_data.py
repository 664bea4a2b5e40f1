"""Package materials: elastic constants and free thermal strain ε_th = ∫α dT, with sources.

Sources are listed in ``docs/fem.md``, design notes §D4, and
``../shared/reference/physics_reference.json`` (``package_cte_ppm_per_K``). Silicon takes α(T) and
E(T) from :mod:`sim.materials`; E is held at the reference temperature in the elastic solve.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from sim.fem.elasticity import IsotropicMaterial
from sim.materials import KELVIN, silicon_thermal_strain, silicon_youngs_modulus_pa

SILICON_POISSON_110 = 0.064  # in-plane ν along ⟨110⟩, the die edges (Hopcroft et al. 2010; docs/fem.md §D4)


@dataclass(frozen=True)
class PackageMaterial:
    """Elastic constants and a bilinear CTE: α1 below ``tg_c``, α2 above (α2 = α1: no Tg)."""

    name: str
    youngs_gpa: float
    poisson: float
    cte1_ppm_per_k: float
    cte2_ppm_per_k: float | None = None
    tg_c: float = np.inf
    source: str = ""

    def elastic(self) -> IsotropicMaterial:
        return IsotropicMaterial(self.name, self.youngs_gpa * 1e9, self.poisson)

    def thermal_strain(self, temperature_c, reference_c: float) -> np.ndarray:
        """∫_{T_ref}^{T} α dT [1], exact for the bilinear α (clipping at Tg)."""
        t = np.asarray(temperature_c, float)
        a1 = self.cte1_ppm_per_k * 1e-6
        a2 = (self.cte2_ppm_per_k if self.cte2_ppm_per_k is not None else self.cte1_ppm_per_k) * 1e-6

        def antiderivative(x):
            return a1 * np.minimum(x, self.tg_c) + a2 * np.maximum(x - self.tg_c, 0.0)

        return antiderivative(t) - antiderivative(np.asarray(reference_c, float))


def silicon(reference_c: float = 25.0) -> PackageMaterial:
    """Silicon die: E(T_ref) of Gysin et al. (sim.materials), ν ⟨110⟩; α(T) via :func:`strain`."""
    e_gpa = float(silicon_youngs_modulus_pa(reference_c + KELVIN)) / 1e9
    return PackageMaterial("silicon", e_gpa, SILICON_POISSON_110, 2.55, source="sim.materials (Okada & Tokumaru "
                           "1984 α(T), Gysin 2004 E(T)); ν Hopcroft 2010")


def fr4() -> PackageMaterial:
    return PackageMaterial("FR-4", 25.0, 0.18, 15.0, source="docs/fem.md §D4: in-plane E 25 GPa, ν_xy 0.18, "
                           "α 15 ppm/K (physics_reference.json FR4_xy 14-20)")


def sac305() -> PackageMaterial:
    return PackageMaterial("SAC305", 45.0, 0.36, 22.0, source="docs/fem.md §D4: E 40-50 GPa, α 21-23 ppm/K "
                           "(physics_reference.json solder_SAC305)")


def copper_c194() -> PackageMaterial:
    return PackageMaterial("Cu C194", 121.0, 0.36, 17.4, source="docs/fem.md §D4: leadframe 0.203 mm")


def epoxy_attach(youngs_gpa: float = 3.9) -> PackageMaterial:
    return PackageMaterial("die attach", youngs_gpa, 0.35, 40.0, 150.0, 120.0,
                           source="docs/fem.md §D4, 84-1LMISR4: 3.9 GPa at 25 °C, α1 40 / α2 150 ppm/K, Tg 120 °C")


def mould_compound(cte1_ppm_per_k: float = 11.0) -> PackageMaterial:
    return PackageMaterial("mould", 23.0, 0.28, cte1_ppm_per_k, 36.0, 128.0,
                           source="docs/fem.md §D4, EMC-G845: 23 GPa, α1 11 / α2 36 ppm/K, Tg 128 °C")


def free_strain(material: PackageMaterial, temperature_c, reference_c: float) -> np.ndarray:
    """ε_th of a material from ``reference_c`` to ``temperature_c``; silicon uses Okada's α(T)."""
    if material.name == "silicon":
        return silicon_thermal_strain(np.asarray(temperature_c, float) + KELVIN, reference_c + KELVIN)
    return material.thermal_strain(temperature_c, reference_c)
