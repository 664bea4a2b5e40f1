"""Linear thermoelasticity in 2-D with quadratic elements (scikit-fem), one unit load per material.

Kinematics of the cross-section (x along it, y through the thickness, z out of the plane):

* ``plane_strain``: ε_zz = 0; σ = λ tr(ε) I + 2μ ε − (3λ + 2μ) θ I;
* ``plane_stress``: σ_zz = 0, i.e. λ* = 2λμ/(λ + 2μ) and a thermal modulus β* = E/(1 − ν);
* ``gps`` (generalised plane strain): ε_zz = ε0, one global unknown, with ∫σ_zz dA = 0. Bordered
  bilinear form ∫[2μ ε(u):ε(v) + λ tr ε(u) tr ε(v)] + ∫λ ε0 tr ε(v) + ∫λ tr ε(u) η + ∫(λ+2μ) ε0 η,
  load ∫(3λ+2μ) θ [tr ε(v) + η] (docs/fem.md §D2 item 2).

θ is the free thermal strain ∫α dT. The problem is linear in θ: with θ = Σ_k θ_k 1_{Ω_k} (one
value per material k), u = Σ_k θ_k U_k where U_k solves a unit thermal strain in material k alone
(docs/fem.md §D2 item 4). References: Timoshenko & Goodier, *Theory of Elasticity* (1951) §§ 150–152 for
the thermoelastic constitutive law; Barber, *Elasticity* (2010) ch. 14 for plane stress/strain.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp
from scipy.sparse.linalg import splu

KINEMATICS = ("plane_strain", "plane_stress", "gps")


@dataclass(frozen=True)
class IsotropicMaterial:
    """Linear-elastic isotropic material at its reference state.

    Attributes
    ----------
    name : str
        Material name.
    youngs_pa : float
        Young's modulus E [Pa].
    poisson : float
        Poisson's ratio ν [1].
    """

    name: str
    youngs_pa: float
    poisson: float

    @property
    def lame_lambda_pa(self) -> float:
        """Lamé's λ = Eν / ((1 + ν)(1 − 2ν)) [Pa] (Timoshenko & Goodier §6)."""
        return self.youngs_pa * self.poisson / ((1 + self.poisson) * (1 - 2 * self.poisson))

    @property
    def shear_modulus_pa(self) -> float:
        """Shear modulus μ = E / (2(1 + ν)) [Pa] (standard isotropic relation)."""
        return self.youngs_pa / (2 * (1 + self.poisson))


def moduli_pa(material: IsotropicMaterial, kinematics: str) -> tuple[float, float, float]:
    """(λ, μ, β) for the kinematics, β the thermal modulus: σ_thermal = −β θ I in the plane.

    Plane stress uses λ* = 2λμ/(λ + 2μ) and β* = 2μ(3λ + 2μ)/(λ + 2μ) = E/(1 − ν).

    Parameters
    ----------
    material : IsotropicMaterial
        E [Pa] and ν [1].
    kinematics : {"plane_strain", "plane_stress", "gps"}
        Out-of-plane assumption.

    Returns
    -------
    lam, mu, beta : float
        λ, μ and β [Pa].

    References
    ----------
    Timoshenko & Goodier, *Theory of Elasticity* (1951) §§ 150–152; Barber, *Elasticity* (2010)
    ch. 14 (plane stress/strain).
    """
    lam, mu = material.lame_lambda_pa, material.shear_modulus_pa
    if kinematics == "plane_stress":
        return 2 * lam * mu / (lam + 2 * mu), mu, 2 * mu * (3 * lam + 2 * mu) / (lam + 2 * mu)
    if kinematics in ("plane_strain", "gps"):
        return lam, mu, 3 * lam + 2 * mu
    raise ValueError(f"kinematics must be one of {KINEMATICS}, got {kinematics!r}")


@dataclass
class ThermoelasticSystem:
    """Assembled stiffness ``K`` and unit thermal loads ``F`` (one column per material).

    With ``gps`` the last row/column is the out-of-plane strain ε0; ``n_field`` is the number of
    displacement degrees of freedom (``basis.N``).

    Attributes
    ----------
    basis : skfem.Basis
        Q2 vector basis of the mesh.
    K : scipy.sparse.csr_matrix
        Stiffness [N/m per metre of depth, i.e. Pa].
    F : ndarray
        Loads of a unit thermal strain in each material [N/m], one column per material.
    kinematics : str
        ``"plane_strain"``, ``"plane_stress"`` or ``"gps"``.
    material_names : tuple of str
        Names in column order of ``F``.
    lam, beta : ndarray
        λ and β at the quadrature points (nelems, nqp) [Pa].
    """

    basis: object
    K: sp.csr_matrix
    F: np.ndarray
    kinematics: str
    material_names: tuple[str, ...]
    lam: np.ndarray  # (nelems, nqp) coefficient fields, kept for extra loads
    beta: np.ndarray

    @property
    def n_field(self) -> int:
        """Number of displacement degrees of freedom."""
        return self.basis.N

    @property
    def n_dofs(self) -> int:
        """Number of unknowns (displacements, plus ε0 under ``gps``)."""
        return self.K.shape[0]


def _forms():
    from skfem import BilinearForm, Functional, LinearForm
    from skfem.helpers import ddot, sym_grad, trace

    @BilinearForm
    def stiffness(u, v, w):
        return 2 * w.mu * ddot(sym_grad(u), sym_grad(v)) + w.lam * trace(sym_grad(u)) * trace(sym_grad(v))

    @LinearForm
    def trace_load(v, w):
        return w.c * trace(sym_grad(v))

    @Functional
    def integral(w):
        return w.c

    return stiffness, trace_load, integral


def vector_quadratic_basis(mesh, intorder: int = 4):
    """Basis of Q2 (9-node) vector fields on a quadrilateral mesh.

    Parameters
    ----------
    mesh : skfem.MeshQuad
        Mesh [m].
    intorder : int
        Gauss rule order; 4 is exact for the Q2 stiffness on affine cells.

    Returns
    -------
    skfem.Basis
        Vector Q2 basis.
    """
    from skfem import Basis, ElementQuad2, ElementVector

    return Basis(mesh, ElementVector(ElementQuad2()), intorder=intorder)


def assemble(mesh, material_index, materials: list[IsotropicMaterial], kinematics: str = "gps",
             intorder: int = 4) -> ThermoelasticSystem:
    """Stiffness and one unit-θ load per material (θ = 1 in material k, 0 elsewhere).

    Parameters
    ----------
    mesh : skfem.MeshQuad
        Mesh [m].
    material_index : int array
        Material of each element (index into ``materials``).
    materials : list of IsotropicMaterial
        E [Pa], ν [1].
    kinematics : {"plane_strain", "plane_stress", "gps"}
        Out-of-plane assumption (module docstring).
    intorder : int
        Gauss rule order.

    Returns
    -------
    ThermoelasticSystem
        K and F (per metre of depth).

    References
    ----------
    Weak form of linear thermoelasticity (Timoshenko & Goodier §§ 150–152); the bordered GPS form of
    docs/fem.md §D2 item 2.
    """
    stiffness, trace_load, integral = _forms()
    basis = vector_quadratic_basis(mesh, intorder)
    idx = np.asarray(material_index, int)
    props = np.array([moduli_pa(m, kinematics) for m in materials])  # (nmat, 3)
    nqp = basis.X.shape[1]
    lam, mu, beta = (np.repeat(props[idx, c][:, None], nqp, axis=1) for c in range(3))
    K = stiffness.assemble(basis, lam=lam, mu=mu)
    F = np.column_stack([trace_load.assemble(basis, c=beta * (idx == k)[:, None]) for k in range(len(materials))])
    if kinematics == "gps":
        col = trace_load.assemble(basis, c=lam)
        corner = integral.assemble(basis, c=lam + 2 * mu)
        K = sp.bmat([[K, sp.csr_matrix(col[:, None])], [sp.csr_matrix(col[None, :]), sp.csr_matrix([[corner]])]])
        row = np.array([integral.assemble(basis, c=beta * (idx == k)[:, None]) for k in range(len(materials))])
        F = np.vstack([F, row[None, :]])
    return ThermoelasticSystem(basis, sp.csr_matrix(K), F, kinematics, tuple(m.name for m in materials), lam, beta)


def field_load(system: ThermoelasticSystem, theta) -> np.ndarray:
    """Load vector of a spatially varying thermal strain ``theta(x_m, y_m)`` (every material).

    Parameters
    ----------
    system : ThermoelasticSystem
        Assembled system.
    theta : callable
        θ(x [m], y [m]) [1], vectorised over quadrature points.

    Returns
    -------
    ndarray
        Load vector [N/m], with the ε0 entry under ``gps``.
    """
    _, trace_load, integral = _forms()
    x = system.basis.mapping.F(system.basis.X)  # quadrature points (2, nelems, nqp)
    c = system.beta * theta(x[0], x[1])
    f = trace_load.assemble(system.basis, c=c)
    if system.kinematics == "gps":
        f = np.append(f, integral.assemble(system.basis, c=c))
    return f


def nearest_node_dofs(basis, point_m) -> np.ndarray:
    """(x-dof, y-dof) of the mesh vertex nearest to ``point_m``.

    Parameters
    ----------
    basis : skfem.Basis
        Vector basis.
    point_m : sequence of 2 float
        (x, y) [m].

    Returns
    -------
    ndarray of int
        The two dof indices.
    """
    p = basis.mesh.p
    k = int(np.argmin((p[0] - point_m[0]) ** 2 + (p[1] - point_m[1]) ** 2))
    return basis.nodal_dofs[:, k]


def determinate_supports(basis, bottom_m, top_m) -> np.ndarray:
    """Three constraints that remove the rigid-body modes and nothing else.

    Both components at ``bottom_m``, the x component at ``top_m`` (a point vertically above).

    Parameters
    ----------
    basis : skfem.Basis
        Vector basis.
    bottom_m, top_m : sequence of 2 float
        (x, y) of the two support points [m].

    Returns
    -------
    ndarray of int
        Three constrained dof indices.
    """
    a, b = nearest_node_dofs(basis, bottom_m), nearest_node_dofs(basis, top_m)
    return np.array([a[0], a[1], b[0]])


class Factorized:
    """The stiffness with some dofs prescribed, LU-factorised once; :meth:`solve` takes many loads.

    Parameters
    ----------
    K : scipy.sparse matrix
        Stiffness (n, n) [Pa].
    fixed_dofs : int array
        Indices of the prescribed dofs.
    """

    def __init__(self, K: sp.spmatrix, fixed_dofs: np.ndarray):
        n = K.shape[0]
        self.n = n
        self.fixed = np.unique(np.asarray(fixed_dofs, int))
        self.free = np.setdiff1d(np.arange(n), self.fixed)
        K = sp.csr_matrix(K)
        self.K_fixed_cols = K[self.free][:, self.fixed]
        self.lu = splu(sp.csc_matrix(K[self.free][:, self.free]), permc_spec="COLAMD")

    def solve(self, loads: np.ndarray, fixed_values: np.ndarray | None = None) -> np.ndarray:
        """Solutions (n, m) for loads (n, m) (or (n,)); prescribed values default to 0.

        Parameters
        ----------
        loads : ndarray
            Load vectors (n,) or (n, m) [N/m].
        fixed_values : ndarray, optional
            Values of the prescribed dofs [m], one column per load.

        Returns
        -------
        ndarray
            Displacements (n,) or (n, m) [m] (ε0 [1] under ``gps``).
        """
        f = np.asarray(loads, float)
        single = f.ndim == 1
        f = f[:, None] if single else f
        u = np.zeros((self.n, f.shape[1]))
        rhs = f[self.free]
        if fixed_values is not None:
            g = np.asarray(fixed_values, float).reshape(self.fixed.size, -1)
            u[self.fixed] = g
            rhs = rhs - self.K_fixed_cols @ g
        u[self.free] = self.lu.solve(np.ascontiguousarray(rhs))
        return u[:, 0] if single else u


def strain_energy_j_per_m(system: ThermoelasticSystem, u: np.ndarray) -> float:
    """½ uᵀ K u [J per metre of depth]: the elastic energy of a solution of K u = f.

    Parameters
    ----------
    system : ThermoelasticSystem
        Assembled system.
    u : ndarray
        Solution vector [m].

    Returns
    -------
    float
        Strain energy [J/m].
    """
    return 0.5 * float(u @ (system.K @ u))
