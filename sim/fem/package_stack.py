"""2-D cross-section of board / solder / leadframe / die attach / die / mould, solved once per unit load.

Geometry (µm, x along the sensing axis through the package centre, y up): an FR-4 board, SAC305
joints under the exposed pad and under the leads, a Cu leadframe (pad + leads, mould between), the
die attach, the MEMS die (die + cap as one silicon block) and the mould compound up to the
package height (QFPN-24, 4 × 4 × 1.8 mm; pad 2.3 mm, leadframe 0.203 mm: datasheet DS10757
Fig. 12). The die size and stand-offs are not public: stated assumptions (docs/fem.md §D2 item 1).

The stack is stress-free at ``stress_free_c`` (cure). The elastic problem is linear in the free
thermal strain of each material, so ``U_k`` (unit θ in material k) is solved once with one LU
factorisation and u(T) = Σ_k θ_k(T) U_k — exact for α(T) of any shape, including silicon's and a
Tg step (docs/fem.md §D2 item 4). Approximated: E and ν held at their reference values (silicon's E(T)
moves −68 ppm/K, i.e. 0.4 % over 60 K; polymers far more near Tg), no creep, no 3-D effects (the
generalised plane-strain curvature of a square die is ≈ 15 % above the 3-D biaxial one, docs/fem.md §D3 T2).
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from functools import lru_cache

import numpy as np

from sim.fem import materials_data as md
from sim.fem.elasticity import (
    Factorized,
    ThermoelasticSystem,
    assemble,
    determinate_supports,
)
from sim.fem.mesh import VOID, layered_mesh

UM = 1e-6


@dataclass(frozen=True)
class PackageDesign:
    """Parameters of the cross-section [µm, GPa, ppm/K, °C]; defaults are the reference stack.

    ``layout``: ``"board"`` (full stack), ``"package"`` (no board, no solder: board decoupled)
    or ``"bare_die"`` (the silicon die alone: homogeneous, the analytic-comb limit).

    Attributes
    ----------
    die_width_um, die_thickness_um : float
        Die (die + cap) size [µm].
    die_offset_um : float
        Die centre relative to the package centre (placement error) [µm].
    attach_thickness_um : float
        Die-attach bond line [µm].
    attach_modulus_gpa : float
        Die-attach Young's modulus [GPa].
    mould_cte_ppm_per_k : float
        Mould CTE α1 [ppm/K].
    package_width_um, package_height_um : float
        Package size [µm].
    pad_width_um, lead_length_um, leadframe_thickness_um : float
        Exposed pad, leads and leadframe [µm].
    solder_thickness_um : float
        Solder joints [µm].
    board_width_um, board_thickness_um : float
        FR-4 board [µm].
    stress_free_c : float
        Stress-free (cure) temperature [°C].
    layout : {"board", "package", "bare_die"}
        What is modelled (above).
    kinematics : {"gps", "plane_strain", "plane_stress"}
        Out-of-plane assumption (:mod:`sim.fem.elasticity`).
    element_um : float
        Largest element edge in x [µm] (die region: half of it).
    """

    die_width_um: float = 2000.0
    die_thickness_um: float = 400.0
    die_offset_um: float = 0.0  # die centre relative to the package centre (placement error)
    attach_thickness_um: float = 25.0
    attach_modulus_gpa: float = 3.9
    mould_cte_ppm_per_k: float = 11.0
    package_width_um: float = 4000.0
    package_height_um: float = 1800.0
    pad_width_um: float = 2300.0
    lead_length_um: float = 400.0
    leadframe_thickness_um: float = 203.0
    solder_thickness_um: float = 50.0
    board_width_um: float = 8000.0
    board_thickness_um: float = 1600.0
    stress_free_c: float = 175.0
    layout: str = "board"
    kinematics: str = "gps"
    element_um: float = 100.0  # largest element edge in x (die region: half of it)

    def __post_init__(self) -> None:
        if self.layout not in ("board", "package", "bare_die"):
            raise ValueError(f"layout must be board, package or bare_die, got {self.layout!r}")
        for name in ("die_width_um", "die_thickness_um", "attach_thickness_um", "attach_modulus_gpa",
                     "package_width_um", "leadframe_thickness_um", "solder_thickness_um", "board_thickness_um",
                     "element_um"):
            if not getattr(self, name) > 0:
                raise ValueError(f"{name} must be > 0, got {getattr(self, name)}")
        if abs(self.die_offset_um) + self.die_width_um / 2 > self.package_width_um / 2 - self.lead_length_um:
            raise ValueError(f"the die ({self.die_width_um:g} µm, offset {self.die_offset_um:g} µm) must sit inside "
                             f"the leads of the {self.package_width_um:g} µm package")
        top = self.leadframe_thickness_um + self.attach_thickness_um + self.die_thickness_um
        if self.layout != "bare_die" and top >= self.package_height_um:
            raise ValueError(f"leadframe + attach + die = {top:g} µm must stay below the package height "
                             f"{self.package_height_um:g} µm")

    def materials(self) -> list[md.PackageMaterial]:
        """Material list; the index in this list is the element's material index.

        Returns
        -------
        list of PackageMaterial
            Silicon, FR-4, SAC305, Cu C194, attach, mould (E [GPa], α [ppm/K]).
        """
        return [md.silicon(), md.fr4(), md.sac305(), md.copper_c194(), md.epoxy_attach(self.attach_modulus_gpa),
                md.mould_compound(self.mould_cte_ppm_per_k)]


SI, FR4, SOLDER, CU, ATTACH, MOULD = range(6)


def _section(d: PackageDesign):
    """Grid lines [m], cell materials, element sizes and the die-top height of the cross-section."""
    half_die, c = d.die_width_um / 2, d.die_offset_um
    hp, hpad = d.package_width_um / 2, d.pad_width_um / 2
    lead_in = hp - d.lead_length_um
    if d.layout == "bare_die":
        xb = np.unique([c - half_die, c, c + half_die])
        rows = [("die", d.die_thickness_um)]
    else:
        xb = np.unique(np.round([-hp, -lead_in, -hpad, hpad, lead_in, hp, 0.0, c - half_die, c, c + half_die], 9))
        if d.layout == "board":
            xb = np.unique(np.concatenate([xb, [-d.board_width_um / 2, d.board_width_um / 2]]))
        rows = ([("board", d.board_thickness_um), ("solder", d.solder_thickness_um)] if d.layout == "board" else [])
        mould_top = d.package_height_um - d.leadframe_thickness_um - d.attach_thickness_um - d.die_thickness_um
        rows += [("leadframe", d.leadframe_thickness_um), ("attach", d.attach_thickness_um),
                 ("die", d.die_thickness_um), ("mould", mould_top)]
    mid = 0.5 * (xb[:-1] + xb[1:])
    in_die = np.abs(mid - c) < half_die
    in_pkg = np.abs(mid) < hp
    metal = (np.abs(mid) < hpad) | ((np.abs(mid) > lead_in) & in_pkg)
    fill = {"board": np.full(mid.size, FR4), "solder": np.where(metal, SOLDER, VOID),
            "leadframe": np.where(metal, CU, np.where(in_pkg, MOULD, VOID)),
            "attach": np.where(in_die, ATTACH, np.where(in_pkg, MOULD, VOID)),
            "die": np.where(in_die, SI, np.where(in_pkg, MOULD, VOID)), "mould": np.where(in_pkg, MOULD, VOID)}
    cells = np.array([fill[name] for name, _ in rows])
    yb = np.concatenate([[0.0], np.cumsum([t for _, t in rows])])
    die_row = [name for name, _ in rows].index("die")
    dx = np.where(np.abs(mid - c) < half_die + d.element_um, d.element_um / 2, d.element_um)
    dy = np.array([min(t / 2, 4 * d.element_um if name in ("board", "mould") else d.element_um) for name, t in rows])
    return xb * UM, yb * UM, cells, dx * UM, dy * UM, yb[die_row + 1] * UM


@dataclass
class StackSolution:
    """Unit-load solutions of one design: ``U[:, k]`` is the response to θ = 1 in material k.

    Attributes
    ----------
    design : PackageDesign
        The design solved.
    system : ThermoelasticSystem
        Assembled stiffness and loads.
    U : ndarray
        Unit-load solutions (n_dofs, n_materials) [m per unit strain].
    materials : list of PackageMaterial
        Materials in column order of ``U``.
    material_index : ndarray of int
        Material of each element.
    die_top_y_m : float
        Height of the die's top surface [m].
    die_x_m : tuple of 2 float
        Left and right die edges [m].
    probes : dict
        Free-form extra data (empty by default; not used by this module).
    """

    design: PackageDesign
    system: ThermoelasticSystem
    U: np.ndarray
    materials: list
    material_index: np.ndarray
    die_top_y_m: float
    die_x_m: tuple[float, float]
    probes: dict = field(default_factory=dict)

    @property
    def n_dofs(self) -> int:
        """Number of unknowns of the system."""
        return self.system.n_dofs

    @property
    def n_elements(self) -> int:
        """Number of elements of the mesh."""
        return int(self.material_index.size)

    def surface_unit_displacements(self, x_m: np.ndarray, y_m: float | None = None) -> tuple[np.ndarray, np.ndarray]:
        """(u_x, u_y) per unit load at points (x_m, die top): arrays (n_materials, len(x_m)) [m].

        Parameters
        ----------
        x_m : float or ndarray
            Abscissae [m].
        y_m : float, optional
            Height [m]; default the die top.

        Returns
        -------
        ux, uy : ndarray
            Displacements per unit thermal strain of each material [m].
        """
        x = np.atleast_1d(np.asarray(x_m, float))
        y = self.die_top_y_m if y_m is None else y_m
        P = self.system.basis.probes(np.vstack([x, np.full_like(x, y)]))
        vals = (P @ self.U[: self.system.n_field]).T  # (nmat, 2n): u_x of every point, then u_y
        return vals[:, : x.size], vals[:, x.size:]

    def thermal_strains(self, temperature_c, reference_c: float | None = None) -> np.ndarray:
        """θ_k(T) from ``reference_c`` (default: stress-free): array (len(T), n_materials).

        Parameters
        ----------
        temperature_c : float or ndarray
            Temperature [°C].
        reference_c : float, optional
            Reference temperature [°C]; default ``design.stress_free_c``.

        Returns
        -------
        ndarray
            Free thermal strain of each material [1] (:func:`sim.fem.materials_data.free_strain`).
        """
        ref = self.design.stress_free_c if reference_c is None else reference_c
        t = np.atleast_1d(np.asarray(temperature_c, float))
        return np.column_stack([md.free_strain(m, t, ref) for m in self.materials])

    def displacement(self, temperature_c: float, reference_c: float | None = None) -> np.ndarray:
        """Full dof vector at one temperature (from the stress-free state unless ``reference_c``).

        Exact superposition u(T) = Σ_k θ_k(T) U_k (docs/fem.md §D2 item 4).

        Parameters
        ----------
        temperature_c : float
            Temperature [°C].
        reference_c : float, optional
            Reference temperature [°C].

        Returns
        -------
        ndarray
            Displacements [m] (ε0 [1] under ``gps``).
        """
        return self.U @ self.thermal_strains(temperature_c, reference_c)[0]


def build_system(design: PackageDesign):
    """Mesh and assemble the design.

    Parameters
    ----------
    design : PackageDesign
        The cross-section [µm].

    Returns
    -------
    system : ThermoelasticSystem
        Stiffness and unit loads.
    material : ndarray of int
        Material index per element.
    die_top : float
        Height of the die top [m].
    fixed : ndarray of int
        Dofs of the statically determinate supports.
    """
    xb, yb, cells, dx, dy, die_top = _section(design)
    lm = layered_mesh(xb, yb, cells, dx, dy, min_divisions=2)
    mats = design.materials()
    system = assemble(lm.mesh, lm.material, [m.elastic() for m in mats], design.kinematics)
    x0 = design.die_offset_um * UM if design.layout == "bare_die" else 0.0
    fixed = determinate_supports(system.basis, (x0, yb[0]), (x0, yb[-1]))
    return system, lm.material, die_top, fixed


@lru_cache(maxsize=64)
def solve_stack(design: PackageDesign) -> StackSolution:
    """Assemble, factorise once and solve every unit load of ``design`` (cached per design).

    Parameters
    ----------
    design : PackageDesign
        The cross-section [µm].

    Returns
    -------
    StackSolution
        Unit-load solutions [m].
    """
    system, material, die_top, fixed = build_system(design)
    U = Factorized(system.K, fixed).solve(system.F)
    c, h = design.die_offset_um * UM, design.die_width_um / 2 * UM
    return StackSolution(design, system, U, design.materials(), material, die_top, (c - h, c + h))


@dataclass(frozen=True)
class DieSurface:
    """The die's top surface at each temperature (rows): displacement, strain, curvature, bow.

    Attributes
    ----------
    temperature_c : ndarray
        Temperatures [°C].
    x_um : ndarray
        Points relative to the die centre [µm].
    ux_m, uy_m : ndarray
        Displacements [m].
    strain_xx : ndarray
        In-plane strain ∂u_x/∂x [1].
    curvature_per_m : ndarray
        Curvature [1/m].
    warpage_um : ndarray
        Bow, peak-to-valley after removing the best line [µm].
    """

    temperature_c: np.ndarray
    x_um: np.ndarray  # relative to the die centre
    ux_m: np.ndarray
    uy_m: np.ndarray
    strain_xx: np.ndarray
    curvature_per_m: np.ndarray
    warpage_um: np.ndarray


def die_surface(sol: StackSolution, temperature_c, reference_c: float | None = None, points: int = 201) -> DieSurface:
    """Die-top displacement, in-plane strain, curvature and bow versus temperature.

    Strain ∂u_x/∂x, curvature from a quadratic fit of u_y, bow as the peak-to-valley of u_y after
    removing the best line.

    Parameters
    ----------
    sol : StackSolution
        Solved package.
    temperature_c : float or ndarray
        Temperature [°C].
    reference_c : float, optional
        Reference temperature [°C]; default the stress-free one.
    points : int
        Sample points across the die.

    Returns
    -------
    DieSurface
        Displacement [m], strain [1], curvature [1/m], bow [µm].
    """
    a, b = sol.die_x_m
    x = np.linspace(a, b, points)
    ux1, uy1 = sol.surface_unit_displacements(x)
    theta = sol.thermal_strains(temperature_c, reference_c)
    ux, uy = theta @ ux1, theta @ uy1
    xc = x - 0.5 * (a + b)
    quad = np.polynomial.polynomial.polyfit(xc, uy.T, 2)  # (3, nT)
    line = np.polynomial.polynomial.polyfit(xc, uy.T, 1)
    resid = uy - np.polynomial.polynomial.polyval(xc, line)
    return DieSurface(np.atleast_1d(np.asarray(temperature_c, float)), xc / UM, ux, uy,
                      np.gradient(ux, x, axis=1), 2 * quad[2], (resid.max(axis=1) - resid.min(axis=1)) / UM)


def mirrored(design: PackageDesign) -> PackageDesign:
    """The same design mirrored about the package centre (x → −x).

    Parameters
    ----------
    design : PackageDesign
        The design.

    Returns
    -------
    PackageDesign
        With ``die_offset_um`` negated.
    """
    return replace(design, die_offset_um=-design.die_offset_um)
