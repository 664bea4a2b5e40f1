"""The tests a chamber can run: its limits, one candidate test program, and the candidates within a
time budget (docs/plan.md §2).

A candidate is a cycle between two set-points — hold, ramp up, hold, ramp down, hold — repeated,
each repetition at its own ramp rate, ending back at the start temperature (the reference revisited:
aging and creep leave a closure error there). The orientation is one of ``fixed`` (+1 g throughout),
``flip`` (one run at +1 g, one at −1 g: the runs share the budget) or ``tumble`` (+1 g and −1 g in
blocks within one run); power-ons are spread evenly through each run.
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass

from pydantic import Field, model_validator

from twin.model.sections import Section

#: ramp rates tried [°C/h]: 0.25 to 4 °C/min, the span of common chamber programs
RAMP_RATES_C_PER_H = (15.0, 30.0, 60.0, 120.0, 240.0)
#: dwell lengths tried [s]: from a short soak to hours (creep time constants are hours)
DWELLS_S = (900.0, 1800.0, 3600.0, 7200.0, 14400.0)
#: tumble block [s]: long against a die lag, short against a thermal cycle
TUMBLE_BLOCK_S = 1200.0


class ChamberLimits(Section):
    """What the chamber and the fixture can do (``--chamber LIMITS.yaml``)."""

    min_c: float = Field(-40.0, ge=-100.0, le=200.0, description="lowest set-point [°C]")
    max_c: float = Field(85.0, ge=-100.0, le=250.0, description="highest set-point [°C]")
    max_ramp_c_per_h: float = Field(180.0, gt=0.0, le=3600.0, description="fastest ramp [°C/h]")
    min_ramp_c_per_h: float = Field(15.0, gt=0.0, le=3600.0, description="slowest ramp worth running [°C/h]")
    orientations: list[str] = Field(default_factory=lambda: ["fixed", "flip", "tumble"],
                                    description="what the fixture allows: fixed, flip (a second run upside down), "
                                                "tumble (+1 g / -1 g blocks within a run)")
    max_power_ons: int = Field(4, ge=1, le=50, description="power-ons per run the setup can switch")
    logger_rate_hz: float = Field(1.0, gt=0.0, le=1000.0, description="logger rate of the planned test [Hz]")

    @model_validator(mode="after")
    def _ordered(self) -> ChamberLimits:
        if self.max_c <= self.min_c + 10.0:
            raise ValueError(f"max_c {self.max_c:g} °C must exceed min_c {self.min_c:g} °C by more than 10 °C")
        if self.min_ramp_c_per_h > self.max_ramp_c_per_h:
            raise ValueError(f"min_ramp_c_per_h {self.min_ramp_c_per_h:g} exceeds max_ramp_c_per_h "
                             f"{self.max_ramp_c_per_h:g}")
        unknown = sorted(set(self.orientations) - {"fixed", "flip", "tumble"})
        if unknown or not self.orientations:
            raise ValueError(f"orientations: expected some of fixed, flip, tumble; got {self.orientations}")
        return self


@dataclass(frozen=True)
class PlannedTest:
    """One candidate chamber test.

    Attributes
    ----------
    low_c, high_c, start_c : float
        Set-points [°C]; the program starts and ends at ``start_c``.
    ramp_c_per_h : tuple of float
        Ramp rate of each cycle, cycling [°C/h].
    dwell_s : float
        Hold at each set-point [s].
    cycles : int
        Up-down cycles per run.
    orientation : str
        ``fixed``, ``flip`` or ``tumble``.
    power_ons : int
        Power-ons per run, evenly spread.
    logger_rate_hz : float
    """

    low_c: float
    high_c: float
    start_c: float
    ramp_c_per_h: tuple[float, ...]
    dwell_s: float
    cycles: int
    orientation: str
    power_ons: int
    logger_rate_hz: float = 1.0

    def steps(self) -> list[dict]:
        """The program steps of one run (``program.steps`` of a scenario)."""
        out = [{"type": "hold", "dwell_s": self.dwell_s}]
        for k in range(self.cycles):
            rate = self.ramp_c_per_h[k % len(self.ramp_c_per_h)]
            out += [{"type": "ramp", "target_c": self.high_c, "ramp_c_per_h": rate},
                    {"type": "hold", "dwell_s": self.dwell_s},
                    {"type": "ramp", "target_c": self.low_c, "ramp_c_per_h": rate},
                    {"type": "hold", "dwell_s": self.dwell_s}]
        out += [{"type": "ramp", "target_c": self.start_c, "ramp_c_per_h": self.ramp_c_per_h[0]},
                {"type": "hold", "dwell_s": self.dwell_s}]
        return out

    @property
    def runs(self) -> int:
        """Runs of the program: two when flipped, else one."""
        return 2 if self.orientation == "flip" else 1

    def run_hours(self) -> float:
        """Duration of one run [h]."""
        return program_hours(self.start_c, self.steps())

    def hours(self) -> float:
        """Chamber time of the whole test, every run [h]."""
        return self.runs * self.run_hours()

    def test_plan(self) -> dict:
        """The scenario's ``test_plan`` section."""
        run_s = self.run_hours() * 3600.0
        plan: dict = {"logger_rate_hz": self.logger_rate_hz, "runs": self.runs,
                      "power_on_s": [round(k * run_s / self.power_ons, 1) for k in range(self.power_ons)]}
        if self.orientation == "flip":
            plan["run_applied_g"] = [1.0, -1.0]
        elif self.orientation == "tumble":
            plan["tumble"] = {"block_s": TUMBLE_BLOCK_S, "applied_g": [1.0, -1.0]}
        return plan

    def program(self) -> dict:
        """The scenario's ``program`` section."""
        return {"start_c": self.start_c, "cycles": 1, "steps": self.steps()}

    def label(self) -> str:
        """A one-line description, e.g. ``2 cycles -40/85 °C at 30, 240 °C/h, 1 h dwells, flip, 3 power-ons``."""
        rates = ", ".join(f"{r:g}" for r in self.ramp_c_per_h)
        return (f"{self.cycles} cycle{'s' * (self.cycles > 1)} {self.low_c:g}/{self.high_c:g} °C at {rates} °C/h, "
                f"{self.dwell_s / 3600:g} h dwells, {self.orientation}, {self.power_ons} power-on"
                f"{'s' * (self.power_ons > 1)} per run")


def program_hours(start_c: float, steps: list[dict], cycles: int = 1) -> float:
    """Duration of a program's steps [h] (holds plus ramps at their rates).

    Parameters
    ----------
    start_c : float
        Temperature at the start [°C].
    steps : list of dict
        ``hold`` (``dwell_s``) and ``ramp`` (``target_c``, ``ramp_c_per_h``) steps.
    cycles : int
        Repetitions of the steps.

    Returns
    -------
    float
        Hours.
    """
    t_s, temp = 0.0, start_c
    for s in steps:
        if s["type"] == "hold":
            t_s += float(s["dwell_s"])
        else:
            t_s += abs(float(s["target_c"]) - temp) / float(s["ramp_c_per_h"]) * 3600.0
            temp = float(s["target_c"])
    return cycles * t_s / 3600.0


def _rate_sets(limits: ChamberLimits) -> list[tuple[float, ...]]:
    """Single rates and slow/fast pairs within the chamber's limits."""
    rates = sorted({min(max(r, limits.min_ramp_c_per_h), limits.max_ramp_c_per_h)
                    for r in RAMP_RATES_C_PER_H + (limits.max_ramp_c_per_h,)})
    pairs = [(a, b) for a, b in itertools.combinations(rates, 2) if b >= 4 * a]
    return [(r,) for r in rates] + pairs


def candidate_programs(limits: ChamberLimits, budget_h: float, start_c: float = 25.0) -> list[PlannedTest]:
    """Every candidate test within ``budget_h`` chamber hours: each rate set, dwell, orientation and
    power-on count at the most cycles that fit (more cycles at one design never separate less).

    Parameters
    ----------
    limits : ChamberLimits
    budget_h : float
        Chamber hours available, every run included.
    start_c : float
        Start and end temperature [°C], clipped into the limits.

    Returns
    -------
    list of PlannedTest
        Sorted by label; empty when not one cycle fits the budget.
    """
    start = min(max(start_c, limits.min_c), limits.max_c)
    out = []
    power = sorted({1, min(3, limits.max_power_ons), limits.max_power_ons})
    for rates, dwell, orient, pons in itertools.product(_rate_sets(limits), DWELLS_S, limits.orientations, power):
        if orient == "tumble" and dwell < TUMBLE_BLOCK_S:
            continue  # a dwell shorter than a block would not see both orientations
        best = None
        for cycles in range(1, 13):
            p = PlannedTest(limits.min_c, limits.max_c, start, rates, dwell, cycles, orient, pons, limits.logger_rate_hz)
            if p.hours() > budget_h + 1e-9:
                break
            best = p
        if best is not None and best.cycles >= len(rates):  # every rate of the set is run
            out.append(best)
    return sorted(out, key=PlannedTest.label)
