"""Thermal chain tested as physics: analytic solutions, convergence order, common limits, energy."""

import numpy as np
import pytest
from scipy.optimize import brentq

from sim.program import Hold, Staircase, compile_program
from sim.thermal import (
    ConductionStack,
    Layer,
    LumpedChain,
    Thermometer,
    first_order_lag,
    simulate_chain,
    simulate_network,
    stored_energy_j,
)

AL = dict(conductivity_w_per_mk=167.0, density_kg_per_m3=2700.0, specific_heat_j_per_kgk=896.0)
FR4 = dict(conductivity_w_per_mk=0.3, density_kg_per_m3=1850.0, specific_heat_j_per_kgk=1100.0)


def _slab(cells, h_bottom, h_top, theta=1.0, thickness_mm=10.0, props=FR4):
    return ConductionStack((Layer("slab", thickness_mm, cells=cells, **props),), h_bottom, h_top, theta)


def _centres(stack):
    dx = stack.cells()[0]
    return np.cumsum(dx) - dx / 2


def _diffusivity(props):
    return props["conductivity_w_per_mk"] / (props["density_kg_per_m3"] * props["specific_heat_j_per_kgk"])


def _observed_order(errors, step):
    """Observed order of convergence: least-squares slope of log(error) against log(step)."""
    return np.polyfit(np.log(step), np.log(errors), 1)[0]


def test_first_order_lag_step_matches_exponential():
    # Exact discretisation: a step (held from the second sample) follows 1 - exp(-(t - dt)/tau)
    # up to the first-order-hold ramp over the first interval, i.e. to ~dt/tau.
    dt, tau = 0.1, 30.0
    t = np.arange(0, 300, dt)
    u = np.where(t > 0, 1.0, 0.0)
    y = first_order_lag(u, dt, tau)
    expected = 1 - np.exp(-(t - dt / 2) / tau)
    assert np.max(np.abs(y[1:] - expected[1:])) < 1e-4


def test_first_order_lag_ramp_lags_by_rate_times_tau():
    # docs/physics.md §1.6: steady lag of a first-order element on a ramp = rate x tau.
    dt, tau, rate = 0.1, 100.0, 0.4 / 35
    t = np.arange(0, 3000, dt)
    y = first_order_lag(rate * t, dt, tau)
    assert rate * t[-1] - y[-1] == pytest.approx(rate * tau, rel=1e-6)


@pytest.mark.parametrize("cells", [10, 20, 40, 80])
def test_dirichlet_sine_mode_decays_analytically(cells):
    # T(x, 0) = sin(pi x / L), walls at 0: T = sin(pi x / L) exp(-a pi^2 t / L^2) (Carslaw & Jaeger §3.3).
    stack = _slab(cells, np.inf, np.inf)
    L = stack.thickness_m
    x = _centres(stack)
    a = _diffusivity(FR4)
    t_end = 0.1 * L**2 / a
    C, G, g = stack.matrices()
    y = simulate_network(C, G, g, np.zeros(2), t_end, np.eye(cells), initial_c=np.sin(np.pi * x / L))
    exact = np.sin(np.pi * x / L) * np.exp(-a * np.pi**2 * t_end / L**2)
    # Second-order scheme: error shrinks ~4x per halving; at 10 cells it is ~1 % of the amplitude.
    assert np.max(np.abs(y[-1] - exact)) < 3.0 / cells**2


def test_spatial_convergence_order_dirichlet_and_robin():
    a = _diffusivity(FR4)
    sizes = np.array([8, 16, 32, 64])
    for h_top in (np.inf, 50.0):
        errors = []
        for n in sizes:
            # Adiabatic bottom, top at Dirichlet or convective: eigenmode cos(lam x) with
            # lam L tan(lam L) = Bi (Bi = inf -> lam L = pi/2).
            stack = _slab(n, 0.0, h_top)
            L = stack.thickness_m
            bi = h_top * L / FR4["conductivity_w_per_mk"]
            lam = np.pi / (2 * L) if np.isinf(bi) else brentq(lambda z: z * np.tan(z) - bi, 1e-9, np.pi / 2 - 1e-12) / L
            x = _centres(stack)
            t_end = 0.2 * L**2 / a
            C, G, g = stack.matrices()
            y = simulate_network(C, G, g, np.zeros(2), t_end, np.eye(n), initial_c=np.cos(lam * x))
            errors.append(np.max(np.abs(y[-1] - np.cos(lam * x) * np.exp(-a * lam**2 * t_end))))
        order = _observed_order(np.array(errors), 1.0 / sizes)
        # Cell-centred finite volumes with harmonic face conductance: formally second order.
        assert 1.85 < order < 2.2, (h_top, errors, order)


@pytest.mark.parametrize("theta,expected_order", [(1.0, 1.0), (0.5, 2.0)])
def test_temporal_convergence_order_of_theta_method(theta, expected_order):
    # Same semi-discrete system, exact-in-time reference: only the time error remains.
    stack = _slab(20, 25.0, 25.0, theta=theta, thickness_mm=5.0, props=AL)
    C, G, g = stack.matrices()
    t_end = 2000.0
    t = np.linspace(0, t_end, 4001)
    u_func = lambda tt: 10 * np.sin(2 * np.pi * tt / 1500.0)  # noqa: E731 - smooth input
    ref = simulate_network(C, G, g, u_func(t), t[1], np.eye(20), method="exact")[-1]
    steps = np.array([20, 40, 80, 160])
    errors = []
    for n in steps:
        tt = np.linspace(0, t_end, n + 1)
        errors.append(np.max(np.abs(simulate_network(C, G, g, u_func(tt), tt[1], np.eye(20), method="theta", theta=theta)[-1] - ref)))
    order = _observed_order(np.array(errors), t_end / steps)
    # Backward Euler is still slightly pre-asymptotic at 20 steps (0.94 observed).
    assert abs(order - expected_order) < 0.15, (errors, order)


def test_energy_balance_theta_method_is_exact():
    # The theta-scheme conserves energy discretely: sum C dT = dt * [theta q(k+1) + (1-theta) q(k)],
    # q = g.(u - T) the heat flow in through the convective faces (1^T G = g^T).
    layers = (Layer("fixture", 5, cells=4, **AL), Layer("board", 1.6, cells=6, **FR4))
    for theta in (1.0, 0.5):
        stack = ConductionStack(layers, 25.0, 10.0, theta)
        C, G, g = stack.matrices()
        t = np.arange(0, 4000, 1.0)
        u = np.where(t < 2000, t * 0.01, 20.0)
        T = simulate_network(C, G, g, u, 1.0, np.eye(C.size), method="theta", theta=theta)
        q = (u[:, None] - T) @ g
        e_in = np.sum(theta * q[1:] + (1 - theta) * q[:-1]) * 1.0
        delta_e = stored_energy_j(C, T[-1]) - stored_energy_j(C, T[0])
        assert e_in == pytest.approx(delta_e, rel=1e-10)


def test_energy_balance_lumped_exact_discretisation():
    # Exact solution: the balance holds to the quadrature error of the trapezoid rule on q (O(dt^2)).
    chain = LumpedChain(board_tau_s=300, die_tau_s=20, die_to_board_capacity_ratio=0.1)
    C, G, g = chain.matrices()
    t = np.arange(0, 6000, 0.5)
    u = 20 * np.sin(2 * np.pi * t / 4000)
    T = simulate_network(C, G, g, u, 0.5, np.eye(2))
    q = (u[:, None] - T) @ g
    e_in = np.trapezoid(q, t)
    delta_e = stored_energy_j(C, T[-1]) - stored_energy_j(C, T[0])
    assert e_in == pytest.approx(delta_e, rel=1e-5)


def _paper_program():
    return compile_program(-20, [Hold(1800), Staircase(50, 0.4, 35), Hold(1800)], 1)


def test_lumped_and_1d_agree_at_small_biot_number():
    # A thin Al plate (Bi = h L / k ~ 1e-4) is isothermal: the 1-D stack is one lumped node of
    # tau = rho c L / (h_bottom + h_top). Disagreement should be of order Bi x lag (~1e-4 degC).
    h = 10.0
    props = AL
    stack = ConductionStack((Layer("board", 1.0, cells=3, **props), Layer("die", 1.0, cells=3, **props)), h, h)
    tau = props["density_kg_per_m3"] * props["specific_heat_j_per_kgk"] * stack.thickness_m / (2 * h)
    chain = LumpedChain(board_tau_s=tau, die_tau_s=1e-3, die_to_board_capacity_ratio=1e-6)
    prog = _paper_program()
    t = np.arange(0, prog.duration_s, 1.0)
    sp = prog.setpoint_c(t)
    r1 = simulate_chain(t, sp, 60.0, chain, Thermometer(attached_to="die", tau_s=0))
    r2 = simulate_chain(t, sp, 60.0, stack, Thermometer(attached_to="die", tau_s=0))
    lag = np.max(np.abs(r1.air_c - r1.die_c))
    assert lag > 1.0  # the comparison is not trivial: the plate lags the air by degrees
    assert np.max(np.abs(r1.die_c - r2.die_c)) < 2e-3 * lag
    # ... and at Bi ~ 0.5 (FR-4 10 mm, h = 50) the two fidelities visibly part.
    thick = ConductionStack((Layer("board", 5.0, cells=8, **FR4), Layer("die", 5.0, cells=8, **FR4)), 50.0, 50.0)
    tau2 = FR4["density_kg_per_m3"] * FR4["specific_heat_j_per_kgk"] * thick.thickness_m / 100.0
    r3 = simulate_chain(t, sp, 60.0, LumpedChain(tau2, 1e-3, 1e-6), Thermometer(attached_to="die", tau_s=0))
    r4 = simulate_chain(t, sp, 60.0, thick, Thermometer(attached_to="die", tau_s=0))
    assert np.max(np.abs(r3.die_c - r4.die_c)) > 0.05


def test_thermometer_on_die_without_lag_reads_die():
    prog = _paper_program()
    t = np.arange(0, prog.duration_s, 0.1)
    r = simulate_chain(t, prog.setpoint_c(t), 60.0, LumpedChain(), Thermometer(attached_to="die", tau_s=0.0))
    np.testing.assert_array_equal(r.probe_c, r.die_c)


def test_die_lags_board_thermometer_during_ramps_and_settles_in_dwells():
    prog = _paper_program()
    t = np.arange(0, prog.duration_s, 0.1)
    chain = LumpedChain(board_tau_s=300, die_tau_s=20)
    r = simulate_chain(t, prog.setpoint_c(t), 60.0, chain, Thermometer(attached_to="board", tau_s=2.0))
    heating = (t > 1800 + 2000) & (t < 1800 + 5000)
    lag = r.probe_c[heating] - r.die_c[heating]
    # heating: die behind the probe by ~ rate x (die_tau - probe_tau) = 0.0114 x 18 = 0.21 degC
    assert np.median(lag) == pytest.approx(0.4 / 35 * 18, rel=0.1)
    assert abs(r.probe_c[-1] - r.die_c[-1]) < 1e-3


def test_coarse_thermal_step_matches_fine():
    prog = _paper_program()
    t = np.arange(0, prog.duration_s, 0.1)
    sp = prog.setpoint_c(t)
    fine = simulate_chain(t, sp, 60.0, LumpedChain(), Thermometer())
    coarse = simulate_chain(t, sp, 60.0, LumpedChain(), Thermometer(), thermal_step_s=1.0)
    # Step edges decimated to 1 s shift the 60-s air node by <= 0.4 degC x 0.9 s / 60 s.
    assert np.max(np.abs(fine.die_c - coarse.die_c)) < 0.4 * 0.9 / 60
