"""Finite-element package model (sim.fem): verified against analytic references, convergence
order, invariants and symmetries; the package_fem effect, `twin package` and the FE render."""

import json
from dataclasses import replace

import numpy as np
import pytest
from schemas import check_schema
from conftest import ROOT, run_cli

from sim.fem.comb_on_substrate import (
    AnchorLayout,
    anchor_motion,
    comb_drift,
    package_drift,
    slope_per_c,
)
from sim.fem.elasticity import (
    Factorized,
    IsotropicMaterial,
    assemble,
    determinate_supports,
)
from sim.fem.package_stack import PackageDesign, die_surface, mirrored, solve_stack
from sim.fem.verification import (
    bimetal_curvature_fe,
    manufactured_error,
    observed_orders,
    plane_strain_substitution,
    timoshenko_curvature_per_m,
)
from sim.microstructure import CombGeometry, drift_g

SWEEP_C = np.linspace(-40.0, 85.0, 26)
STEEL, ALUMINIUM = IsotropicMaterial("steel", 200e9, 0.0), IsotropicMaterial("Al", 70e9, 0.0)
SI, FR4 = IsotropicMaterial("Si", 169e9, 0.064), IsotropicMaterial("FR-4", 25e9, 0.18)


@pytest.fixture(scope="module")
def board():
    return solve_stack(PackageDesign())


# -- analytic references ---------------------------------------------------------------------------

def test_steel_aluminium_strip_matches_timoshenko():
    """docs/fem.md §D3 T1 (ν = 0, so plane strain = plane stress = beam): κ = 1.5343 1/m at ΔT = +100 K.
    0.5 % is the acceptance bound; the FE curvature over the central half of a 20:1 strip is exact
    up to the free-edge boundary layers, so the error observed is ~1e-5."""
    ref = timoshenko_curvature_per_m(0.5e-3, 0.5e-3, 200e9, 70e9, 12e-6, 23e-6, 100.0)
    assert ref == pytest.approx(1.5343, abs=1e-4)
    fe = bimetal_curvature_fe(STEEL, ALUMINIUM, 0.5e-3, 0.5e-3, 12e-6, 23e-6, 100.0, layers_per_material=2)
    # Timoshenko's κ > 0 bends the strip convex on material 2's side; here material 2 is on top, so u_y″ = −κ
    assert abs(-fe.curvature_per_m / ref - 1) <= 0.005


@pytest.mark.parametrize("kinematics,substitute", [("plane_strain", True), ("plane_stress", False)])
def test_silicon_fr4_strip_matches_timoshenko_with_the_memos_substitutions(kinematics, substitute):
    """docs/fem.md §D3 T2 (0.5 mm Si on 1.6 mm FR-4, ΔT = −100 K): plane strain needs E′ = E/(1−ν²) AND
    α′ = (1+ν)α (1.0571 1/m), plane stress the plain values (0.8787 1/m); ≤ 0.5 % (acceptance)."""
    (e1, a1), (e2, a2) = ((plane_strain_substitution(SI, 2.6e-6), plane_strain_substitution(FR4, 15e-6))
                          if substitute else ((SI.youngs_pa, 2.6e-6), (FR4.youngs_pa, 15e-6)))
    ref = timoshenko_curvature_per_m(0.5e-3, 1.6e-3, e1, e2, a1, a2, -100.0)
    fe = bimetal_curvature_fe(SI, FR4, 0.5e-3, 1.6e-3, 2.6e-6, 15e-6, -100.0, kinematics)
    assert abs(-fe.curvature_per_m / ref - 1) <= 0.005  # sign: see the steel/aluminium test
    assert abs(ref) == pytest.approx(1.0571 if substitute else 0.87874, rel=2e-4)  # docs/fem.md §D3 T2


def test_observed_convergence_order_of_q2_is_three_in_l2_and_two_in_h1():
    """Manufactured smooth solution (no singularity): Q2 theory gives ‖e‖_L2 = O(h³), |e|_H1 = O(h²);
    the acceptance window is ±0.3 on each observed order."""
    runs = [manufactured_error(n) for n in (4, 8, 16)]
    h = [r.h_m for r in runs]
    l2, h1 = observed_orders([r.l2_m for r in runs], h), observed_orders([r.h1_semi for r in runs], h)
    assert np.all(np.abs(l2 - 3.0) <= 0.3), l2
    assert np.all(np.abs(h1 - 2.0) <= 0.3), h1


def test_free_homogeneous_silicon_dilates_uniformly_in_gps():
    """docs/fem.md §D3 T3: a free homogeneous body in GPS has ε_xx = ε_zz = αΔT and no curvature (exact:
    the linear field is in the Q2 space, so only round-off remains; 1e-9 relative)."""
    sol = solve_stack(PackageDesign(layout="bare_die"))
    x = np.linspace(*sol.die_x_m, 7)
    ux, uy = sol.surface_unit_displacements(x)
    k = [m.name for m in sol.materials].index("silicon")
    centre = np.mean(sol.die_x_m)
    assert np.allclose(ux[k], x - centre, rtol=0, atol=1e-9 * np.ptp(x))
    assert np.ptp(uy[k]) < 1e-9 * np.ptp(x)
    assert sol.U[-1, k] == pytest.approx(1.0, rel=1e-9)  # ε0 = θ


# -- the comb on the substrate ---------------------------------------------------------------------

@pytest.mark.parametrize("reading", ["H", "HE"])
def test_silicon_on_silicon_reproduces_the_analytic_comb(reading):
    """No package: anchors move exactly with the comb's own dilation, so the comb is sim.microstructure's
    reading H / HE. Acceptance: 1e-6 relative on the scale factor; the offset is zero analytically
    and here only round-off of a 2 µm gap (< 1e-9 g)."""
    geometry = CombGeometry()
    sol = solve_stack(PackageDesign(layout="bare_die"))
    am = anchor_motion(sol, AnchorLayout(cell_x_um=250.0, electrode_shift_um=30.0))
    theta = sol.thermal_strains(SWEEP_C, 25.0)
    fe = comb_drift(geometry, SWEEP_C, theta @ am.mass_m, theta @ am.right_m, theta @ am.left_m, reading)
    ref = drift_g(geometry, SWEEP_C, 1.0, reading)
    scale = np.max(np.abs(ref["scale_factor"]))
    # H: dilation leaves ΔC nearly invariant (6e-8 left by the full-scale Δu); HE: E(T) moves it by ~1e-2
    assert scale > 1e-8
    assert np.max(np.abs(fe.scale_factor - ref["scale_factor"])) <= 1e-6 * scale
    assert np.max(np.abs(fe.offset_g - ref["offset"])) < 1e-9


def test_anchor_map_of_a_quadratic_field_gives_the_memos_75_pm():
    """docs/fem.md §D3 T6: u = ½ε′x², ε′ = 1 ppm/mm, springs ±400 µm, electrodes ±100 µm → δ = 75 pm = 2.72 mg
    at 3 kHz (small-signal, so within 1 %)."""
    geometry = CombGeometry()
    eps_prime = 1e-6 / 1e-3
    u = {x: 0.5 * eps_prime * (x * 1e-6) ** 2 for x in (-400, 400, -100, 100)}
    mass = 0.5 * (u[-400] + u[400])
    delta = mass - 0.5 * (u[100] + u[-100])
    assert delta == pytest.approx(75e-12, rel=1e-9)
    off = comb_drift(geometry, np.array([25.0]), mass, u[100], u[-100]).offset_g[0]
    assert off * 1e3 == pytest.approx(2.72, rel=0.01)


def test_symmetric_package_and_anchors_give_zero_offset(board):
    """Mirror symmetry makes u_x odd about the centre: the offset vanishes to solver precision.
    Compared with the same package with the cell moved 300 µm (≈ 3 mg/°C), the residual is < 1e-9 of it."""
    geometry = CombGeometry()
    sym = package_drift(board, AnchorLayout(), geometry, SWEEP_C)
    asym = package_drift(board, AnchorLayout(cell_x_um=300.0), geometry, SWEEP_C)
    assert np.max(np.abs(asym.offset_mg)) > 10.0
    assert np.max(np.abs(sym.offset_mg)) < 1e-9 * np.max(np.abs(asym.offset_mg))


def test_mirroring_the_anchor_placement_flips_the_offset():
    """Die offset +200 µm and cell +150 µm against the mirror image (−200, −150): the meshes are mirror
    images, so the offsets are opposite to round-off (1e-8 relative); TCSo (even) is unchanged."""
    geometry = CombGeometry()
    design = replace(PackageDesign(), die_offset_um=200.0, element_um=150.0)
    a = package_drift(solve_stack(design), AnchorLayout(cell_x_um=150.0), geometry, SWEEP_C)
    b = package_drift(solve_stack(mirrored(design)), AnchorLayout(cell_x_um=-150.0), geometry, SWEEP_C)
    scale = np.max(np.abs(a.offset_mg))
    assert scale > 1.0
    assert np.max(np.abs(a.offset_mg + b.offset_mg)) < 1e-8 * scale
    assert np.allclose(a.scale_factor_ppm, b.scale_factor_ppm, rtol=1e-8, atol=1e-8)


def test_superposition_of_unit_loads_equals_the_direct_solve(board):
    """u(T) = Σ_k θ_k(T) U_k is exact: it equals one solve with the combined load (1e-10 relative)."""
    system = board.system
    theta = board.thermal_strains(-40.0)[0]
    fixed = determinate_supports(system.basis, (0.0, 0.0), (0.0, system.basis.mesh.p[1].max()))
    direct = Factorized(system.K, fixed).solve(system.F @ theta)
    assert np.max(np.abs(board.U @ theta - direct)) < 1e-10 * np.max(np.abs(direct))


def test_operator_is_symmetric_positive_and_reciprocal(board):
    """Betti reciprocity U_a·F_b = U_b·F_a (K symmetric), rigid-body modes in the kernel of the
    plane-strain operator, positive energy ½uᵀKu of every unit solution; round-off bounds 1e-9."""
    K, F, U = board.system.K, board.system.F, board.U
    asym = abs(K - K.T).max()
    assert asym <= 1e-12 * abs(K).max()
    W = U.T @ F
    assert np.allclose(W, W.T, rtol=1e-9, atol=1e-9 * np.abs(W).max())
    assert np.all(np.einsum("ik,ik->k", U, K @ U) > 0)
    ps = assemble(board.system.basis.mesh, board.material_index, [m.elastic() for m in board.materials], "plane_strain")
    p = ps.basis.doflocs
    for rigid in (np.where(np.arange(ps.n_field) % 2 == 0, 1.0, 0.0),          # x translation
                  np.where(np.arange(ps.n_field) % 2 == 0, -p[1], p[0])):      # rotation
        assert np.abs(ps.K @ rigid).max() <= 1e-9 * abs(ps.K).max() * np.abs(rigid).max()


def test_die_bow_is_zero_at_the_stress_free_temperature_and_tcoff_is_linear(board):
    surf = die_surface(board, np.array([board.design.stress_free_c, -40.0]))
    assert surf.warpage_um[0] < 1e-12 and surf.warpage_um[1] > 0.01
    drift = package_drift(board, AnchorLayout(cell_x_um=300.0), CombGeometry(), SWEEP_C)
    # below every Tg the slope is nearly constant: TCOff over the two halves agree within 10 %
    lo, hi = slope_per_c(SWEEP_C, drift.offset_mg, -40, 25), slope_per_c(SWEEP_C, drift.offset_mg, 25, 85)
    assert lo == pytest.approx(hi, rel=0.1)


# -- twin side -------------------------------------------------------------------------------------

def test_package_fem_effect_passes_conformance_and_follows_its_parameters():
    from twin.effects.check import check_effect
    from twin.effects.package_fem import PackageFem

    check_effect(PackageFem)
    centred = PackageFem(cell_offset_um=0.0)
    _, offset, _ = centred.tables()
    assert np.max(np.abs(offset)) < 1e-12  # symmetric: no bias
    _, a, _ = PackageFem(cell_offset_um=300.0).tables()
    _, b, _ = PackageFem(cell_offset_um=-300.0).tables()
    assert np.allclose(a, -b, atol=1e-12)


def test_twin_package_cli_reports_tcoff_beside_the_datasheet(tmp_path):
    out = tmp_path / "p.json"
    r = run_cli("package", "scenarios/package_fem.yaml", "--json", str(out))
    assert r.returncode == 0, r.stderr
    res = json.loads(out.read_text())
    check_schema(res, "package")
    assert res["datasheet"]["tcoff_mg_per_c"] == 0.8 and res["mesh"]["dofs"] > 1000
    by_material = sum(res["tcoff_by_material_mg_per_c"].values())
    assert by_material == pytest.approx(res["tcoff_mg_per_c"], rel=0.02)  # small-signal: the split adds up
    assert "TCOff" in r.stdout
    bad = run_cli("package", str(tmp_path / "missing.yaml"))
    assert bad.returncode == 2 and bad.stderr.count("\n") == 1


def test_fem_render_png_and_gif(tmp_path, board):
    iio = pytest.importorskip("imageio.v3")
    from twin.reporting.fem_render import render_fem_png, render_fem_sweep

    imgs = [iio.imread(render_fem_png(board, t, tmp_path / f"f{t}.png")).astype(float) for t in (-40, 85)]
    assert all(img.var() > 100 for img in imgs)  # a blank image has variance 0
    assert np.abs(imgs[0] - imgs[1]).mean() > 1.0
    frames = iio.imread(render_fem_sweep(board, [-40, 20, 85], tmp_path / "s.gif"), index=None)
    assert frames.shape[0] == 3 and not np.array_equal(frames[0], frames[-1])


def test_twin_render_fem_draws_the_solved_field(tmp_path):
    iio = pytest.importorskip("imageio.v3")
    out = tmp_path / "fem.gif"
    r = run_cli("render", str(ROOT / "scenarios" / "package_fem.yaml"), "--fem", "--sweep", "-40:85:62.5",
                "-o", str(out), "--json", "-")
    assert r.returncode == 0, r.stderr
    result = json.loads(r.stdout)
    assert result["field"] == "package_fem" and result["frames"] == 3 and result["exaggeration"] == 50.0
    frames = iio.imread(out, index=None)
    assert frames.shape[0] == 3 and not np.array_equal(frames[0], frames[-1])
