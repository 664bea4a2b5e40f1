"""The tests a chamber can run: its limits, one candidate test program, and the candidates within a
time budget (docs/plan.md §2).

A candidate is one of three shapes, each ending back at the start temperature (the reference
revisited: aging and creep leave a closure error there):

* ``cycles``: a cycle between two set-points — hold, ramp up, hold, ramp down, hold — repeated,
  each repetition at its own ramp rate;
* ``loops``: one such cycle, then partial loops about the middle of the range at a slow and a fast
  rate with short holds — many reversals for a memory of the temperature path (hysteresis), two
  rates for what grows with the rate (a gradient);
* ``soak``: one hold at the start temperature — what drifts with time alone (aging) against what
  follows each power-on (warm-up), with no tempco in the way.

The orientation is one of ``fixed`` (+1 g throughout), ``flip`` (one run at +1 g, one at −1 g: the
runs share the budget) or ``tumble`` (+1 g and −1 g in blocks within one run); power-ons are spread
evenly through each run. The logger rate is a factor of the plan's finalists
(:meth:`ChamberLimits.logger_rates`), not of the candidates.
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
#: spans of the partial loops [°C]: beyond twice a play half-width of up to 8 °C (the screening
#: grid's widest) plus what the board's lag takes off a fast reversal
LOOP_SPANS_C = (30.0, 60.0)
#: hold at each turn of a loop [s]: two board time constants, so the die turns at the set-point
LOOP_DWELL_S = 600.0
#: logger rates tried, as multiples of the chamber file's rate: the diagnosis judges an effect on
#: 10-s means, whose white noise falls as 1/√(samples per mean), while the sensor's bias
#: instability does not (a faster log can hand the screen's random-walk retest a slow effect).
#: Up to 10×: 1 → 10 Hz is PX4's thermal-calibration logging rate, and a 0.1-mg hysteresis needs
#: it to pass the held-out gain (docs/plan.md §2)
LOGGER_RATE_FACTORS = (1.0, 2.0, 3.0, 5.0, 10.0)


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
    logger_rate_hz: float = Field(1.0, gt=0.0, le=1000.0, description="logger rate of the planned test, the "
                                  "slowest tried [Hz]")
    max_logger_rate_hz: float | None = Field(None, gt=0.0, le=1000.0, description="fastest logger rate the plan may "
                                             "ask for [Hz] (default: 10 × logger_rate_hz)")

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
        if self.max_logger_rate_hz is not None and self.max_logger_rate_hz < self.logger_rate_hz:
            raise ValueError(f"max_logger_rate_hz {self.max_logger_rate_hz:g} is below logger_rate_hz "
                             f"{self.logger_rate_hz:g}")
        return self

    def logger_rates(self, odr_hz: float | None = None) -> list[float]:
        """The logger rates a finalist is tried at: :data:`LOGGER_RATE_FACTORS` × ``logger_rate_hz``
        up to ``max_logger_rate_hz`` and the sensor's output data rate.

        Parameters
        ----------
        odr_hz : float, optional
            The sensor's output data rate [Hz]: a faster log repeats samples.

        Returns
        -------
        list of float
            Ascending, the chamber file's rate first [Hz].
        """
        top = LOGGER_RATE_FACTORS[-1] * self.logger_rate_hz if self.max_logger_rate_hz is None else self.max_logger_rate_hz
        if odr_hz is not None:
            top = min(top, max(float(odr_hz), self.logger_rate_hz))
        return sorted({self.logger_rate_hz} | {self.logger_rate_hz * f for f in LOGGER_RATE_FACTORS
                                               if self.logger_rate_hz * f <= top + 1e-9})


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
        Hold at each set-point [s] (a soak: the whole run).
    cycles : int
        Up-down cycles per run (0 with no loops: a soak).
    orientation : str
        ``fixed``, ``flip`` or ``tumble``.
    power_ons : int
        Power-ons per run, evenly spread.
    logger_rate_hz : float
    loops : int
        Partial loops after the cycles.
    loop_low_c, loop_high_c : float
        Set-points of the loops [°C].
    loop_ramp_c_per_h : tuple of float
        Ramp rate of each loop, cycling [°C/h].
    loop_dwell_s : float
        Hold at each turn of a loop [s].
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
    loops: int = 0
    loop_low_c: float = 0.0
    loop_high_c: float = 0.0
    loop_ramp_c_per_h: tuple[float, ...] = ()
    loop_dwell_s: float = LOOP_DWELL_S

    @property
    def shape(self) -> str:
        """``cycles``, ``loops`` or ``soak``."""
        return "loops" if self.loops else "cycles" if self.cycles else "soak"

    def steps(self) -> list[dict]:
        """The program steps of one run (``program.steps`` of a scenario)."""
        out = [{"type": "hold", "dwell_s": self.dwell_s}]
        if self.shape == "soak":
            return out
        out += _turns(self.high_c, self.low_c, self.ramp_c_per_h, self.dwell_s, self.cycles)
        out += _turns(self.loop_high_c, self.loop_low_c, self.loop_ramp_c_per_h, self.loop_dwell_s, self.loops)
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
        """A one-line description, e.g. ``2 cycles -40/85 °C at 30, 240 °C/h, 1 h dwells, flip, 3 power-ons
        per run, logged at 1 Hz``."""
        tail = (f"{self.orientation}, {self.power_ons} power-on{'s' * (self.power_ons > 1)} per run, "
                f"logged at {self.logger_rate_hz:g} Hz")
        if self.shape == "soak":
            return f"soak at {self.start_c:g} °C for {self.dwell_s / 3600:.3g} h, {tail}"
        rates = ", ".join(f"{r:g}" for r in self.ramp_c_per_h)
        text = (f"{self.cycles} cycle{'s' * (self.cycles > 1)} {self.low_c:g}/{self.high_c:g} °C at {rates} °C/h, "
                f"{self.dwell_s / 3600:g} h dwells, ")
        if self.loops:
            loop_rates = ", ".join(f"{r:g}" for r in self.loop_ramp_c_per_h)
            text += (f"then {self.loops} loops {self.loop_low_c:g}/{self.loop_high_c:g} °C at {loop_rates} °C/h, "
                     f"{self.loop_dwell_s / 60:g} min turns, ")
        return text + tail


def _turns(high_c: float, low_c: float, rates: tuple[float, ...], dwell_s: float, count: int) -> list[dict]:
    """``count`` up-down cycles between ``low_c`` and ``high_c``, each at the next rate, a hold at each turn."""
    out: list[dict] = []
    for k in range(count):
        rate = rates[k % len(rates)]
        out += [{"type": "ramp", "target_c": high_c, "ramp_c_per_h": rate}, {"type": "hold", "dwell_s": dwell_s},
                {"type": "ramp", "target_c": low_c, "ramp_c_per_h": rate}, {"type": "hold", "dwell_s": dwell_s}]
    return out


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
    """Every candidate test within ``budget_h`` chamber hours, at the chamber file's logger rate:

    * cycles: each rate set, dwell, orientation and power-on count at the most cycles that fit (more
      cycles at one design never separate less);
    * loops: one cycle at each single rate and dwell of an hour or less, then the most partial loops
      of each span that fit, at a third of the fastest rate and the fastest, each orientation, one
      power-on per run (a memory of the path, not of a power-on, is what loops show);
    * soak: the whole budget at the start temperature, each orientation and power-on count.

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
    rate_sets = _rate_sets(limits)
    for rates, dwell, orient, pons in itertools.product(rate_sets, DWELLS_S, limits.orientations, power):
        if orient == "tumble" and dwell < TUMBLE_BLOCK_S:
            continue  # a dwell shorter than a block would not see both orientations
        test = lambda n: PlannedTest(limits.min_c, limits.max_c, start, rates, dwell, n, orient, pons,  # noqa: E731
                                     limits.logger_rate_hz)
        best = _most_that_fit(test, budget_h, 12)
        if best is not None and best.cycles >= len(rates):  # every rate of the set is run
            out.append(best)
    fast = limits.max_ramp_c_per_h
    loop_rates = tuple(sorted({max(fast / 3.0, limits.min_ramp_c_per_h), fast}))
    mid = 0.5 * (limits.min_c + limits.max_c)
    for (rate,), dwell, span, orient in itertools.product([r for r in rate_sets if len(r) == 1], DWELLS_S[1:3],
                                                          LOOP_SPANS_C, limits.orientations):
        half = 0.5 * min(span, limits.max_c - limits.min_c)
        test = lambda n: PlannedTest(limits.min_c, limits.max_c, start, (rate,), dwell, 1, orient, 1,  # noqa: E731
                                     limits.logger_rate_hz, n, mid - half, mid + half, loop_rates)
        best = _most_that_fit(test, budget_h, 100)
        if best is not None and best.loops >= len(loop_rates):
            out.append(best)
    if not out:  # not one cycle fits: too short a budget for a chamber test (the error says what one needs)
        return []
    for orient, pons in itertools.product(limits.orientations, power):
        runs = 2 if orient == "flip" else 1
        out.append(PlannedTest(limits.min_c, limits.max_c, start, (fast,), budget_h * 3600.0 / runs, 0, orient, pons,
                               limits.logger_rate_hz))
    return sorted(out, key=PlannedTest.label)


def _most_that_fit(test, budget_h: float, most: int) -> PlannedTest | None:
    """``test(n)`` at the largest n in 1..``most`` within ``budget_h`` (None when n = 1 does not fit)."""
    best = None
    for n in range(1, most + 1):
        p = test(n)
        if p.hours() > budget_h + 1e-9:
            break
        best = p
    return best
