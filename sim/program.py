"""Chamber temperature program: hold, ramp and staircase steps, repeated in cycles.

The program is compiled once into segments, each linear or a staircase in time, so the set-point
is evaluated for any array of times without a Python loop per sample.

References
----------
Qi et al. (2022), Micromachines 13, 2156, §2.2.1: hold −20 °C 1 h, heat to 50 °C "0.4 °C every
35 s" (41 °C/h), hold 1 h, cool at the same rate.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np


class ProgramError(ValueError):
    """A chamber program that cannot be run (e.g. a ramp that never reaches its target).

    Parameters
    ----------
    message : str
        What is wrong.
    step_index : int, optional
        Zero-based index of the offending step, when there is one (kept as ``step_index``).
    """

    def __init__(self, message: str, step_index: int | None = None) -> None:
        super().__init__(message)
        self.step_index = step_index


@dataclass(frozen=True)
class Hold:
    """Hold the set-point for ``dwell_s``; ``target_c`` (optional) steps to a new value first.

    Attributes
    ----------
    dwell_s : float
        Hold time [s].
    target_c : float or None
        New set-point [°C] stepped to before the hold; None keeps the current one.
    """

    dwell_s: float
    target_c: float | None = None


@dataclass(frozen=True)
class Ramp:
    """Linear ramp to ``target_c`` at ``ramp_c_per_h`` (magnitude, or signed towards the target).

    Attributes
    ----------
    target_c : float
        Final set-point [°C].
    ramp_c_per_h : float
        Ramp rate [°C/h].
    """

    target_c: float
    ramp_c_per_h: float


@dataclass(frozen=True)
class Staircase:
    """Steps of ``step_c`` every ``step_s`` until ``target_c`` (the paper's 0.4 °C every 35 s).

    The first level is the starting temperature, held ``step_s``; the target is reached after
    ``ceil(|Δ| / step_c)`` steps, the last one partial if ``step_c`` does not divide ``Δ``.

    Attributes
    ----------
    target_c : float
        Final set-point [°C].
    step_c : float
        Size of one step [°C], > 0.
    step_s : float
        Time per step [s], > 0.

    References
    ----------
    Qi et al. (2022), Micromachines 13, 2156, §2.2.1 (0.4 °C every 35 s).
    """

    target_c: float
    step_c: float
    step_s: float


Step = Hold | Ramp | Staircase


@dataclass(frozen=True)
class Segment:
    """One compiled piece of the program: set-point from ``t0_s`` to ``t1_s``.

    Attributes
    ----------
    t0_s, t1_s : float
        Start and end time [s].
    start_c, end_c : float
        Set-point at the start and at the end [°C].
    kind : {"hold", "ramp", "staircase"}
        Shape of the set-point in the segment.
    step_c : float
        Staircase step [°C] (0 otherwise).
    step_s : float
        Staircase step time [s] (0 otherwise).
    cycle : int
        Zero-based program cycle.
    index : int
        Zero-based index of the step in the cycle.
    """

    t0_s: float
    t1_s: float
    start_c: float
    end_c: float
    kind: str  # "hold" | "ramp" | "staircase"
    step_c: float = 0.0
    step_s: float = 0.0
    cycle: int = 0
    index: int = 0


@dataclass(frozen=True)
class ChamberProgram:
    """A compiled program: contiguous segments starting at t = 0.

    Attributes
    ----------
    segments : tuple of Segment
        The segments, in time order.
    start_c : float
        Set-point at t = 0 [°C].
    """

    segments: tuple[Segment, ...]
    start_c: float

    @property
    def duration_s(self) -> float:
        """Total duration of the program [s]."""
        return self.segments[-1].t1_s if self.segments else 0.0

    def setpoint_c(self, t_s: np.ndarray) -> np.ndarray:
        """Chamber set-point [°C] at times ``t_s`` [s] (held at the last value after the end).

        Parameters
        ----------
        t_s : ndarray
            Times [s].

        Returns
        -------
        ndarray
            Set-point [°C].
        """
        return setpoint_c(self, t_s)

    def segment_index(self, t_s: np.ndarray) -> np.ndarray:
        """Index of the segment each time falls in (the last one after the end).

        Parameters
        ----------
        t_s : ndarray
            Times [s].

        Returns
        -------
        ndarray of int
            Index into ``segments``.
        """
        starts = np.array([s.t0_s for s in self.segments])
        return np.clip(np.searchsorted(starts, np.asarray(t_s, float), side="right") - 1, 0, len(starts) - 1)


def compile_program(start_c: float, steps: list[Step], cycles: int = 1) -> ChamberProgram:
    """Compile steps, repeated ``cycles`` times, into time segments.

    Parameters
    ----------
    start_c : float
        Set-point at t = 0 [°C]; the chamber and device start in equilibrium there.
    steps : list of Hold, Ramp, Staircase
        One cycle of the program.
    cycles : int
        How many times the steps are repeated.

    Raises
    ------
    ProgramError
        A non-finite number, a non-positive dwell or step time, a zero step, or a ramp whose signed rate points away
        from its target (it would never get there). ``steps[i]`` in the message is zero-based.

    Returns
    -------
    ChamberProgram
        The compiled segments.
    """
    if cycles < 1:
        raise ProgramError(f"cycles must be >= 1, got {cycles}")
    if not steps:
        raise ProgramError("program has no steps")
    if not math.isfinite(start_c):
        raise ProgramError(f"start_c must be a finite temperature, got {start_c}")
    for i, step in enumerate(steps):  # NaN passes every "> 0" test the wrong way: refuse it first
        for name, v in vars(step).items():
            if v is not None and not math.isfinite(v):
                raise ProgramError(f"steps[{i}].{name} must be finite, got {v}", i)
    segments: list[Segment] = []
    t, temp = 0.0, float(start_c)
    for cycle in range(cycles):
        for i, step in enumerate(steps):
            where = f"steps[{i}]"
            if isinstance(step, Hold):
                if not step.dwell_s > 0:
                    raise ProgramError(f"{where}.dwell_s must be > 0 s, got {step.dwell_s}", i)
                if step.target_c is not None:
                    temp = float(step.target_c)
                segments.append(Segment(t, t + step.dwell_s, temp, temp, "hold", cycle=cycle, index=i))
                t += step.dwell_s
            elif isinstance(step, Ramp):
                delta = step.target_c - temp
                rate = step.ramp_c_per_h
                # A positive rate is a magnitude; a negative one is signed and must point at the target.
                if rate == 0 or (rate < 0 < delta):
                    raise ProgramError(
                        f"{where}: ramp at {rate} °C/h from {temp:g} °C never reaches target_c {step.target_c:g} °C", i
                    )
                duration = abs(delta) / abs(rate) * 3600.0
                if duration == 0:
                    continue
                segments.append(Segment(t, t + duration, temp, step.target_c, "ramp", cycle=cycle, index=i))
                t += duration
                temp = float(step.target_c)
            elif isinstance(step, Staircase):
                if not step.step_c > 0:
                    raise ProgramError(f"{where}.step_c must be > 0 °C, got {step.step_c}", i)
                if not step.step_s > 0:
                    raise ProgramError(f"{where}.step_s must be > 0 s, got {step.step_s}", i)
                delta = step.target_c - temp
                n_steps = math.ceil(abs(delta) / step.step_c - 1e-9)
                if n_steps == 0:
                    continue
                duration = n_steps * step.step_s
                segments.append(
                    Segment(t, t + duration, temp, step.target_c, "staircase", step.step_c, step.step_s, cycle, i)
                )
                t += duration
                temp = float(step.target_c)
            else:  # pragma: no cover - guarded by the scenario schema
                raise ProgramError(f"{where}: unknown step {step!r}")
    return ChamberProgram(tuple(segments), float(start_c))


def setpoint_c(program: ChamberProgram, t_s: np.ndarray) -> np.ndarray:
    """Evaluate the set-point [°C] of a compiled program at times ``t_s`` [s], vectorised.

    Parameters
    ----------
    program : ChamberProgram
        The compiled program.
    t_s : ndarray
        Times [s]; after the end the last value is held.

    Returns
    -------
    ndarray
        Set-point [°C].
    """
    t = np.asarray(t_s, dtype=float)
    seg = program.segments
    idx = program.segment_index(t)
    t0 = np.array([s.t0_s for s in seg])[idx]
    t1 = np.array([s.t1_s for s in seg])[idx]
    c0 = np.array([s.start_c for s in seg])[idx]
    c1 = np.array([s.end_c for s in seg])[idx]
    kind_stair = np.array([s.kind == "staircase" for s in seg])[idx]
    step_c = np.array([s.step_c for s in seg])[idx]
    step_s = np.array([s.step_s for s in seg])[idx]
    tau = np.clip(t - t0, 0.0, t1 - t0)
    frac = np.divide(tau, t1 - t0, out=np.zeros_like(tau), where=(t1 > t0))
    linear = c0 + (c1 - c0) * frac
    n_done = np.floor(np.divide(tau, step_s, out=np.zeros_like(tau), where=step_s > 0) + 1e-9)
    stair = c0 + np.sign(c1 - c0) * np.minimum(n_done * step_c, np.abs(c1 - c0))
    return np.where(kind_stair, stair, linear)


def segment_kind(program: ChamberProgram, t_s: np.ndarray) -> np.ndarray:
    """Per-sample label: 0 dwell, +1 heating, −1 cooling (by the set-point's direction).

    Parameters
    ----------
    program : ChamberProgram
        The compiled program.
    t_s : ndarray
        Times [s].

    Returns
    -------
    ndarray of int8
        −1, 0 or +1 per time.
    """
    idx = program.segment_index(t_s)
    direction = np.array([np.sign(s.end_c - s.start_c) for s in program.segments], dtype=np.int8)
    return direction[idx]
