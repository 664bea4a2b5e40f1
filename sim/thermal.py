"""Thermal chain of a chamber test: air → board/fixture → package/die, and a reference thermometer.

Two fidelities share one solver:

* **lumped**: a well-mixed air node following the set-point through the chamber controller
  (first order, ``air_tau_s``), then an RC network board ↔ die;
* **1-D finite volume**: conduction through a layer stack (fixture, board, die, mould) with
  convective faces to the air node, discretised with cell-centred finite volumes and the
  θ-method in time (θ = 1: backward Euler, θ = ½: Crank–Nicolson).

Both are linear time-invariant networks ``C dT/dt = −G T + g u``. With ``C`` diagonal and ``G``
symmetric, ``C^{-1/2} G C^{-1/2} = Q Λ Qᵀ`` decouples them into independent first-order modes,
each stepped by one first-order recursion (:func:`sim.recursion.one_pole`, compiled), so a
590k-sample run needs no Python loop per sample. The lumped network uses the exact discretisation for a piecewise-linear input
(first-order hold); the 1-D network uses the θ-method exactly as an implicit solver would.

References
----------
Incropera & DeWitt, *Fundamentals of Heat and Mass Transfer*, §5.2 (lumped capacitance), §5.10
(finite-difference/finite-volume transient conduction). Patankar (1980), *Numerical Heat Transfer
and Fluid Flow*, §4.2 (harmonic-mean interface conductance). docs/physics.md §1.6, §2.3.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from sim.recursion import first_order_filter


def _mode_coefficients(lam: np.ndarray, dt_s: float, method: str, theta: float) -> tuple[np.ndarray, ...]:
    """Per-mode recursion ``z[k+1] = p z[k] + b1 u[k+1] + b0 u[k]`` for ``dz/dt = −λ z + u``.

    ``exact`` integrates the mode exactly with ``u`` linear between samples (first-order hold);
    ``theta`` is the θ-method.
    """
    lh = lam * dt_s
    if method == "exact":
        p = np.exp(-lh)
        small = lh < 1e-6
        lam_safe = np.where(small, 1.0, lam)
        i0 = np.where(small, dt_s * (1 - lh / 2), -np.expm1(-lh) / lam_safe)  # ∫ e^{-λ(h-s)} ds
        i1 = np.where(small, dt_s * (0.5 - lh / 6), (1 - i0 / dt_s) / lam_safe)  # ∫ e^{-λ(h-s)} s/h ds
        return p, i1, i0 - i1
    if method == "theta":
        den = 1 + theta * lh
        return (1 - (1 - theta) * lh) / den, dt_s * theta / den, dt_s * (1 - theta) / den
    raise ValueError(f"method must be 'exact' or 'theta', got {method!r}")


def simulate_network(capacity: np.ndarray, conductance: np.ndarray, input_conductance: np.ndarray, u: np.ndarray,
                     dt_s: float, outputs: np.ndarray, *, method: str = "exact", theta: float = 1.0,
                     initial_c: np.ndarray | None = None) -> np.ndarray:
    """Response of ``C dT/dt = −G T + g u``, by default from equilibrium at ``u[0]`` (Incropera & DeWitt §5.2, §5.10).

    Parameters
    ----------
    capacity : (n,) array
        Heat capacities C [J/K] (or per area, J/(m² K)).
    conductance : (n, n) array
        Symmetric conductance matrix G [W/K], boundary conductances to the input on its diagonal.
    input_conductance : (n,) array
        Conductance g [W/K] from the input temperature to each node. ``G·1 = g`` is required, so
        that a uniform temperature equal to the input is the steady state.
    u : (N,) array
        Input temperature [°C] sampled every ``dt_s``.
    dt_s : float
        Sample interval [s].
    outputs : (m, n) array
        Each row weights the nodes into one output temperature.
    method : {"exact", "theta"}
    theta : float
        θ of the θ-method (1 backward Euler, 0.5 Crank–Nicolson).
    initial_c : (n,) array, optional
        Node temperatures at ``t = 0`` [°C]; default: all equal to ``u[0]``.

    Returns
    -------
    (N, m) array
        Output temperatures [°C].
    """
    c = np.asarray(capacity, float)
    G = np.asarray(conductance, float)
    g = np.asarray(input_conductance, float)
    if not np.allclose(G.sum(axis=1), g, rtol=1e-9, atol=1e-12 * np.abs(G).max()):
        raise ValueError("conductance rows must sum to the input conductance (equilibrium at the input)")
    s = 1.0 / np.sqrt(c)
    lam, Q = np.linalg.eigh(s[:, None] * G * s[None, :])
    lam = np.clip(lam, 0.0, None)
    beta = Q.T @ (s * g)  # input gain of each mode
    out_modes = np.asarray(outputs, float) @ (s[:, None] * Q)  # (m, n): node weights → modes
    u = np.asarray(u, float)
    du = u - u[0]
    z0 = np.zeros(lam.size) if initial_c is None else Q.T @ (np.sqrt(c) * (np.asarray(initial_c, float) - u[0]))
    p, b1, b0 = _mode_coefficients(lam, dt_s, method, theta)
    y = np.zeros((u.size, out_modes.shape[0]))
    for i in range(lam.size):
        if (beta[i] == 0 and z0[i] == 0) or not np.any(out_modes[:, i]):
            continue
        z = first_order_filter(du, beta[i] * b1[i], beta[i] * b0[i], p[i], z0[i])  # z[0] = z0: du[0] = 0
        y += z[:, None] * out_modes[:, i][None, :]
    return y + u[0]


def first_order_lag(u: np.ndarray, dt_s: float, tau_s: float) -> np.ndarray:
    """Exact response of ``τ dy/dt = u − y`` to a piecewise-linear input, from equilibrium.

    ``tau_s = 0`` returns ``u`` unchanged (an ideal thermal contact). Standard first-order lag.

    Parameters
    ----------
    u : (N,) array
        Input [°C], sampled every ``dt_s``.
    dt_s, tau_s : float
        Sample interval and time constant τ ≥ 0 [s].

    Returns
    -------
    (N,) array
        Response y [°C].
    """
    if tau_s < 0:
        raise ValueError(f"tau_s must be >= 0, got {tau_s}")
    if tau_s == 0:
        return np.asarray(u, float).copy()
    one = np.ones(1)
    return simulate_network(one, one[None, :] / tau_s, one / tau_s, u, dt_s, one[None, :])[:, 0]


@dataclass(frozen=True)
class LumpedChain:
    """Board and die nodes behind the air node.

    Parameters
    ----------
    board_tau_s : float
        C_board / G_air→board [s]: convective time constant of the board/fixture (docs/physics.md
        §1.6: 33–1350 s for a board or an Al fixture at 10–50 W/m² K).
    die_tau_s : float
        C_die / G_board→die [s] (package on board, ≈ 10–90 s).
    die_to_board_capacity_ratio : float
        C_die / C_board; the die's back-reaction on the board.
    board_heat_capacity_j_per_k : float
        C_board [J/K]; sets the absolute scale for heat flows (energy balance), not the temperatures.
    """

    board_tau_s: float = 300.0
    die_tau_s: float = 20.0
    die_to_board_capacity_ratio: float = 0.01
    board_heat_capacity_j_per_k: float = 50.0

    def matrices(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(C, G, g) of the board/die RC network with the air temperature as input (Incropera & DeWitt §5.2).

        Returns
        -------
        C, G, g : ndarray
            Capacities [J/K], conductance matrix [W/K], input conductances [W/K].
        """
        c_b = self.board_heat_capacity_j_per_k
        c_d = c_b * self.die_to_board_capacity_ratio
        g_ab = c_b / self.board_tau_s
        g_bd = c_d / self.die_tau_s
        C = np.array([c_b, c_d])
        G = np.array([[g_ab + g_bd, -g_bd], [-g_bd, g_bd]])
        return C, G, np.array([g_ab, 0.0])

    def node_weights(self) -> dict[str, np.ndarray]:
        """Output weights of the nodes.

        Returns
        -------
        dict of str to ndarray
            ``board`` and ``die`` weights over the two nodes [1].
        """
        return {"board": np.array([1.0, 0.0]), "die": np.array([0.0, 1.0])}


@dataclass(frozen=True)
class Layer:
    """One layer of the conduction stack (bottom to top).

    Attributes
    ----------
    name : str
    thickness_mm, conductivity_w_per_mk, density_kg_per_m3, specific_heat_j_per_kgk : float
        Thickness [mm], λ [W/(m K)], ρ [kg/m³], c [J/(kg K)].
    cells : int
        Finite-volume cells across the layer.
    """

    name: str
    thickness_mm: float
    conductivity_w_per_mk: float
    density_kg_per_m3: float
    specific_heat_j_per_kgk: float
    cells: int = 4

    @property
    def volumetric_heat_capacity_j_per_m3k(self) -> float:
        """ρ c [J/(m³ K)]."""
        return self.density_kg_per_m3 * self.specific_heat_j_per_kgk


@dataclass(frozen=True)
class ConductionStack:
    """A 1-D layer stack, per unit area, with convective faces to the air node.

    ``h = inf`` makes a face isothermal at the air temperature (Dirichlet), ``h = 0`` adiabatic.

    Attributes
    ----------
    layers : tuple of Layer
    h_bottom_w_per_m2k, h_top_w_per_m2k, theta : float
        Face convection coefficients [W/(m² K)]; θ of the time stepping (1 backward Euler, ½ Crank–Nicolson).
    """

    layers: tuple[Layer, ...]
    h_bottom_w_per_m2k: float = 25.0
    h_top_w_per_m2k: float = 25.0
    theta: float = 1.0

    def cells(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """Cell widths, conductivities, volumetric heat capacities and layer index.

        Returns
        -------
        dx, k, rc, layer : ndarray
            [m], [W/(m K)], [J/(m³ K)], index of each cell's layer.
        """
        dx, k, rc, lid = [], [], [], []
        for j, layer in enumerate(self.layers):
            n = int(layer.cells)
            dx += [layer.thickness_mm * 1e-3 / n] * n
            k += [layer.conductivity_w_per_mk] * n
            rc += [layer.volumetric_heat_capacity_j_per_m3k] * n
            lid += [j] * n
        return np.array(dx), np.array(k), np.array(rc), np.array(lid)

    def matrices(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(C, G, g) per unit area: harmonic-mean (series) conductance between cell centres (Patankar §4.2).

        Returns
        -------
        C, G, g : ndarray
            Capacities [J/(m² K)], conductance matrix and input conductances [W/(m² K)].
        """
        dx, k, rc, _ = self.cells()
        n = dx.size
        half_r = dx / (2 * k)  # centre-to-face resistance [m² K/W]
        g_int = 1.0 / (half_r[:-1] + half_r[1:])
        G = np.zeros((n, n))
        idx = np.arange(n - 1)
        G[idx, idx] += g_int
        G[idx + 1, idx + 1] += g_int
        G[idx, idx + 1] -= g_int
        G[idx + 1, idx] -= g_int
        g = np.zeros(n)
        for cell, h in ((0, self.h_bottom_w_per_m2k), (n - 1, self.h_top_w_per_m2k)):
            if h > 0:
                g_b = 1.0 / (half_r[cell] + (0.0 if np.isinf(h) else 1.0 / h))
                G[cell, cell] += g_b
                g[cell] += g_b
        return rc * dx, G, g

    def layer_weights(self, name: str) -> np.ndarray:
        """Heat-capacity-weighted mean over the cells of layer ``name``.

        Parameters
        ----------
        name : str

        Returns
        -------
        ndarray
            Weights over all cells [1], summing to 1.
        """
        names = [layer.name for layer in self.layers]
        if name not in names:
            raise KeyError(f"no layer named {name!r}; layers are {names}")
        dx, _, rc, lid = self.cells()
        w = np.where(lid == names.index(name), rc * dx, 0.0)
        return w / w.sum()

    def node_weights(self) -> dict[str, np.ndarray]:
        """Output weights of every layer (:meth:`layer_weights`).

        Returns
        -------
        dict of str to ndarray
            Weights [1] per layer name.
        """
        names = [layer.name for layer in self.layers]
        return {name: self.layer_weights(name) for name in names}

    @property
    def thickness_m(self) -> float:
        """Total thickness [m]."""
        return sum(layer.thickness_mm for layer in self.layers) * 1e-3


def stored_energy_j(capacity: np.ndarray, temperature_c: np.ndarray, reference_c: float = 0.0) -> np.ndarray:
    """Heat stored relative to ``reference_c``: Σ C_i (T_i − T_ref) [J or J/m²] (sensible heat, standard result).

    Parameters
    ----------
    capacity, temperature_c : ndarray
        Node capacities (n,) [J/K or J/(m² K)] and temperatures (..., n) [°C].
    reference_c : float
        Reference temperature [°C].

    Returns
    -------
    ndarray
        Stored heat [J or J/m²].
    """
    return (np.asarray(temperature_c) - reference_c) @ np.asarray(capacity)


@dataclass(frozen=True)
class Thermometer:
    """Reference thermometer: attached to a node through its own contact time constant.

    ``tau_s = 0`` on the die node means the thermometer reads the die with no lag (a device
    with nothing hidden). Noise, resolution and accuracy are applied by :func:`read_thermometer`.

    Attributes
    ----------
    attached_to : str
    tau_s, noise_c, resolution_c, offset_c, sample_rate_hz : float
        Contact time constant [s]; white-noise σ, resolution, fixed offset [°C]; sample rate [Hz].
    """

    attached_to: str = "board"
    tau_s: float = 2.0
    noise_c: float = 0.01
    resolution_c: float = 0.01
    offset_c: float = 0.0
    sample_rate_hz: float = 10.0


@dataclass
class ThermalResult:
    """Temperatures [°C] on the scenario time base.

    Attributes
    ----------
    time_s, setpoint_c, air_c, board_c, die_c, probe_c : ndarray
        Time [s]; set-point, air, board, die and thermometer-element temperatures [°C].
    extra : dict of str to ndarray
        Other nodes of a stack [°C].
    """

    time_s: np.ndarray
    setpoint_c: np.ndarray
    air_c: np.ndarray
    board_c: np.ndarray
    die_c: np.ndarray
    probe_c: np.ndarray  # true temperature of the thermometer element (before its noise)
    extra: dict[str, np.ndarray] = field(default_factory=dict)


def simulate_chain(time_s: np.ndarray, setpoint: np.ndarray, air_tau_s: float, device: LumpedChain | ConductionStack,
                   thermometer: Thermometer, *, board_node: str = "board", die_node: str = "die",
                   thermal_step_s: float | None = None) -> ThermalResult:
    """Run the thermal chain on a uniform time base.

    Parameters
    ----------
    time_s, setpoint : (N,) array
        Uniform sample times [s] and the chamber set-point [°C] at them.
    air_tau_s : float
        Time constant of the chamber air following its set-point (controller + mixing) [s].
    device : LumpedChain or ConductionStack
        The air → device link.
    thermometer : Thermometer
        Where the reference thermometer sits and its contact time constant.
    board_node, die_node : str
        Names of the board and die nodes (for a stack: layer names).
    thermal_step_s : float, optional
        Coarser step for the thermal solve [s], linearly interpolated back to ``time_s``. The
        temperatures vary on time scales of tens of seconds, so 1 s loses nothing measurable.

    Returns
    -------
    ThermalResult
        Temperatures [°C] on ``time_s``.
    """
    time_s = np.asarray(time_s, float)
    dt = float(time_s[1] - time_s[0]) if time_s.size > 1 else 1.0
    t_solve, u = time_s, np.asarray(setpoint, float)
    if thermal_step_s and thermal_step_s > dt * 1.0001 and time_s.size > 2:
        # Decimate: a 0.4 °C step smeared over 1 s moves a 60-s air node by ≈ 3 mK.
        stride = max(1, int(round(thermal_step_s / dt)))
        t_solve, u, dt = time_s[::stride], u[::stride], dt * stride
    air = first_order_lag(u, dt, air_tau_s)
    C, G, g = device.matrices()
    weights = device.node_weights()
    for name in (board_node, die_node):
        if name not in weights:
            raise KeyError(f"thermal model has no node {name!r}; nodes are {sorted(weights)}")
    if isinstance(device, ConductionStack):
        method, theta = "theta", device.theta
    else:
        method, theta = "exact", 1.0
    host_names = [n for n in weights if n not in (board_node, die_node)]
    out_names = [board_node, die_node] + host_names
    temps = simulate_network(C, G, g, air, dt, np.array([weights[n] for n in out_names]), method=method, theta=theta)
    nodes = {"air": air, **{n: temps[:, i] for i, n in enumerate(out_names)}}
    if thermometer.attached_to not in nodes:
        raise KeyError(f"thermometer.attached_to {thermometer.attached_to!r} is not a node; nodes are {sorted(nodes)}")
    nodes["probe"] = first_order_lag(nodes[thermometer.attached_to], dt, thermometer.tau_s)
    if t_solve is not time_s:
        nodes = {k: np.interp(time_s, t_solve, v) for k, v in nodes.items()}
    return ThermalResult(time_s=time_s, setpoint_c=np.asarray(setpoint, float), air_c=nodes["air"],
                         board_c=nodes[board_node], die_c=nodes[die_node], probe_c=nodes["probe"],
                         extra={k: v for k, v in nodes.items() if k in host_names})


def read_thermometer(time_s: np.ndarray, probe_c: np.ndarray, thermometer: Thermometer,
                     rng: np.random.Generator) -> np.ndarray:
    """What the logger records: sample-and-hold at the thermometer's rate, noise, offset, resolution.

    The paper's system is specified as ±0.03 °C at 10 Hz; the default reads that as a 3σ bound
    on white noise (σ = 0.01 °C) with 0.01 °C resolution and no fixed offset.

    Parameters
    ----------
    time_s, probe_c : (N,) array
        Time [s] and true element temperature [°C].
    thermometer : Thermometer
    rng : numpy.random.Generator

    Returns
    -------
    (N,) array
        Logged temperature [°C].
    """
    time_s = np.asarray(time_s, float)
    t_sample = np.floor(time_s * thermometer.sample_rate_hz + 1e-9) / thermometer.sample_rate_hz
    held_idx = np.clip(np.searchsorted(time_s, t_sample, side="left"), 0, time_s.size - 1)
    value = probe_c[held_idx] + thermometer.offset_c
    _, first = np.unique(t_sample, return_inverse=True)  # one noise draw per thermometer sample, held with the value
    noise = rng.normal(0.0, thermometer.noise_c, first.max() + 1)[first] if thermometer.noise_c > 0 else 0.0
    value = value + noise
    if thermometer.resolution_c > 0:
        value = np.round(value / thermometer.resolution_c) * thermometer.resolution_c
    return value
