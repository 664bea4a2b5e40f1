"""Datasets with a hidden effect, drawn by a seeded generator, for the diagnosis acceptance tests
and the Monte-Carlo benchmark (docs/diagnosis.md §3.1).

The device = the twin + one hidden module, through the same simulator. Test plan: 25 → 85 → −40 →
25 °C at 1 and 2 °C/min with 30-min dwells, two runs (+1 g, −1 g), a power cycle in each run,
logged at 1 Hz; noise stack: white (218 µg/√Hz), Gauss–Markov bias instability, 0.98 mg
quantisation, thermometer noise, a turn-on bias per run. Forms are mismatched on purpose where
the case says so (two-node lag, two-term creep, off-grid τ, a cubic scale-factor tempco against the
linear + quadratic candidate, logarithmic settling against the linear aging rate). The case names
given to files are neutral; the truth stays in memory.
"""

from __future__ import annotations

import hashlib
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import yaml

from twin.measurement import Measurement, from_dataset, write_canonical_csv
from twin.model.scenario import LoadedScenario, parse_scenario
from twin.model.simulate import simulate
from twin.parts import load_part

#: case → family the diagnosis must name (None: nothing to find)
CASES = {
    "none": None,
    "thermal_lag": "thermal_lag",
    "thermal_lag_2node": "thermal_lag",
    "hysteresis": "hysteresis",
    "creep_2term": "hysteresis",
    "scale_factor": "scale_factor",
    "scale_factor_cubic": "scale_factor",
    "aging": "aging",
    "aging_log": "aging",
    "warmup": "warmup",
    "probe_offset": None,
    "scale_factor_one_orientation": None,
    "noise_misspecified": None,
    "out_of_library": None,
    "lag_and_scale_factor": "thermal_lag",
    "thermal_gradient": "thermal_lag",  # stress ∝ dT/dt of its own sign and size: not what a lag predicts
}

#: detectable RMS over σ of the noise on 10-s means (docs/diagnosis.md §3.1 item 7)
LEVEL_BANDS = {"clear": (1.5, 3.0), "marginal": (0.5, 1.0), "sub": (0.1, 0.3)}
#: cases whose hidden term is linear in its amplitudes, so the level can be set exactly
LINEAR_CASES = {"hysteresis", "creep_2term", "thermal_gradient", "scale_factor", "scale_factor_cubic", "aging",
                "aging_log", "warmup"}


def detectable_ratio(m: Measurement, twin: LoadedScenario, hidden_g: np.ndarray, noise_g: np.ndarray,
                     average_s: float = 10.0) -> float:
    """RMS of the hidden term after projecting out what the twin absorbs (offsets, its free
    amplitudes), over the σ of the noise, both on ``average_s`` means (docs/diagnosis.md §3.1 item 7).

    Parameters
    ----------
    m : Measurement
        The dataset.
    twin : LoadedScenario
        The twin's scenario (what it absorbs).
    hidden_g, noise_g : np.ndarray
        The hidden term and the noise in the output, per sample [g].
    average_s : float
        Block length of the means [s].

    Returns
    -------
    float
        Detectable RMS over σ of the noise [1].
    """
    from twin.estimation.linalg import orthonormal_basis
    from twin.estimation.problem import DiagnosisConfig, Problem, design_matrix

    p = Problem(m, DiagnosisConfig(average_s=average_s))
    X, _, _, _ = design_matrix(p, twin.twin_composition())
    Q = orthonormal_basis(p.avg(np.column_stack([p.nuisance, X])))
    h = p.avg(hidden_g)
    h = h - Q @ (Q.T @ h)
    return float(np.sqrt(np.mean(h * h)) / np.std(p.avg(noise_g)))


_PROGRAM = {
    "start_c": 25.0,
    "cycles": 1,
    "steps": [
        {"type": "hold", "dwell_s": 1800},
        {"type": "ramp", "target_c": 85.0, "ramp_c_per_h": 60},
        {"type": "hold", "dwell_s": 1800},
        {"type": "ramp", "target_c": -40.0, "ramp_c_per_h": 120},
        {"type": "hold", "dwell_s": 1800},
        {"type": "ramp", "target_c": 25.0, "ramp_c_per_h": 60},
        {"type": "hold", "dwell_s": 1800},
    ],
}


@dataclass
class Case:
    """One dataset with a hidden effect and its truth (docs/diagnosis.md §3.1).

    Attributes
    ----------
    kind : str
        A key of :data:`CASES`.
    seed : int
    level : str
        ``clear``, ``marginal`` or ``sub`` (:data:`LEVEL_BANDS`).
    family : str or None
        What the diagnosis should name.
    truth : dict
        Drawn parameters, in each one's unit (kept from the diagnosis).
    measurement : Measurement
    noise_only_rms_g : float
        RMS of the noise alone [g].
    twin : LoadedScenario
        The twin's scenario: never holds the hidden effect.
    hidden_g : np.ndarray, optional
        The hidden term in the output [g] (None where it acts through temperature).
    noise_g : np.ndarray, optional
        The noise in the output [g].
    """

    kind: str
    seed: int
    level: str
    family: str | None  # what the diagnosis should name
    truth: dict  # drawn parameters (kept from the diagnosis)
    measurement: Measurement
    noise_only_rms_g: float
    twin: LoadedScenario  # the twin's scenario: never holds the hidden effect
    hidden_g: np.ndarray | None = None  # the hidden term in the output (None where it acts through temperature)
    noise_g: np.ndarray | None = None

    @property
    def file_stem(self) -> str:
        """A neutral file name stem (a hash of kind, seed and level: the truth stays in memory)."""
        return "case_" + hashlib.sha1(f"{self.kind}/{self.seed}/{self.level}".encode()).hexdigest()[:10]

    def write_csv(self, directory: Path) -> Path:
        """Write the measurement as a canonical CSV named :attr:`file_stem`.

        Parameters
        ----------
        directory : Path

        Returns
        -------
        Path
            The file written.
        """
        m = self.measurement
        return write_canonical_csv(Path(directory) / f"{self.file_stem}.csv", m.time_s, m.temperature_c, m.output_g,
                                   m.applied_g, m.run_index, m.power_on)


def _u(rng, lo, hi):
    return float(rng.uniform(lo, hi))


def draw_case(kind: str, seed: int, level: str = "clear", rate_hz: float = 1.0) -> Case:
    """Draw one dataset of ``kind`` (see :data:`CASES`) at ``level`` ('clear' or 'marginal').

    Parameters
    ----------
    kind : str
        A key of :data:`CASES`.
    seed : int
        Seed of the draw and of the simulation.
    level : str
        ``clear``, ``marginal`` or ``sub`` (:data:`LEVEL_BANDS`).
    rate_hz : float
        Logger rate [Hz].

    Returns
    -------
    Case

    Raises
    ------
    ValueError
        An unknown kind or level.
    """
    if kind not in CASES:
        raise ValueError(f"unknown case {kind!r}; cases: {', '.join(CASES)}")
    if level not in ("clear", "marginal", "sub"):
        raise ValueError(f"level must be clear, marginal or sub, got {level!r}")
    rng = np.random.default_rng(np.random.SeedSequence([seed, sum(map(ord, kind)), sum(map(ord, level))]))
    marginal, sub = level == "marginal", level == "sub"
    device = {
        "static_bias_tc": {"tc1_mg_per_c": _u(rng, 0.2, 0.8), "tc2_mg_per_c2": _u(rng, -2e-3, 2e-3)},
        "scale_factor_tc": {"tc1_ppm_per_c": _u(rng, 30, 120)},
    }
    twin_effects = ["static_bias_tc", "scale_factor_tc"]
    sensor = {"turn_on_bias_mg": 0.5}
    thermometer = {"attached_to": "die", "tau_s": 0.0, "noise_c": 0.03, "resolution_c": 0.01}
    lumped = {"board_tau_s": 300.0, "die_tau_s": 20.0}
    test_plan = {"logger_rate_hz": rate_hz, "runs": 2, "run_applied_g": [1.0, -1.0], "power_on_s": [0, 9000]}
    truth: dict = {}
    if kind in ("thermal_lag", "lag_and_scale_factor"):
        tau = _u(rng, 40, 70) if marginal else _u(rng, 120, 400)  # off the twin's grid
        thermometer.update(attached_to="board", tau_s=0.0)
        lumped["die_tau_s"] = tau
        truth["die_tau_s"] = tau
        if kind == "lag_and_scale_factor":
            twin_effects = ["static_bias_tc"]
            device["scale_factor_tc"]["tc1_ppm_per_c"] = 30.0
            truth["scale_factor_tc"] = 30.0
    elif kind == "thermal_lag_2node":  # thermometer in the air: board and die both behind it
        thermometer.update(attached_to="air", tau_s=0.0)
        lumped.update(board_tau_s=_u(rng, 120, 300), die_tau_s=_u(rng, 20, 60))
        truth.update(board_tau_s=lumped["board_tau_s"], die_tau_s=lumped["die_tau_s"])
    elif kind == "hysteresis":
        k = _u(rng, 0.015, 0.025) if sub else _u(rng, 0.06, 0.1) if marginal else _u(rng, 0.2, 0.4)
        device["thermal_hysteresis"] = {"k_mg_per_c": k, "half_width_c": _u(rng, 1.5, 5.0)}
        truth.update(device["thermal_hysteresis"])
    elif kind == "creep_2term":
        device["stress_relaxation"] = {"k1_mg_per_c": _u(rng, 0.03, 0.06), "tau_s": _u(rng, 2500, 9000),
                                       "k2_mg_per_c": _u(rng, 0.01, 0.03), "tau2_s": _u(rng, 15000, 40000)}
        truth.update(device["stress_relaxation"])
    elif kind in ("scale_factor", "scale_factor_one_orientation"):
        twin_effects = ["static_bias_tc"]
        tc = _u(rng, 8, 14) if marginal else _u(rng, 40, 150)
        device["scale_factor_tc"] = {"tc1_ppm_per_c": tc}
        truth["tc1_ppm_per_c"] = tc
        if kind == "scale_factor_one_orientation":
            test_plan["run_applied_g"] = [1.0]
    elif kind == "scale_factor_cubic":  # no cubic term in the library: added to the output below
        twin_effects = ["static_bias_tc"]
        device["scale_factor_tc"] = {"tc1_ppm_per_c": _u(rng, 20, 60)}
        truth.update(tc1_ppm_per_c=device["scale_factor_tc"]["tc1_ppm_per_c"], tc3_ppm_per_c3=_u(rng, 1e-3, 3e-3))
    elif kind == "aging":
        rate = _u(rng, 0.01, 0.015) if sub else _u(rng, 0.04, 0.06) if marginal else _u(rng, 0.12, 0.25)
        device["aging_drift"] = {"rate_mg_per_h": rate}
        truth["rate_mg_per_h"] = rate
    elif kind == "aging_log":  # settling c·ln(1 + t/t0), t0 off the candidate's fixed 3600 s
        device["aging_drift"] = {"rate_mg_per_h": _u(rng, 0.02, 0.06), "log_mg": _u(rng, 0.8, 2.0),
                                 "t0_s": float(np.exp(rng.uniform(np.log(8000), np.log(30000))))}
        truth.update(device["aging_drift"])
    elif kind == "warmup":
        amp = _u(rng, 0.1, 0.15) if sub else _u(rng, 0.35, 0.5) if marginal else _u(rng, 0.8, 1.6)
        device["warmup"] = {"amplitude_mg": amp * (1 if rng.random() < 0.5 else -1), "tau_s": _u(rng, 40, 250)}
        truth.update(device["warmup"])
    elif kind == "thermal_gradient":  # raises the output while heating, where a lag lowers it
        device["thermal_gradient"] = {"coef_mg_per_c_per_min": _u(rng, 1.0, 3.0), "tau_s": _u(rng, 120, 400)}
        truth.update(device["thermal_gradient"])
    elif kind == "probe_offset":
        device["probe_offset"] = {"offset_c": _u(rng, 0.5, 2.0) * (1 if rng.random() < 0.5 else -1)}
        truth.update(device["probe_offset"])
    elif kind == "noise_misspecified":  # 2x stronger, 3x longer-correlated than nominal
        nominal = load_part("IIS328DQ").value("noise_density_ug_per_sqrt_hz")
        sensor.update(noise_density_ug_per_sqrt_hz=2 * nominal, bias_instability_mg=0.1, bias_instability_tau_s=900.0)
    _AMPLITUDE = {"thermal_hysteresis": ["k_mg_per_c"], "stress_relaxation": ["k1_mg_per_c", "k2_mg_per_c"],
                  "scale_factor_tc": ["tc1_ppm_per_c"], "aging_drift": ["rate_mg_per_h", "log_mg"],
                  "warmup": ["amplitude_mg"], "thermal_gradient": ["coef_mg_per_c_per_min"]}
    scenario = {
        "seed": int(seed), "program": _PROGRAM,
        "chamber": {"model": "lumped", "lumped": lumped, "thermometer": thermometer},
        "device": {"sensor": sensor, "effects": device}, "test_plan": test_plan, "twin": {"effects": twin_effects},
    }
    hidden_names = [n for n in device if n not in twin_effects]
    twin_scn = dict(scenario, device={"sensor": sensor, "effects": {}})
    twin = parse_scenario(yaml.safe_dump(twin_scn, sort_keys=False), "<twin>")
    band = LEVEL_BANDS.get(level) if kind in LINEAR_CASES else None
    for attempt in range(2):  # the level is a detectable-RMS ratio: rescale the (linear) amplitude to hit it
        loaded = parse_scenario(yaml.safe_dump(scenario, sort_keys=False), f"<hidden {kind}>")
        ds = simulate(loaded)
        noise = ds["truth/noise_white_g"] + ds["truth/noise_bias_instability_g"] + ds["truth/quantisation_g"]
        hidden = sum((ds[f"truth/effects/{n}_g"] for n in hidden_names), np.zeros(len(ds))) if hidden_names else None
        m = from_dataset(ds)
        if "tc3_ppm_per_c3" in truth:  # the cubic scale-factor term, s3·ΔT³ on the die, odd in g
            cubic = truth["tc3_ppm_per_c3"] * 1e-6 * (ds["temperature/die_c"] - 25.0) ** 3 * m.applied_g
            m.output_g = m.output_g + cubic
            hidden = hidden + cubic
        if band is None or attempt == 1:
            break
        ratio = detectable_ratio(m, twin, hidden, noise)
        target = _u(rng, *band)
        factor = target / ratio if ratio > 0 else 1.0
        for name in hidden_names:
            for amp in _AMPLITUDE.get(name, []):
                if amp in device[name]:
                    device[name][amp] *= factor
                    truth[amp] = device[name][amp]
        if "tc3_ppm_per_c3" in truth:
            truth["tc3_ppm_per_c3"] *= factor
        truth["target_ratio"] = target
    if kind == "out_of_library":  # slow unlogged disturbance (humidity-like), 3-h period, 0.3-0.5 mg
        amp, phase = _u(rng, 0.3, 0.5) * 1e-3, _u(rng, 0, 2 * np.pi)
        hidden = amp * np.sin(2 * np.pi * m.time_s / 10800.0 + phase)
        m.output_g = m.output_g + hidden
        truth.update(amplitude_mg=amp * 1e3)
    return Case(kind, seed, level, CASES[kind], truth, m, float(np.sqrt(np.mean(noise**2))), twin, hidden, noise)
