"""Scenario YAML: schema, validation with clear errors, and compilation into sim objects.

Top-level sections: ``seed``, ``program`` (chamber set-point), ``chamber`` (thermal model),
``device`` (``sensor``, ``geometry``, ``effects`` the simulated device truly has), ``test_plan``
(orientations, power cycles, runs, logger), ``twin`` (what the model assumes), ``output``.
Every key is documented in ``docs/scenario.md``; ``twin schema`` prints the JSON Schema.

pydantic does the validation (types, bounds, unknown keys, JSON Schema); this module turns its
errors into one line naming the file, the YAML line, the key path and what was expected.
"""

from __future__ import annotations

import difflib
import math
import types
import typing
from dataclasses import dataclass
from pathlib import Path
from typing import Annotated, Any, Literal, Union

import yaml
from pydantic import BaseModel, ConfigDict, Field, ValidationError, field_validator, model_validator

from sim import program as prog
from sim import thermal
from sim.sensor import IIS328DQ
from twin.errors import ModelError, ScenarioError

PositiveFloat = Annotated[float, Field(gt=0)]
NonNegativeFloat = Annotated[float, Field(ge=0)]


class _Section(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True)


# ------------------------------------------------------------------ program


class HoldStep(_Section):
    """Hold the set-point; optionally step to ``target_c`` first."""

    type: Literal["hold"]
    dwell_s: float = Field(gt=0, description="how long to hold [s]")
    target_c: float | None = Field(None, description="step the set-point here first [°C]")


class RampStep(_Section):
    """Linear ramp to ``target_c``."""

    type: Literal["ramp"]
    target_c: float = Field(description="end temperature [°C]")
    ramp_c_per_h: float = Field(description="rate [°C/h]: a magnitude, or signed towards the target")


class StaircaseStep(_Section):
    """Steps of ``step_c`` every ``step_s`` up or down to ``target_c`` (0.4 °C every 35 s)."""

    type: Literal["staircase"]
    target_c: float
    step_c: float = Field(gt=0, description="temperature increment [°C]")
    step_s: float = Field(gt=0, description="time per step [s]")


Step = Annotated[Union[HoldStep, RampStep, StaircaseStep], Field(discriminator="type")]


class ProgramSection(_Section):
    """Chamber set-point program: ``steps`` repeated ``cycles`` times from ``start_c``."""

    start_c: float = Field(-20.0, description="set-point at t = 0; the chamber starts in equilibrium there [°C]")
    cycles: int = Field(1, ge=1)
    steps: list[Step] = Field(min_length=1)


# ------------------------------------------------------------------ chamber


class ThermometerSection(_Section):
    attached_to: str = Field("board", description="node it sits on: air, board, die (or a 1-D layer name)")
    tau_s: NonNegativeFloat = Field(2.0, description="contact time constant to that node; 0 = no lag [s]")
    accuracy_c: NonNegativeFloat = Field(0.03, description="stated accuracy; documentation only [°C]")
    noise_c: NonNegativeFloat = Field(0.01, description="white noise σ per reading (±0.03 °C read as 3σ) [°C]")
    resolution_c: NonNegativeFloat = Field(0.01, description="reading resolution [°C]")
    offset_c: float = Field(0.0, description="fixed reading offset [°C]")
    sample_rate_hz: PositiveFloat = Field(10.0, description="thermometer sample rate [Hz]")


class LumpedSection(_Section):
    board_tau_s: PositiveFloat = Field(300.0, description="board/fixture convective time constant [s]")
    die_tau_s: PositiveFloat = Field(20.0, description="package/die to board time constant [s]")
    die_to_board_capacity_ratio: PositiveFloat = Field(0.01, description="C_die / C_board [1]")
    board_heat_capacity_j_per_k: PositiveFloat = Field(50.0, description="C_board, scales heat flows [J/K]")


class LayerSection(_Section):
    name: str
    thickness_mm: PositiveFloat
    conductivity_w_per_mk: PositiveFloat
    density_kg_per_m3: PositiveFloat
    specific_heat_j_per_kgk: PositiveFloat
    cells: int = Field(4, ge=1, le=200)


def _default_layers() -> list[LayerSection]:
    # Handbook values: Al 6061, FR-4, Si, epoxy mould compound (physics-notes §1.4, [T]).
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


class Conduction1DSection(_Section):
    layers: list[LayerSection] = Field(default_factory=_default_layers, min_length=1)
    h_bottom_w_per_m2k: NonNegativeFloat = Field(25.0, description="convection, fixture underside ↔ air [W/(m² K)]")
    h_top_w_per_m2k: NonNegativeFloat = Field(25.0, description="convection, package top ↔ air [W/(m² K)]")
    theta: float = Field(1.0, ge=0.5, le=1.0, description="θ-method: 1 backward Euler, 0.5 Crank–Nicolson")
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


class ChamberSection(_Section):
    model: Literal["lumped", "conduction_1d"] = "lumped"
    air_tau_s: PositiveFloat = Field(60.0, description="air following the set-point (controller, fan) [s]")
    thermal_step_s: PositiveFloat | None = Field(None, description="coarser thermal step, interpolated back [s]")
    lumped: LumpedSection = LumpedSection()
    conduction_1d: Conduction1DSection = Conduction1DSection()
    thermometer: ThermometerSection = ThermometerSection()


# ------------------------------------------------------------------ device


class SensorSection(_Section):
    model: Literal["IIS328DQ"] = "IIS328DQ"
    full_scale_g: Literal[2, 4, 8] = 2
    odr_hz: Literal[50, 100, 400, 1000] = 50
    noise_density_ug_per_sqrt_hz: NonNegativeFloat = Field(218.0, description="recalled family value, unverified")
    bias_instability_mg: NonNegativeFloat = Field(0.05, description="Gauss–Markov σ; typical, not datasheet")
    bias_instability_tau_s: PositiveFloat = 300.0
    zero_g_offset_mg: float = Field(0.0, description="zero-g offset at the reference temperature [mg]")
    turn_on_bias_mg: NonNegativeFloat = Field(0.0, description="σ of a bias drawn afresh at each run's start [mg]")


class GeometrySection(_Section):
    """Comb microstructure (paper §2.1, physics-notes §2.5); used by the microstructure effects."""

    b_um: PositiveFloat = 100.0
    e_um: PositiveFloat = 5.0
    h_um: PositiveFloat = 3.0
    g_um: PositiveFloat = 110.0
    u_um: PositiveFloat = 2.0
    m_um: PositiveFloat = 3.0
    n_um: PositiveFloat = 15.0
    j_um: PositiveFloat = 15.0
    i_um: PositiveFloat = 110.0
    resonance_hz: PositiveFloat = 3000.0


EffectParams = dict[str, float]


class DeviceSection(_Section):
    sensor: SensorSection = SensorSection()
    geometry: GeometrySection = GeometrySection()
    effects: dict[str, EffectParams] = Field(
        default_factory=lambda: {"static_bias_tc": {}, "scale_factor_tc": {}},
        description="effects the simulated device truly has, with their parameters",
    )


# ------------------------------------------------------------------ test plan, twin, output


class OrientationSection(_Section):
    at_s: NonNegativeFloat = Field(description="time from the start of each run [s]")
    applied_g: float = Field(description="acceleration along the sensing axis from then on [g]")


class TumbleSection(_Section):
    """Orientation blocks repeated through each run (+1 g, −1 g, 0 g tumble)."""

    block_s: PositiveFloat = Field(description="time in each orientation [s]")
    applied_g: list[float] = Field(min_length=1, description="the cycle of orientations [g]")


class TestPlanSection(_Section):
    logger_rate_hz: PositiveFloat = 10.0
    logger_mode: Literal["latest", "average"] = "latest"
    orientations: list[OrientationSection] = Field(default_factory=lambda: [OrientationSection(at_s=0.0, applied_g=1.0)])
    power_on_s: list[NonNegativeFloat] = Field(default_factory=lambda: [0.0], description="power-on times in each run [s]")
    runs: int = Field(1, ge=1, description="independent runs of the program (same device, new noise)")
    tumble: TumbleSection | None = Field(None, description="cyclic orientation blocks, instead of orientations")
    run_applied_g: list[float] | None = Field(None, min_length=1,
                                              description="one constant orientation per run, cycling (e.g. [1, -1])")

    @model_validator(mode="after")
    def _one_orientation_source(self) -> TestPlanSection:
        given = [k for k in ("orientations", "tumble", "run_applied_g")
                 if k in self.model_fields_set and getattr(self, k) is not None]
        if len(given) > 1:
            raise ValueError(f"give one of orientations, tumble, run_applied_g; got {', '.join(given)}")
        return self

    def orientation_schedule(self, duration_s: float) -> tuple[list[float], list[float]]:
        """(at_s, applied_g) of the orientation steps in one run."""
        if self.tumble is None:
            return [o.at_s for o in self.orientations], [o.applied_g for o in self.orientations]
        n = int(duration_s // self.tumble.block_s) + 1
        values = self.tumble.applied_g
        return [k * self.tumble.block_s for k in range(n)], [values[k % len(values)] for k in range(n)]

    @field_validator("orientations")
    @classmethod
    def _sorted(cls, v: list[OrientationSection]) -> list[OrientationSection]:
        if not v:
            raise ValueError("needs at least one orientation")
        times = [o.at_s for o in v]
        if times != sorted(times):
            raise ValueError("orientations must be in increasing at_s")
        return v


class TwinSection(_Section):
    effects: list[str] = Field(default_factory=lambda: ["static_bias_tc", "scale_factor_tc"],
                               description="effects the twin's model assumes")
    plugins: list[str] = Field(default_factory=list,
                               description="user effect modules: .py paths (relative to the scenario) or module names; "
                                           "loading one runs its code")


class OutputSection(_Section):
    path: str | None = Field(None, description="default HDF5 output path")
    compression: Literal["lzf", "gzip", "none"] = "lzf"


class Scenario(_Section):
    """A thermal-chamber test scenario."""

    seed: int = Field(0, ge=0, description="seed of every random draw")
    name: str = ""
    description: str = ""
    program: ProgramSection
    chamber: ChamberSection = ChamberSection()
    device: DeviceSection = DeviceSection()
    test_plan: TestPlanSection = TestPlanSection()
    twin: TwinSection = TwinSection()
    output: OutputSection = OutputSection()


# ------------------------------------------------------------------ loading


@dataclass
class LoadedScenario:
    """A validated scenario with its source text and compiled program."""

    scenario: Scenario
    text: str
    path: str
    program: prog.ChamberProgram

    def geometry(self):
        from sim.microstructure import CombGeometry

        return CombGeometry(**self.scenario.device.geometry.model_dump())

    def device_composition(self):
        """The effects the simulated device truly has."""
        from twin.effects import Composition, get_effect

        ctx = {"geometry": self.geometry()}
        return Composition([get_effect(n)(ctx, **(p or {})) for n, p in self.scenario.device.effects.items()])

    def twin_composition(self, values: dict[str, dict[str, float]] | None = None):
        """The effects the twin's model assumes (``twin.effects``), at defaults or ``values``."""
        from twin.effects import Composition, get_effect

        ctx = {"geometry": self.geometry()}
        values = values or {}
        return Composition([get_effect(n)(ctx, **values.get(n, {})) for n in self.scenario.twin.effects])

    def sensor(self) -> IIS328DQ:
        s = self.scenario.device.sensor
        return IIS328DQ(s.full_scale_g, s.odr_hz, s.noise_density_ug_per_sqrt_hz, s.bias_instability_mg,
                        s.bias_instability_tau_s)

    def thermometer(self) -> thermal.Thermometer:
        t = self.scenario.chamber.thermometer
        return thermal.Thermometer(t.attached_to, t.tau_s, t.noise_c, t.resolution_c, t.offset_c, t.sample_rate_hz)

    def thermal_device(self) -> tuple[thermal.LumpedChain | thermal.ConductionStack, str, str]:
        """The air → device link and the names of its board and die nodes."""
        c = self.scenario.chamber
        if c.model == "lumped":
            lp = c.lumped
            return thermal.LumpedChain(lp.board_tau_s, lp.die_tau_s, lp.die_to_board_capacity_ratio,
                                       lp.board_heat_capacity_j_per_k), "board", "die"
        cd = c.conduction_1d
        layers = tuple(thermal.Layer(**layer.model_dump()) for layer in cd.layers)
        return (thermal.ConductionStack(layers, cd.h_bottom_w_per_m2k, cd.h_top_w_per_m2k, cd.theta),
                cd.board_layer, cd.die_layer)


def _line_map(text: str) -> dict[tuple, int]:
    """Key path → 1-based YAML line, from the composed node tree."""
    lines: dict[tuple, int] = {}

    def walk(node: yaml.Node, path: tuple) -> None:
        lines.setdefault(path, node.start_mark.line + 1)
        if isinstance(node, yaml.MappingNode):
            for key, value in node.value:
                sub = path + (key.value,)
                lines[sub] = key.start_mark.line + 1
                walk(value, sub)
        elif isinstance(node, yaml.SequenceNode):
            for i, item in enumerate(node.value):
                walk(item, path + (i,))

    try:
        root = yaml.compose(text, Loader=yaml.SafeLoader)
    except yaml.YAMLError:
        return lines
    if root is not None:
        walk(root, ())
    return lines


def _unwrap(annotation: Any) -> list[Any]:
    """The concrete types behind Optional/Union/Annotated/list/dict annotations."""
    origin = typing.get_origin(annotation)
    if origin is Annotated:
        return _unwrap(typing.get_args(annotation)[0])
    if origin in (Union, types.UnionType):
        return [t for a in typing.get_args(annotation) for t in _unwrap(a)]
    return [annotation]


def _model_at(loc: tuple) -> tuple[type[BaseModel] | None, tuple]:
    """Walk a pydantic error location from ``Scenario``; return the model that holds its last key
    and the location with union tags removed (pydantic inserts the discriminator into ``loc``)."""
    current: list[Any] = [Scenario]
    clean: list[Any] = []
    parent: type[BaseModel] | None = Scenario
    for part in loc:
        models = [t for t in current if isinstance(t, type) and issubclass(t, BaseModel)]
        containers = [t for t in current if typing.get_origin(t) in (list, dict)]
        if isinstance(part, int) or (containers and not models):
            args = [a for t in containers for a in typing.get_args(t)]
            current = [t for a in args[-1:] for t in _unwrap(a)] if args else []
            clean.append(part)
            continue
        # A discriminator tag: pick the union member whose literal ``type`` equals it.
        tagged = [m for m in models if "type" in m.model_fields and part in typing.get_args(m.model_fields["type"].annotation)]
        if tagged and len(models) > 1:
            current = tagged
            continue
        model = models[0] if models else None
        parent = model
        clean.append(part)
        if model is not None and part in model.model_fields:
            current = _unwrap(model.model_fields[part].annotation)
        else:
            current = []
    return parent, tuple(clean)


def _format_path(loc: tuple) -> str:
    out = ""
    for part in loc:
        out += f"[{part}]" if isinstance(part, int) else (f".{part}" if out else str(part))
    return out or "(top level)"


def _where(path: str, lines: dict[tuple, int], loc: tuple) -> str:
    for n in range(len(loc), -1, -1):
        if loc[:n] in lines:
            return f"{path}:{lines[loc[:n]]}"
    return path


def _validation_message(err: ValidationError, path: str, lines: dict[tuple, int]) -> str:
    # A misspelt key shows as "unknown" and "missing" at once; the unknown one, with its
    # suggestion, is the message that helps.
    order = {"extra_forbidden": 0, "union_tag_invalid": 1}
    e = min(err.errors(include_url=False), key=lambda x: order.get(x["type"], 2))
    loc = tuple(e["loc"])
    parent, clean = _model_at(loc)
    key = _format_path(clean)
    where = _where(path, lines, clean)
    if e["type"] == "extra_forbidden":
        name = clean[-1]
        valid = list(parent.model_fields) if parent is not None else []
        close = difflib.get_close_matches(str(name), valid, n=1)
        hint = f"; did you mean {close[0]!r}?" if close else f"; valid keys: {', '.join(valid)}"
        return f"{where}: unknown key {name!r} at {_format_path(clean[:-1])}{hint}"
    if e["type"] == "union_tag_invalid":
        tags, tag = e["ctx"]["expected_tags"], e["ctx"]["tag"]
        options = [t.strip(" '") for t in tags.split(",")]
        close = difflib.get_close_matches(str(tag), options, n=1)
        hint = f"; did you mean {close[0]!r}?" if close else ""
        return f"{where}: {key}.type: unknown step type {tag!r} (expected {tags}){hint}"
    if e["type"] == "missing":
        return f"{where}: missing required key {key!r}"
    msg = e["msg"]
    got = e.get("input")
    shown = "" if isinstance(got, (dict, list)) else f" (got {got!r})"
    return f"{where}: {key}: {msg}{shown}"


def load_yaml_mapping(text: str, path: str, what: str) -> tuple[dict, dict[tuple, int]]:
    """Parse YAML that must be a mapping; return it with its key-path → line map."""
    try:
        data = yaml.safe_load(text)
    except yaml.YAMLError as exc:
        mark = getattr(exc, "problem_mark", None)
        line = f":{mark.line + 1}" if mark is not None else ""
        problem = getattr(exc, "problem", None) or str(exc).splitlines()[0]
        raise ScenarioError(f"{path}{line}: malformed YAML: {problem}") from None
    if not isinstance(data, dict):
        raise ScenarioError(f"{path}: {what}, got {type(data).__name__}")
    return data, _line_map(text)


def parse_scenario(text: str, path: str = "<string>") -> LoadedScenario:
    """Validate scenario text; raise :class:`ScenarioError` with a one-line message."""
    data, lines = load_yaml_mapping(text, path, "a scenario is a YAML mapping with a 'program' section")
    try:
        scenario = Scenario.model_validate(data)
    except ValidationError as exc:
        raise ScenarioError(_validation_message(exc, path, lines)) from None
    program = _compile_program(scenario, path, lines)
    _load_plugins(scenario, path, lines)
    _check_consistency(scenario, path, lines)
    return LoadedScenario(scenario, text, path, program)


def load_scenario(path: str | Path) -> LoadedScenario:
    """Read and validate a scenario file."""
    p = Path(path)
    if not p.is_file():
        raise ScenarioError(f"{p}: scenario file not found")
    try:
        text = p.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        raise ScenarioError(f"{p}: cannot read scenario: {exc}") from None
    return parse_scenario(text, str(p))


def _compile_program(scenario: Scenario, path: str, lines: dict[tuple, int]) -> prog.ChamberProgram:
    p = scenario.program
    steps: list[prog.Step] = []
    for s in p.steps:
        if isinstance(s, HoldStep):
            steps.append(prog.Hold(s.dwell_s, s.target_c))
        elif isinstance(s, RampStep):
            steps.append(prog.Ramp(s.target_c, s.ramp_c_per_h))
        else:
            steps.append(prog.Staircase(s.target_c, s.step_c, s.step_s))
    try:
        return prog.compile_program(p.start_c, steps, p.cycles)
    except prog.ProgramError as exc:
        loc = ("program", "steps", exc.step_index) if exc.step_index is not None else ("program",)
        raise ScenarioError(f"{_where(path, lines, loc)}: program.{exc}") from None


def _load_plugins(scenario: Scenario, path: str, lines: dict[tuple, int]) -> None:
    from twin.effects import load_plugin

    base = Path(path).parent if path and not path.startswith("<") else Path(".")
    for i, spec in enumerate(scenario.twin.plugins):
        try:
            load_plugin(spec, base)
        except ModelError as exc:
            raise ScenarioError(f"{_where(path, lines, ('twin', 'plugins', i))}: twin.plugins[{i}]: {exc}") from None


def _check_consistency(scenario: Scenario, path: str, lines: dict[tuple, int]) -> None:
    """Cross-section checks: effect names and parameters, thermometer node, logger vs ODR."""
    from twin.effects import get_effect

    for name, params in scenario.device.effects.items():
        loc = ("device", "effects", name)
        try:
            effect = get_effect(name)(**(params or {}))
        except ModelError as exc:
            raise ScenarioError(f"{_where(path, lines, loc)}: device.effects: {exc}") from None
        if effect.slot == "temperature":
            raise ScenarioError(
                f"{_where(path, lines, loc)}: device.effects: {name!r} is the twin's model of the die-thermometer lag; "
                "a simulated device gets its lag from the thermal chain (set chamber.thermometer.attached_to and tau_s)")
    for i, name in enumerate(scenario.twin.effects):
        try:
            get_effect(name)
        except ModelError as exc:
            raise ScenarioError(f"{_where(path, lines, ('twin', 'effects', i))}: twin.effects[{i}]: {exc}") from None
    c = scenario.chamber
    nodes = ["air", "board", "die"] if c.model == "lumped" else ["air"] + [layer.name for layer in c.conduction_1d.layers]
    if c.thermometer.attached_to not in nodes:
        close = difflib.get_close_matches(c.thermometer.attached_to, nodes, n=1)
        hint = f"; did you mean {close[0]!r}?" if close else ""
        loc = ("chamber", "thermometer", "attached_to")
        raise ScenarioError(
            f"{_where(path, lines, loc)}: chamber.thermometer.attached_to {c.thermometer.attached_to!r} is not a node "
            f"of the {c.model} model (nodes: {', '.join(nodes)}){hint}"
        )
    from sim.microstructure import CombGeometry, GeometryError, check_gaps

    try:
        check_gaps(CombGeometry(**scenario.device.geometry.model_dump()), scenario.device.sensor.full_scale_g)
    except GeometryError as exc:
        raise ScenarioError(f"{_where(path, lines, ('device', 'geometry'))}: device.{exc}") from None
    tp = scenario.test_plan
    if tp.logger_rate_hz > scenario.device.sensor.odr_hz:
        raise ScenarioError(
            f"{_where(path, lines, ('test_plan', 'logger_rate_hz'))}: test_plan.logger_rate_hz {tp.logger_rate_hz:g} Hz "
            f"exceeds the sensor ODR {scenario.device.sensor.odr_hz} Hz"
        )
    if not math.isfinite(tp.logger_rate_hz):
        raise ScenarioError(f"{_where(path, lines, ('test_plan',))}: test_plan.logger_rate_hz must be finite")


def json_schema() -> dict:
    """JSON Schema of the scenario file, for editors."""
    schema = Scenario.model_json_schema()
    schema["$schema"] = "https://json-schema.org/draft/2020-12/schema"
    schema["title"] = "tde-twin scenario"
    return schema
