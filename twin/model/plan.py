"""The test plan of a scenario file (``test_plan``: logger, orientations, power-ons, runs) and
:class:`Scenario`, the whole file, which holds it with the sections of :mod:`twin.model.sections`.

Pydantic models as there: types, bounds, unknown-key errors and the JSON Schema (``twin schema``);
every key is documented in ``docs/scenario.md``.
"""

from __future__ import annotations

import math
from typing import Literal

from pydantic import Field, field_validator, model_validator

from twin.model.sections import (
    AXES,
    AccelerationG,
    ChamberSection,
    DeviceSection,
    NonNegativeFloat,
    OutputSection,
    PositiveFloat,
    ProgramSection,
    Section,
    TwinSection,
)

GRAVITY_TOLERANCE = 0.01  # |gravity_g| must be 1 within this [g]
POSITIONS = {f"{sign}{a}": tuple(float(sign + "1") if b == a else 0.0 for b in AXES) for a in AXES for sign in "+-"}
Position = Literal["+x", "-x", "+y", "-y", "+z", "-z"]


class OrientationSection(Section):
    """An orientation from ``at_s`` [s] on: ``applied_g`` [g] (one axis) or ``gravity_g`` [g] (three)."""
    at_s: NonNegativeFloat = Field(description="time from the start of each run [s]")
    applied_g: AccelerationG | None = Field(None, description="one-axis device: acceleration along the sensing axis from "
                                                      "then on [g]")
    gravity_g: list[float] | None = Field(None, description="three-axis device: gravity seen by the axes x, y, z from "
                                                            "then on (a unit vector) [g]")

    @field_validator("gravity_g")
    @classmethod
    def _unit_vector(cls, v: list[float] | None) -> list[float] | None:
        if v is None:
            return v
        if len(v) != 3:
            raise ValueError(f"needs three components [gx, gy, gz] in g, got {len(v)}")
        norm = math.sqrt(sum(c * c for c in v))
        if not abs(norm - 1.0) <= GRAVITY_TOLERANCE:
            raise ValueError(f"|gravity_g| = {norm:.4g} g; a gravity vector must have unit length "
                             f"(1 ± {GRAVITY_TOLERANCE:g} g), e.g. [0, 0, 1]")
        return v

    @model_validator(mode="after")
    def _one_of_applied_or_gravity(self) -> OrientationSection:
        if (self.applied_g is None) == (self.gravity_g is None):
            raise ValueError("give one of applied_g [g] (one-axis device) or gravity_g [gx, gy, gz] (three-axis "
                             f"device, device.axes); got {'both' if self.applied_g is not None else 'neither'}")
        return self


class TumbleSection(Section):
    """Orientation blocks repeated through each run (+1 g, −1 g, 0 g tumble)."""

    block_s: PositiveFloat = Field(description="time in each orientation [s]")
    applied_g: list[AccelerationG] = Field(min_length=1, description="the cycle of orientations [g]")


class SixPositionSection(Section):
    """Gravity along each sensor axis in turn, blocks of ``block_s`` repeated through each run."""

    block_s: PositiveFloat = Field(description="time in each position [s], the turn into it included")
    turn_s: NonNegativeFloat = Field(10.0, description="time to turn into the next position [s]; gravity rotates at a "
                                                       "constant rate from one position to the next")
    order: list[Position] = Field(default_factory=lambda: list(POSITIONS),
                                  description="the cycle of positions: +x points up, reads +1 g, ... (all six)")

    @field_validator("order")
    @classmethod
    def _all_six(cls, v: list[str]) -> list[str]:
        missing = [p for p in POSITIONS if p not in v]
        if missing:
            raise ValueError(f"must hold all six positions {', '.join(POSITIONS)}; missing {', '.join(missing)}")
        return v

    @model_validator(mode="after")
    def _turn_within_block(self) -> SixPositionSection:
        if self.turn_s >= self.block_s:
            raise ValueError(f"turn_s {self.turn_s:g} s must be shorter than block_s {self.block_s:g} s")
        return self


class TestPlanSection(Section):
    """Logger, orientations, power-ons and runs of the test (``test_plan``)."""
    logger_rate_hz: PositiveFloat = 10.0
    logger_mode: Literal["latest", "average"] = "latest"
    orientations: list[OrientationSection] = Field(default_factory=lambda: [OrientationSection(at_s=0.0, applied_g=1.0)])
    power_on_s: list[NonNegativeFloat] = Field(default_factory=lambda: [0.0], description="power-on times in each run [s]")
    runs: int = Field(1, ge=1, le=100_000, description="independent runs of the program (same device, new noise)")
    tumble: TumbleSection | None = Field(None, description="cyclic orientation blocks, instead of orientations")
    run_applied_g: list[AccelerationG] | None = Field(None, min_length=1,
                                              description="one constant orientation per run, cycling (e.g. [1, -1])")
    six_position: SixPositionSection | None = Field(None, description="three-axis device: gravity along +x, -x, ... "
                                                                      "in blocks, instead of orientations")

    @model_validator(mode="after")
    def _one_orientation_source(self) -> TestPlanSection:
        given = [k for k in ("orientations", "tumble", "run_applied_g")
                 if k in self.model_fields_set and getattr(self, k) is not None]
        if self.six_position is not None and given:
            raise ValueError(f"six_position and {', '.join(given)}: give one orientation source (six_position "
                             "cycles gravity vectors as tumble cycles applied_g)")
        if len(given) > 1:
            raise ValueError(f"give one of orientations, tumble, run_applied_g; got {', '.join(given)}")
        return self

    def orientation_schedule(self, duration_s: float) -> tuple[list[float], list[float]]:
        """(at_s, applied_g) of the orientation steps in one run.

        Parameters
        ----------
        duration_s : float
            Run duration [s].

        Returns
        -------
        tuple of list of float
            Step times [s] and the acceleration applied along the axis from then on [g]; the
            tumble blocks repeated to cover the run when ``tumble`` is given.
        """
        if self.tumble is None:
            return [o.at_s for o in self.orientations], [o.applied_g for o in self.orientations]
        n = int(duration_s // self.tumble.block_s) + 1
        values = self.tumble.applied_g
        return [k * self.tumble.block_s for k in range(n)], [values[k % len(values)] for k in range(n)]

    def gravity_schedule(self, duration_s: float) -> tuple[list[float], list[tuple[float, float, float]]]:
        """(at_s, gravity_g) of the orientation steps in one run of a three-axis device.

        Parameters
        ----------
        duration_s : float
            Run duration [s].

        Returns
        -------
        tuple of list
            Step times [s] and gravity [g] from then on; +z up ([0, 0, 1]) given no orientation.
        """
        if self.six_position is not None:
            six = self.six_position
            n = int(duration_s // six.block_s) + 1
            return [k * six.block_s for k in range(n)], [POSITIONS[six.order[k % len(six.order)]] for k in range(n)]
        if "orientations" not in self.model_fields_set:
            return [0.0], [POSITIONS["+z"]]
        return [o.at_s for o in self.orientations], [tuple(o.gravity_g) for o in self.orientations]

    @field_validator("orientations")
    @classmethod
    def _sorted(cls, v: list[OrientationSection]) -> list[OrientationSection]:
        if not v:
            raise ValueError("needs at least one orientation")
        times = [o.at_s for o in v]
        same = [t for a, t in zip(times, times[1:]) if a == t]
        if same:  # one would silently win
            raise ValueError(f"two orientations at the same instant at_s {same[0]:g} s; give each instant once")
        if times != sorted(times):
            raise ValueError("orientations must be in increasing at_s")
        return v


class Scenario(Section):
    """A thermal-chamber test scenario."""

    seed: int = Field(0, ge=0, le=2**63 - 1, description="seed of every random draw (a 64-bit integer)")
    name: str = ""
    description: str = ""
    program: ProgramSection
    chamber: ChamberSection = ChamberSection()
    device: DeviceSection = DeviceSection()
    test_plan: TestPlanSection = TestPlanSection()
    twin: TwinSection = TwinSection()
    output: OutputSection = OutputSection()
