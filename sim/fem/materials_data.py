"""Package materials: elastic constants and free thermal strain ε_th = ∫α dT, with sources.

Sources are listed in ``docs/fem.md``, design notes §D4, and the CTE ranges of the package materials
in ``docs/physics.md`` §1.4. Silicon takes α(T) and E(T) from
:mod:`sim.materials`; E is held at the reference temperature in the elastic solve.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from sim.fem.elasticity import IsotropicMaterial
from sim.materials import KELVIN, silicon_thermal_strain, silicon_youngs_modulus_pa

SILICON_POISSON_110 = 0.064  # in-plane ν along ⟨110⟩, the die edges (Hopcroft et al. 2010; docs/fem.md §D4)


@dataclass(frozen=True)
class PackageMaterial:
    """Elastic constants and a bilinear CTE: α1 below ``tg_c``, α2 above (α2 = α1: no Tg).

    Attributes
    ----------
    name : str
        Material name (``"silicon"`` selects Okada's α(T) in :func:`free_strain`).
    youngs_gpa : float
        Young's modulus E [GPa].
    poisson : float
        Poisson's ratio ν [1].
    cte1_ppm_per_k : float
        CTE α1 below Tg [ppm/K].
    cte2_ppm_per_k : float or None
        CTE α2 above Tg [ppm/K]; None: α1.
    tg_c : float
        Glass transition Tg [°C]; inf: none.
    source : str
        Where the values come from.
    """

    name: str
    youngs_gpa: float
    poisson: float
    cte1_ppm_per_k: float
    cte2_ppm_per_k: float | None = None
    tg_c: float = np.inf
    source: str = ""

    def elastic(self) -> IsotropicMaterial:
        """The elastic constants for the solver.

        Returns
        -------
        IsotropicMaterial
            E [Pa] and ν [1].
        """
        return IsotropicMaterial(self.name, self.youngs_gpa * 1e9, self.poisson)

    def thermal_strain(self, temperature_c, reference_c: float) -> np.ndarray:
        """Free thermal strain ∫_{T_ref}^{T} α dT [1], exact for the bilinear α (clipping at Tg).

        Parameters
        ----------
        temperature_c : float or ndarray
            Temperature [°C].
        reference_c : float
            Strain-free temperature [°C].

        Returns
        -------
        ndarray
            ε_th [1].

        References
        ----------
        Definition of the thermal strain as the integral of the CTE (standard result); values in
        docs/fem.md §D4.
        """
        t = np.asarray(temperature_c, float)
        a1 = self.cte1_ppm_per_k * 1e-6
        a2 = (self.cte2_ppm_per_k if self.cte2_ppm_per_k is not None else self.cte1_ppm_per_k) * 1e-6

        def antiderivative(x):
            return a1 * np.minimum(x, self.tg_c) + a2 * np.maximum(x - self.tg_c, 0.0)

        return antiderivative(t) - antiderivative(np.asarray(reference_c, float))


def silicon(reference_c: float = 25.0) -> PackageMaterial:
    """Silicon die: E(T_ref) of Gysin et al. (sim.materials), ν ⟨110⟩; α(T) via :func:`free_strain`.

    Parameters
    ----------
    reference_c : float
        Temperature at which E is evaluated [°C].

    Returns
    -------
    PackageMaterial
        E [GPa], ν = 0.064 [1], α1 = 2.55 ppm/K (a constant near α(25 °C); :func:`free_strain`
        uses Okada's α(T) instead).

    References
    ----------
    Gysin et al. (2004) E(T); Okada & Tokumaru (1984) α(T); Hopcroft, Nix & Kenny (2010), JMEMS
    19:229, ν along ⟨110⟩ (docs/fem.md §D4).
    """
    e_gpa = float(silicon_youngs_modulus_pa(reference_c + KELVIN)) / 1e9
    return PackageMaterial("silicon", e_gpa, SILICON_POISSON_110, 2.55, source="sim.materials (Okada & Tokumaru "
                           "1984 α(T), Gysin 2004 E(T)); ν Hopcroft 2010")


def fr4() -> PackageMaterial:
    """FR-4 board laminate, in-plane values (docs/fem.md §D4).

    Returns
    -------
    PackageMaterial
        E 25 GPa, ν 0.18, α 15 ppm/K.
    """
    return PackageMaterial("FR-4", 25.0, 0.18, 15.0, source="docs/fem.md §D4: in-plane E 25 GPa, ν_xy 0.18, "
                           "α 15 ppm/K (docs/physics.md §1.4: FR-4 in-plane 14-20)")


def sac305() -> PackageMaterial:
    """SAC305 solder joints (docs/fem.md §D4: class values, NIST lead-free solder database).

    Returns
    -------
    PackageMaterial
        E 45 GPa, ν 0.36, α 22 ppm/K.
    """
    return PackageMaterial("SAC305", 45.0, 0.36, 22.0, source="docs/fem.md §D4: E 40-50 GPa, α 21-23 ppm/K "
                           "(docs/physics.md §1.4: SAC305 21-23)")


def copper_c194() -> PackageMaterial:
    """Cu C194 leadframe (docs/fem.md §D4: alloy datasheet).

    Returns
    -------
    PackageMaterial
        E 121 GPa, ν 0.36, α 17.4 ppm/K.
    """
    return PackageMaterial("Cu C194", 121.0, 0.36, 17.4, source="docs/fem.md §D4: leadframe 0.203 mm")


def epoxy_attach(youngs_gpa: float = 3.9) -> PackageMaterial:
    """Epoxy die attach 84-1LMISR4 (docs/fem.md §D4: vendor datasheet).

    Parameters
    ----------
    youngs_gpa : float
        Young's modulus [GPa] (3.9 at 25 °C; lower for low-stress attaches).

    Returns
    -------
    PackageMaterial
        ν 0.35, α1 40 / α2 150 ppm/K, Tg 120 °C.
    """
    return PackageMaterial("die attach", youngs_gpa, 0.35, 40.0, 150.0, 120.0,
                           source="docs/fem.md §D4, 84-1LMISR4: 3.9 GPa at 25 °C, α1 40 / α2 150 ppm/K, Tg 120 °C")


def mould_compound(cte1_ppm_per_k: float = 11.0) -> PackageMaterial:
    """Mould compound EMC-G845 (docs/fem.md §D4: vendor datasheet).

    Parameters
    ----------
    cte1_ppm_per_k : float
        CTE α1 below Tg [ppm/K].

    Returns
    -------
    PackageMaterial
        E 23 GPa, ν 0.28, α2 36 ppm/K, Tg 128 °C.
    """
    return PackageMaterial("mould", 23.0, 0.28, cte1_ppm_per_k, 36.0, 128.0,
                           source="docs/fem.md §D4, EMC-G845: 23 GPa, α1 11 / α2 36 ppm/K, Tg 128 °C")


def free_strain(material: PackageMaterial, temperature_c, reference_c: float) -> np.ndarray:
    """ε_th of a material from ``reference_c`` to ``temperature_c``; silicon uses Okada's α(T).

    Parameters
    ----------
    material : PackageMaterial
        The material.
    temperature_c : float or ndarray
        Temperature [°C].
    reference_c : float
        Strain-free temperature [°C].

    Returns
    -------
    ndarray
        Free thermal strain ε_th [1].

    References
    ----------
    Okada & Tokumaru (1984) for silicon (:func:`sim.materials.silicon_thermal_strain`); the
    bilinear α of :meth:`PackageMaterial.thermal_strain` otherwise.
    """
    if material.name == "silicon":
        return silicon_thermal_strain(np.asarray(temperature_c, float) + KELVIN, reference_c + KELVIN)
    return material.thermal_strain(temperature_c, reference_c)
