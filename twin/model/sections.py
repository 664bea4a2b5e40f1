"""The sections of a scenario file: pydantic models giving types, bounds, unknown-key errors
and the JSON Schema (``twin schema``). Every key is documented in ``docs/scenario.md``. Here:
the shared base and field types, ``program``, ``chamber``, ``device``, ``twin`` and ``output``;
the test plan and the whole :class:`~twin.model.plan.Scenario` are in :mod:`twin.model.plan`.

One source of defaults: where a section mirrors a ``sim`` dataclass (thermometer, lumped chain,
conduction stack and layers, comb geometry, program steps), its defaults are read from that
dataclass's fields (:func:`default_of`), never written twice. The sensor's figures have no
defaults here: they come from the part (``twin/parts/``), the scenario overriding any of them.
"""

from __future__ import annotations

import dataclasses
from typing import Annotated, Any, Literal, Union

from pydantic import AfterValidator, BaseModel, ConfigDict, Field, model_validator

from sim import program as prog
from sim import thermal
from sim.microstructure import CombGeometry
from twin.parts import DEFAULT_PART


def default_of(cls: type, name: str) -> Any:
    """The default of field ``name`` of the dataclass ``cls`` (the one place it is written).

    Parameters
    ----------
    cls : type
        A dataclass (e.g. ``sim.thermal.Thermometer``).
    name : str
        One of its fields.

    Returns
    -------
    Any
        The field's default, or a fresh value of its default factory [the field's unit].
    """
    f = next(f for f in dataclasses.fields(cls) if f.name == name)
    if f.default is not dataclasses.MISSING:
        return f.default
    if f.default_factory is not dataclasses.MISSING:
        return f.default_factory()
    raise TypeError(f"{cls.__name__}.{name} has no default")


# Upper bounds keep every product of the simulation finite; the physical ones are named where they apply.
LARGE = 1e9
PositiveFloat = Annotated[float, Field(gt=0, le=LARGE)]
NonNegativeFloat = Annotated[float, Field(ge=0, le=LARGE), AfterValidator(lambda v: v + 0.0)]  # -0.0 → 0.0 (a σ)
#: Chamber set-points: the silicon model (Okada & Tokumaru 1984) holds from 120 K (−153 °C); 300 °C is beyond any
#: MEMS part's storage rating.
SETPOINT_RANGE_C = (-150.0, 300.0)
SetpointC = Annotated[float, Field(ge=SETPOINT_RANGE_C[0], le=SETPOINT_RANGE_C[1])]
AccelerationG = Annotated[float, Field(ge=-1000.0, le=1000.0)]  # beyond any accelerometer's range [g]
OffsetMg = Annotated[float, Field(ge=-1e4, le=1e4)]  # ±10 g [mg]


class Section(BaseModel):
    """Base of every section: unknown keys, ``.inf``/``.nan`` and changes after validation are refused."""

    model_config = ConfigDict(extra="forbid", frozen=True, allow_inf_nan=False)  # .inf/.nan are refused at the key


# ------------------------------------------------------------------ program


class HoldStep(Section):
    """Hold the set-point; optionally step to ``target_c`` first."""

    type: Literal["hold"]
    dwell_s: float = Field(gt=0, le=LARGE, description="how long to hold [s]")
    target_c: SetpointC | None = Field(default_of(prog.Hold, "target_c"), description="step the set-point here first [°C]")


class RampStep(Section):
    """Linear ramp to ``target_c``."""

    type: Literal["ramp"]
    target_c: SetpointC = Field(description="end temperature [°C]")
    ramp_c_per_h: float = Field(ge=-LARGE, le=LARGE, description="rate [°C/h]: a magnitude, or signed towards the target")


class StaircaseStep(Section):
    """Steps of ``step_c`` every ``step_s`` up or down to ``target_c`` (0.4 °C every 35 s)."""

    type: Literal["staircase"]
    target_c: SetpointC = Field(description="end temperature [°C]")
    step_c: float = Field(gt=0, le=LARGE, description="temperature increment [°C]")
    step_s: float = Field(gt=0, le=LARGE, description="time per step [s]")


Step = Annotated[Union[HoldStep, RampStep, StaircaseStep], Field(discriminator="type")]


class ProgramSection(Section):
    """Chamber set-point program: ``steps`` repeated ``cycles`` times from ``start_c``."""

    start_c: SetpointC = Field(-20.0, description="set-point at t = 0; the chamber starts in equilibrium there [°C]")
    cycles: int = Field(1, ge=1, le=100_000)
    steps: list[Step] = Field(min_length=1)


# ------------------------------------------------------------------ chamber


def _thermometer(name: str) -> Any:
    return default_of(thermal.Thermometer, name)


class ThermometerSection(Section):
    """Reference thermometer (``chamber.thermometer``); defaults: ``sim.thermal.Thermometer``."""
    attached_to: str = Field(_thermometer("attached_to"), description="node it sits on: air, board, die (or a 1-D layer name)")
    tau_s: NonNegativeFloat = Field(_thermometer("tau_s"), description="contact time constant to that node; 0 = no lag [s]")
    accuracy_c: NonNegativeFloat = Field(0.03, description="stated accuracy (the paper's ±0.03 °C); documentation only "
                                                           "[°C]")
    noise_c: NonNegativeFloat = Field(_thermometer("noise_c"), description="white noise σ per reading (±0.03 °C read as "
                                                                            "3σ) [°C]")
    resolution_c: NonNegativeFloat = Field(_thermometer("resolution_c"), description="reading resolution [°C]")
    offset_c: float = Field(_thermometer("offset_c"), ge=-100.0, le=100.0, description="fixed reading offset [°C]")
    sample_rate_hz: PositiveFloat = Field(_thermometer("sample_rate_hz"), description="thermometer sample rate [Hz]")


def _lumped(name: str) -> Any:
    return default_of(thermal.LumpedChain, name)


class LumpedSection(Section):
    """Lumped air → board → die chain (``chamber.lumped``); defaults: ``sim.thermal.LumpedChain``."""
    board_tau_s: PositiveFloat = Field(_lumped("board_tau_s"), description="board/fixture convective time constant [s]")
    die_tau_s: PositiveFloat = Field(_lumped("die_tau_s"), description="package/die to board time constant [s]")
    die_to_board_capacity_ratio: PositiveFloat = Field(_lumped("die_to_board_capacity_ratio"),
                                                       description="C_die / C_board [1]")
    board_heat_capacity_j_per_k: PositiveFloat = Field(_lumped("board_heat_capacity_j_per_k"),
                                                       description="C_board, scales heat flows [J/K]")


class LayerSection(Section):
    """One layer of the 1-D stack: thickness [mm], k [W/(m K)], ρ [kg/m³], c [J/(kg K)], cells."""
    name: str
    thickness_mm: PositiveFloat
    conductivity_w_per_mk: PositiveFloat
    density_kg_per_m3: PositiveFloat
    specific_heat_j_per_kgk: PositiveFloat
    cells: int = Field(default_of(thermal.Layer, "cells"), ge=1, le=200)


def _default_layers() -> list[LayerSection]:
    # Handbook values: Al 6061, FR-4, Si, epoxy mould compound (docs/physics.md §1.6; typical values).
    return [
        LayerSection(name="fixture", thickness_mm=5.0, conductivity_w_per_mk=167.0, density_kg_per_m3=2700.0,
                     specific_heat_j_per_kgk=896.0, cells=4),
        LayerSection(name="board", thickness_mm=1.6, conductivity_w_per_mk=0.3, density_kg_per_m3=1850.0,
                     specific_heat_j_per_kgk=1100.0, cells=6),
        LayerSection(name="die", thickness_mm=0.3, conductivity_w_per_mk=148.0, density_kg_per_m3=2330.0,
                     specific_heat_j_per_kgk=705.0, cells=2),
        LayerSection(name="mould", thickness_mm=0.9, conductivity_w_per_mk=0.8, density_kg_per_m3=1900.0,
                     specific_heat_j_per_kgk=900.0, cells=4),
    ]


class Conduction1DSection(Section):
    """1-D conduction through layered fixture/board/die/mould (``chamber.conduction_1d``)."""
    layers: list[LayerSection] = Field(default_factory=_default_layers, min_length=1)
    h_bottom_w_per_m2k: NonNegativeFloat = Field(default_of(thermal.ConductionStack, "h_bottom_w_per_m2k"),
                                                 description="convection, fixture underside ↔ air [W/(m² K)]")
    h_top_w_per_m2k: NonNegativeFloat = Field(default_of(thermal.ConductionStack, "h_top_w_per_m2k"),
                                              description="convection, package top ↔ air [W/(m² K)]")
    theta: float = Field(default_of(thermal.ConductionStack, "theta"), ge=0.5, le=1.0,
                         description="θ-method: 1 backward Euler, 0.5 Crank–Nicolson")
    board_layer: str = "board"
    die_layer: str = "die"

    @model_validator(mode="after")
    def _layers_named(self) -> Conduction1DSection:
        names = [layer.name for layer in self.layers]
        for key in ("board_layer", "die_layer"):
            if getattr(self, key) not in names:
                raise ValueError(f"{key} {getattr(self, key)!r} is not a layer name; layers are {names}")
        if self.h_bottom_w_per_m2k == 0 and self.h_top_w_per_m2k == 0:
            raise ValueError("at least one face must exchange heat with the air (h > 0)")
        return self


class ChamberSection(Section):
    """Thermal chamber: air lag [s], the air → device model and the thermometer."""
    model: Literal["lumped", "conduction_1d"] = "lumped"
    air_tau_s: PositiveFloat = Field(60.0, description="air following the set-point (controller, fan) [s]")
    thermal_step_s: PositiveFloat | None = Field(None, description="coarser thermal step, interpolated back [s]")
    lumped: LumpedSection = LumpedSection()
    conduction_1d: Conduction1DSection = Conduction1DSection()
    thermometer: ThermometerSection = ThermometerSection()


# ------------------------------------------------------------------ device


PositiveNumber = Annotated[Union[int, float], Field(gt=0)]  # an int stays an int (table keys, dataset attrs)


class SensorSection(Section):
    """The accelerometer: a part (its datasheet figures, ``twin parts``) at a full scale and ODR,
    with any figure overridden. ``None`` = the part's figure (choices: the part's lowest)."""

    part: str = Field(DEFAULT_PART, description="built-in part (twin parts), 'generic' (every figure from the "
                                              "scenario), or a part YAML file relative to the scenario")
    model: str | None = Field(None, description="alias of part (older scenarios)")
    full_scale_g: PositiveNumber | None = Field(None, description="full scale [±g]: one of the part's; default its lowest")
    odr_hz: PositiveNumber | None = Field(None, description="output data rate [Hz]: one of the part's; default its lowest")
    sensitivity_mg_per_digit: PositiveFloat | None = Field(None, description="override: one digit at this full scale [mg]")
    resolution_bits: Annotated[int, Field(ge=2, le=16)] | None = Field(None, description="override: output data bits")
    lowpass_hz: PositiveFloat | None = Field(None, description="override: low-pass cut-off at this ODR (noise "
                                                               "bandwidth) [Hz]")
    noise_density_ug_per_sqrt_hz: NonNegativeFloat | None = Field(None, description="override: white-noise density "
                                                                                    "[µg/√Hz]")
    bias_instability_mg: NonNegativeFloat | None = Field(None, description="override: Gauss–Markov bias σ [mg]")
    bias_instability_tau_s: PositiveFloat | None = Field(None, description="override: its correlation time [s]")
    zero_g_offset_mg: OffsetMg = Field(0.0, description="zero-g offset of this device at the reference temperature [mg]")
    turn_on_bias_mg: NonNegativeFloat = Field(0.0, description="σ of a bias drawn afresh at each run's start [mg]")

    @model_validator(mode="after")
    def _model_is_an_alias_of_part(self) -> SensorSection:
        if self.model is not None and "part" in self.model_fields_set and self.model != self.part:
            raise ValueError(f"model {self.model!r} and part {self.part!r} disagree (model is an alias of part: give one)")
        return self

    @property
    def part_spec(self) -> str:
        """The part named by ``part``, or by its alias ``model``."""
        return self.model if self.model is not None and "part" not in self.model_fields_set else self.part


class GeometrySection(Section):
    """Comb microstructure (paper §2.1, docs/physics.md §2.5); used by the microstructure effects.
    Defaults: ``sim.microstructure.CombGeometry``."""

    b_um: PositiveFloat = default_of(CombGeometry, "b_um")
    e_um: PositiveFloat = default_of(CombGeometry, "e_um")
    h_um: PositiveFloat = default_of(CombGeometry, "h_um")
    g_um: PositiveFloat = default_of(CombGeometry, "g_um")
    u_um: PositiveFloat = default_of(CombGeometry, "u_um")
    m_um: PositiveFloat = default_of(CombGeometry, "m_um")
    n_um: PositiveFloat = default_of(CombGeometry, "n_um")
    j_um: PositiveFloat = default_of(CombGeometry, "j_um")
    i_um: PositiveFloat = default_of(CombGeometry, "i_um")
    resonance_hz: PositiveFloat = default_of(CombGeometry, "resonance_hz")


EffectParams = dict[str, float]
AXES = ("x", "y", "z")


def _default_effects() -> dict[str, EffectParams]:
    return {"static_bias_tc": {}, "scale_factor_tc": {}}


class AxisSection(Section):
    """One sensing axis of a three-axis device: its own drift effects and zero-g offset."""

    effects: dict[str, EffectParams] = Field(default_factory=_default_effects,
                                             description="effects this axis truly has, with their parameters")
    zero_g_offset_mg: OffsetMg = Field(0.0, description="zero-g offset of this axis at the reference temperature [mg]")


class AxesSection(Section):
    """The sensing axes x, y, z of a three-axis device: one die and one thermal path, shared;
    effects, zero-g offsets and noise streams per axis."""

    x: AxisSection
    y: AxisSection
    z: AxisSection


class DeviceSection(Section):
    """The simulated device: sensor part, comb geometry, true effects (per axis with ``axes``)."""
    sensor: SensorSection = SensorSection()
    geometry: GeometrySection = GeometrySection()
    effects: dict[str, EffectParams] = Field(
        default_factory=_default_effects,
        description="effects the simulated device truly has, with their parameters",
    )
    axes: AxesSection | None = Field(None, description="a three-axis device: effects and zero-g offset per axis "
                                                       "(instead of effects and sensor.zero_g_offset_mg)")

    @model_validator(mode="after")
    def _axes_carry_their_own_effects(self) -> DeviceSection:
        if self.axes is None:
            return self
        given = (["effects"] if "effects" in self.model_fields_set else []) + (
            ["sensor.zero_g_offset_mg"] if "zero_g_offset_mg" in self.sensor.model_fields_set else [])
        if given:
            raise ValueError(f"{' and '.join(given)} {'is' if len(given) == 1 else 'are'} for a one-axis device; with "
                             "axes give effects and zero_g_offset_mg per axis (axes.x.effects, axes.x.zero_g_offset_mg, ...)")
        return self


# ------------------------------------------------------------------ twin, output


class TwinSection(Section):
    """The twin's model: the effects it assumes and user effect plugins."""
    effects: list[str] = Field(default_factory=lambda: ["static_bias_tc", "scale_factor_tc"],
                               description="effects the twin's model assumes")
    plugins: list[str] = Field(default_factory=list,
                               description="user effect modules: .py paths (relative to the scenario) or module names; "
                                           "loading one runs its code")


class OutputSection(Section):
    """Default HDF5 output path and compression."""
    path: str | None = Field(None, description="default HDF5 output path")
    compression: Literal["lzf", "gzip", "none"] = "lzf"
