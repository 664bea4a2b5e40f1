"""Analytic references for the FE model: Timoshenko's bimetal, a manufactured smooth solution.

Used by tests/test_fem.py and benchmarks/bench_fem.py (docs/fem.md, design notes §D3).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from sim.fem.elasticity import (
    Factorized,
    IsotropicMaterial,
    assemble,
    determinate_supports,
    field_load,
    moduli_pa,
)
from sim.fem.mesh import layered_mesh


def timoshenko_curvature_per_m(t1_m, t2_m, e1_pa, e2_pa, alpha1_per_k, alpha2_per_k, delta_t_k) -> float:
    """Curvature of a free bimetal strip under uniform ΔT.

    κ = 6(α2 − α1)ΔT(1 + m)² / {h[3(1 + m)² + (1 + mn)(m² + 1/(mn))]}, m = t1/t2, n = E1/E2, h = t1 + t2.

    Parameters
    ----------
    t1_m, t2_m : float
        Layer thicknesses [m] (layer 1 below).
    e1_pa, e2_pa : float
        Young's moduli [Pa].
    alpha1_per_k, alpha2_per_k : float
        CTEs [1/K].
    delta_t_k : float
        Uniform temperature change [K].

    Returns
    -------
    float
        Curvature κ [1/m].

    References
    ----------
    Timoshenko (1925), J. Opt. Soc. Am. 11:233 (docs/fem.md §D3).
    """
    h, m, n = t1_m + t2_m, t1_m / t2_m, e1_pa / e2_pa
    return 6 * (alpha2_per_k - alpha1_per_k) * delta_t_k * (1 + m) ** 2 / (
        h * (3 * (1 + m) ** 2 + (1 + m * n) * (m * m + 1 / (m * n))))


def plane_strain_substitution(material: IsotropicMaterial, alpha_per_k: float) -> tuple[float, float]:
    """(E′, α′) = (E/(1 − ν²), (1 + ν)α): the beam formula's inputs for a plane-strain section.

    Parameters
    ----------
    material : IsotropicMaterial
        E [Pa] and ν [1].
    alpha_per_k : float
        CTE α [1/K].

    Returns
    -------
    youngs_pa : float
        E′ [Pa].
    alpha_per_k : float
        α′ [1/K].

    References
    ----------
    docs/fem.md §D3 (inputs per kinematics); standard plane-strain substitution.
    """
    nu = material.poisson
    return material.youngs_pa / (1 - nu * nu), (1 + nu) * alpha_per_k


@dataclass(frozen=True)
class BimetalResult:
    """FE curvature of a bimetal strip and the size of the model.

    Attributes
    ----------
    curvature_per_m : float
        Curvature [1/m].
    n_dofs : int
        Number of unknowns.
    """

    curvature_per_m: float
    n_dofs: int


def bimetal_curvature_fe(m1: IsotropicMaterial, m2: IsotropicMaterial, t1_m, t2_m, alpha1_per_k, alpha2_per_k,
                         delta_t_k, kinematics="plane_strain", length_m=20e-3, dx_m=0.25e-3,
                         layers_per_material=4) -> BimetalResult:
    """FE curvature of a free strip (material 1 below).

    Quadratic fit of u_y on the interface over the central half, away from the free-edge boundary
    layers (docs/fem.md, design notes §D3).

    Parameters
    ----------
    m1, m2 : IsotropicMaterial
        Lower and upper layer (E [Pa], ν [1]).
    t1_m, t2_m : float
        Layer thicknesses [m].
    alpha1_per_k, alpha2_per_k : float
        CTEs [1/K].
    delta_t_k : float
        Uniform temperature change [K].
    kinematics : {"plane_strain", "plane_stress", "gps"}
        Out-of-plane assumption.
    length_m : float
        Strip length [m].
    dx_m : float
        Element length [m].
    layers_per_material : int
        Elements through each layer.

    Returns
    -------
    BimetalResult
        Curvature [1/m] and number of unknowns.
    """
    lm = layered_mesh([-length_m / 2, length_m / 2], [0.0, t1_m, t1_m + t2_m], [[0], [1]], dx_m,
                      [t1_m / layers_per_material, t2_m / layers_per_material])
    system = assemble(lm.mesh, lm.material, [m1, m2], kinematics)
    fixed = determinate_supports(system.basis, (0.0, 0.0), (0.0, t1_m + t2_m))
    u = Factorized(system.K, fixed).solve(system.F @ np.array([alpha1_per_k, alpha2_per_k]) * delta_t_k)
    xs = np.linspace(-length_m / 4, length_m / 4, 41)
    P = system.basis.probes(np.vstack([xs, np.full_like(xs, t1_m)]))
    uy = (P @ u[: system.n_field])[xs.size:]
    return BimetalResult(2 * float(np.polyfit(xs, uy, 2)[0]), system.n_dofs)


@dataclass(frozen=True)
class ManufacturedError:
    """Errors of one mesh of the manufactured-solution test.

    Attributes
    ----------
    h_m : float
        Element size [m].
    l2_m : float
        ‖u_h − u‖_L2 [m·m].
    h1_semi : float
        |u_h − u|_H1 [m].
    n_dofs : int
        Number of unknowns.
    """

    h_m: float
    l2_m: float  # ‖u_h − u‖_L2 [m·m]
    h1_semi: float  # |u_h − u|_H1 [m]
    n_dofs: int


SILICON_100 = IsotropicMaterial("Si", 166e9, 0.28)  # isotropic stand-in for the manufactured test


def manufactured_error(n_per_side: int, material: IsotropicMaterial = SILICON_100,
                       side_m: float = 1e-3, strain: float = 1e-3) -> ManufacturedError:
    """Error of Q2 plane strain on a square with an exact smooth solution.

    u = ∇φ, φ = A(L/π)² sin(πx/L) sin(πy/L), and the thermal strain θ = (λ + 2μ)/(3λ + 2μ)·Δφ makes
    div σ = (λ + 2μ)∇Δφ − (3λ + 2μ)∇θ = 0 (Navier's equation for an irrotational field, Timoshenko &
    Goodier §139); u is prescribed on the whole boundary. Theory for Q2: L2 error O(h³), H1 O(h²).

    Parameters
    ----------
    n_per_side : int
        Elements per side of the square.
    material : IsotropicMaterial
        E [Pa], ν [1].
    side_m : float
        Side L of the square [m].
    strain : float
        Amplitude A of the strain field [1].

    Returns
    -------
    ManufacturedError
        L2 [m·m] and H1-seminorm [m] errors.
    """
    from skfem import Basis, ElementQuad2, ElementVector, Functional, MeshQuad

    L, A, k = side_m, strain, np.pi / side_m
    lam, mu, beta = moduli_pa(material, "plane_strain")

    def exact(x, y):
        return np.array([A / k * np.cos(k * x) * np.sin(k * y), A / k * np.sin(k * x) * np.cos(k * y)])

    def theta(x, y):
        return (lam + 2 * mu) / beta * (-2 * A * np.sin(k * x) * np.sin(k * y))

    mesh = MeshQuad.init_tensor(np.linspace(0, L, n_per_side + 1), np.linspace(0, L, n_per_side + 1))
    system = assemble(mesh, np.zeros(mesh.t.shape[1], int), [material], "plane_strain")
    basis = system.basis
    bdofs = basis.get_dofs().flatten()
    loc = basis.doflocs[:, bdofs]
    values = exact(*loc)[bdofs % 2, np.arange(bdofs.size)]  # even dofs are x components
    u = Factorized(system.K, bdofs).solve(field_load(system, theta), values)

    fine = Basis(mesh, ElementVector(ElementQuad2()), intorder=8)

    @Functional
    def l2(w):
        e = exact(*w.x)
        return (w.uh[0] - e[0]) ** 2 + (w.uh[1] - e[1]) ** 2

    @Functional
    def h1(w):
        x, y = w.x
        g = A * np.array([[-np.sin(k * x) * np.sin(k * y), np.cos(k * x) * np.cos(k * y)],
                          [np.cos(k * x) * np.cos(k * y), -np.sin(k * x) * np.sin(k * y)]])
        return sum((w.uh.grad[i, j] - g[i, j]) ** 2 for i in range(2) for j in range(2))

    uh = fine.interpolate(u)
    return ManufacturedError(L / n_per_side, float(np.sqrt(l2.assemble(fine, uh=uh))),
                             float(np.sqrt(h1.assemble(fine, uh=uh))), system.n_dofs)


def observed_orders(errors: list[float], sizes: list[float]) -> np.ndarray:
    """Observed convergence orders log(e_i/e_{i+1}) / log(h_i/h_{i+1}) for successive refinements.

    Parameters
    ----------
    errors : list of float
        Errors [any unit].
    sizes : list of float
        Element sizes [m].

    Returns
    -------
    ndarray
        Orders [1], one fewer than the meshes.
    """
    e, h = np.asarray(errors), np.asarray(sizes)
    return np.log(e[:-1] / e[1:]) / np.log(h[:-1] / h[1:])
