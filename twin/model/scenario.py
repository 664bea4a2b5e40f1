"""Scenario YAML: validation with clear errors, and compilation into sim objects.

Top-level sections: ``seed``, ``program`` (chamber set-point), ``chamber`` (thermal model),
``device`` (``sensor``, ``geometry``, ``effects`` the simulated device truly has), ``test_plan``
(orientations, power cycles, runs, logger), ``twin`` (what the model assumes), ``output``.
Every key is documented in ``docs/scenario.md``; ``twin schema`` prints the JSON Schema.

The sections themselves are in :mod:`twin.model.sections` and :mod:`twin.model.plan` (re-exported
here), the one-line messages in :mod:`twin.model.yaml_loader` and :mod:`twin.text`. This module loads a scenario:
YAML → sections → the part named by ``device.sensor.part`` with the scenario's overrides → the
compiled program, plugins and cross-section checks → :class:`LoadedScenario`.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from pathlib import Path

from pydantic import ValidationError

from sim import program as prog
from sim import thermal
from sim.microstructure import CombGeometry
from sim.sensor import AccelerometerConfig
from twin.errors import ModelError, ScenarioError
from twin.io import read_text
from twin.model.plan import (  # noqa: F401 - re-exported, as the sections below
    OrientationSection,
    Scenario,
    SixPositionSection,
    TestPlanSection,
    TumbleSection,
)
from twin.model.sections import (  # noqa: F401 - re-exported: the sections are part of this module's API
    AXES,
    AxesSection,
    AxisSection,
    ChamberSection,
    Conduction1DSection,
    DeviceSection,
    GeometrySection,
    HoldStep,
    LayerSection,
    LumpedSection,
    OutputSection,
    ProgramSection,
    RampStep,
    SensorSection,
    StaircaseStep,
    ThermometerSection,
    TwinSection,
)
from twin.model.yaml_loader import validation_message
from twin.parts import (
    SIMULATION_FIGURES,
    Part,
    PartError,
    accelerometer_figures,
    load_part,
)
from twin.text import did_you_mean, load_yaml_mapping, where


def _dataclass_kwargs(section, cls) -> dict:
    """The fields of ``section`` that the dataclass ``cls`` takes, by name (never by position)."""
    return {f.name: getattr(section, f.name) for f in dataclasses.fields(cls)}


@dataclass
class LoadedScenario:
    """A validated scenario with its source text, compiled program and sensor part.

    ``scenario.device.sensor`` holds the resolved figures (the part's, or the scenario's
    overrides), so every reader sees the values the simulation uses.

    Attributes
    ----------
    scenario : Scenario
        The validated scenario.
    text, path : str
        Source text and file name (``<string>`` when parsed from text).
    program : ChamberProgram
        The compiled chamber program.
    part : Part or None
        The sensor part the figures come from.
    """

    scenario: Scenario
    text: str
    path: str
    program: prog.ChamberProgram
    part: Part | None = None

    def geometry(self) -> CombGeometry:
        """The comb geometry of ``device.geometry``.

        Returns
        -------
        CombGeometry
            Dimensions [µm] and resonance [Hz].
        """
        return CombGeometry(**_dataclass_kwargs(self.scenario.device.geometry, CombGeometry))

    @property
    def axes(self) -> tuple[str, ...]:
        """The sensing axes simulated: ``("x", "y", "z")`` with ``device.axes``, else ``()`` (one axis)."""
        return AXES if self.scenario.device.axes is not None else ()

    def device_composition(self, axis: str | None = None):
        """The effects the simulated device truly has (of ``axis`` x, y or z for a three-axis device).

        Parameters
        ----------
        axis : str, optional
            ``"x"``, ``"y"`` or ``"z"``; ``None`` for a one-axis device.

        Returns
        -------
        Composition
            The device's effects at the scenario's values.
        """
        from twin.effects import Composition, get_effect

        ctx = {"geometry": self.geometry()}
        effects = self.scenario.device.effects if axis is None else getattr(self.scenario.device.axes, axis).effects
        return Composition([get_effect(n)(ctx, **(p or {})) for n, p in effects.items()])

    def twin_composition(self, values: dict[str, dict[str, float]] | None = None):
        """The effects the twin's model assumes (``twin.effects``), at defaults or ``values``.

        Parameters
        ----------
        values : dict, optional
            Parameter values by effect name, then parameter name [each parameter's unit].

        Returns
        -------
        Composition
            The twin's effects.
        """
        from twin.effects import Composition, get_effect

        ctx = {"geometry": self.geometry()}
        values = values or {}
        return Composition([get_effect(n)(ctx, **values.get(n, {})) for n in self.scenario.twin.effects])

    def sensor(self) -> AccelerometerConfig:
        """The accelerometer axis: the part's figures at the scenario's full scale and ODR, overrides applied.

        Returns
        -------
        AccelerometerConfig
            Sensor figures (units as in ``sim.sensor``).
        """
        return AccelerometerConfig(**_dataclass_kwargs(self.scenario.device.sensor, AccelerometerConfig))

    def thermometer(self) -> thermal.Thermometer:
        """The reference thermometer of ``chamber.thermometer``.

        Returns
        -------
        Thermometer
            Node, lag [s], noise and resolution [°C], sample rate [Hz].
        """
        return thermal.Thermometer(**_dataclass_kwargs(self.scenario.chamber.thermometer, thermal.Thermometer))

    def thermal_device(self) -> tuple[thermal.LumpedChain | thermal.ConductionStack, str, str]:
        """The air → device link and the names of its board and die nodes.

        Returns
        -------
        tuple
            (``LumpedChain`` or ``ConductionStack``, board node name, die node name).
        """
        c = self.scenario.chamber
        if c.model == "lumped":
            return thermal.LumpedChain(**_dataclass_kwargs(c.lumped, thermal.LumpedChain)), "board", "die"
        cd = c.conduction_1d
        layers = tuple(thermal.Layer(**_dataclass_kwargs(layer, thermal.Layer)) for layer in cd.layers)
        stack = thermal.ConductionStack(layers=layers, h_bottom_w_per_m2k=cd.h_bottom_w_per_m2k,
                                        h_top_w_per_m2k=cd.h_top_w_per_m2k, theta=cd.theta)
        return stack, cd.board_layer, cd.die_layer


def _base_dir(path: str) -> Path:
    """The folder that relative paths in a scenario (plugins, part files) are taken from."""
    return Path(path).parent if path and not path.startswith("<") else Path(".")


def parse_scenario(text: str, path: str = "<string>") -> LoadedScenario:
    """Validate scenario text; raise :class:`ScenarioError` with a one-line message.

    Parameters
    ----------
    text : str
        Scenario YAML.
    path : str
        File name shown in messages; relative plugin and part paths are taken from its folder.

    Returns
    -------
    LoadedScenario
        The validated scenario (plugins loaded, sensor figures resolved).
    """
    data, lines = load_yaml_mapping(text, path, "a scenario is a YAML mapping with a 'program' section")
    try:
        scenario = Scenario.model_validate(data)
    except ValidationError as exc:
        raise ScenarioError(validation_message(exc, Scenario, path, lines)) from None
    program = _compile_program(scenario, path, lines)
    scenario, part = _resolve_sensor(scenario, path, lines)
    _load_plugins(scenario, path, lines)
    _check_consistency(scenario, path, lines)
    return LoadedScenario(scenario, text, path, program, part)


def load_scenario(path: str | Path) -> LoadedScenario:
    """Read and validate a scenario file.

    Parameters
    ----------
    path : str or Path
        Scenario YAML file.

    Returns
    -------
    LoadedScenario
        As :func:`parse_scenario`.
    """
    return parse_scenario(read_text(path, "scenario file", ScenarioError), str(Path(path)))


#: The largest simulation accepted: samples over all runs (one axis; a three-axis device counts
#: 2.5 times, its per-axis arrays). `twin run` on the paper scenario peaks at 351 MB for 583,501
#: samples, 129 MB of it imports: ~380 B per sample, the in-memory HDF5 image included.
MAX_SAMPLES = 10_000_000
BYTES_PER_SAMPLE = 400
MAX_SEGMENTS = 1_000_000  # program segments (cycles × steps) and orientation blocks
MAX_CELLS = 400  # finite-volume cells of a conduction stack (one mode filter each)


def _compile_program(scenario: Scenario, path: str, lines: dict[tuple, int]) -> prog.ChamberProgram:
    """Compile the program after checking its size: duration, samples and memory are estimated
    from the first two cycles, before anything of the run's size is allocated."""
    p = scenario.program
    steps: list[prog.Step] = []
    kinds = {HoldStep: prog.Hold, RampStep: prog.Ramp, StaircaseStep: prog.Staircase}
    for s in p.steps:
        step = kinds[type(s)]
        steps.append(step(**_dataclass_kwargs(s, step)))
    try:
        head = prog.compile_program(p.start_c, steps, min(p.cycles, 2))
        first = prog.compile_program(p.start_c, steps, 1).duration_s
        duration = first + (p.cycles - 1) * (head.duration_s - first)  # cycles after the first are alike
        _check_size(scenario, duration, path, lines)
        return head if p.cycles <= 2 else prog.compile_program(p.start_c, steps, p.cycles)
    except prog.ProgramError as exc:
        loc = ("program", "steps", exc.step_index) if exc.step_index is not None else ("program",)
        raise ScenarioError(f"{where(path, lines, loc)}: program.{exc}") from None


def _check_size(scenario: Scenario, duration_s: float, path: str, lines: dict[tuple, int]) -> None:
    """Refuse a program of zero duration, and runs too large to hold in memory, naming the size."""
    p, tp = scenario.program, scenario.test_plan
    at = where(path, lines, ("program",))
    if not duration_s > 0:
        raise ScenarioError(f"{at}: program lasts 0 s (every step starts at its target); expected a duration > 0 s, "
                            "e.g. a hold with dwell_s > 0")
    if p.cycles * len(p.steps) > MAX_SEGMENTS:
        raise ScenarioError(f"{at}: program has {p.cycles} cycles × {len(p.steps)} steps = "
                            f"{p.cycles * len(p.steps):,} segments; the limit is {MAX_SEGMENTS:,}")
    weight = 2.5 if scenario.device.axes is not None else 1.0
    samples = (math.floor(duration_s * tp.logger_rate_hz) + 1) * tp.runs
    if samples * weight > MAX_SAMPLES:
        gb = samples * weight * BYTES_PER_SAMPLE / 1e9
        raise ScenarioError(
            f"{at}: program of {duration_s:.4g} s at test_plan.logger_rate_hz {tp.logger_rate_hz:g} Hz × "
            f"{tp.runs} run(s) is {samples:.3g} samples, needing ~{gb:.3g} GB of memory; the limit is "
            f"{MAX_SAMPLES / weight:,.0f} samples (~{MAX_SAMPLES * BYTES_PER_SAMPLE / 1e9:.0f} GB): shorten the program "
            "or lower the logger rate or the runs")
    for key in ("tumble", "six_position"):
        block = getattr(tp, key)
        if block is not None and duration_s / block.block_s > MAX_SEGMENTS:
            raise ScenarioError(f"{where(path, lines, ('test_plan', key, 'block_s'))}: test_plan.{key}.block_s "
                                f"{block.block_s:g} s makes {duration_s / block.block_s:.3g} blocks in a {duration_s:.4g} s "
                                f"run; the limit is {MAX_SEGMENTS:,}")
    c = scenario.chamber
    cells = sum(layer.cells for layer in c.conduction_1d.layers)
    if c.model == "conduction_1d" and cells > MAX_CELLS:
        raise ScenarioError(f"{where(path, lines, ('chamber', 'conduction_1d', 'layers'))}: chamber.conduction_1d has "
                            f"{cells} cells in all; the limit is {MAX_CELLS}")


def _resolve_sensor(scenario: Scenario, path: str, lines: dict[tuple, int]) -> tuple[Scenario, Part]:
    """Load the part of ``device.sensor`` and fill the section with the figures the simulation
    uses: the scenario's overrides, else the part's (tables at the chosen full scale and ODR)."""
    s = scenario.device.sensor
    spec_key = "model" if s.model is not None and "part" not in s.model_fields_set else "part"
    spec_loc = ("device", "sensor", spec_key)
    try:
        part = load_part(s.part_spec, _base_dir(path))
    except PartError as exc:
        raise ScenarioError(f"{where(path, lines, spec_loc)}: device.sensor.{spec_key}: {exc}") from None
    choices = {"full_scale_g": s.full_scale_g, "odr_hz": s.odr_hz}
    overrides = {name: getattr(s, name) for name in SIMULATION_FIGURES}
    try:
        figures = accelerometer_figures(part, choices, overrides)
        AccelerometerConfig(**figures)
    except PartError as exc:
        loc = ("device", "sensor", exc.key)
        sep = "." if str(exc).startswith(str(exc.key)) else ": "
        raise ScenarioError(f"{where(path, lines, loc)}: device.sensor{sep}{exc}") from None
    except ValueError as exc:
        raise ScenarioError(f"{where(path, lines, ('device', 'sensor'))}: device.sensor: {exc}") from None
    sensor = s.model_copy(update=figures)
    return scenario.model_copy(update={"device": scenario.device.model_copy(update={"sensor": sensor})}), part


def _load_plugins(scenario: Scenario, path: str, lines: dict[tuple, int]) -> None:
    from twin.effects import load_plugin

    base = _base_dir(path)
    for i, spec in enumerate(scenario.twin.plugins):
        try:
            load_plugin(spec, base)
        except ModelError as exc:
            raise ScenarioError(f"{where(path, lines, ('twin', 'plugins', i))}: twin.plugins[{i}]: {exc}") from None


def _check_consistency(scenario: Scenario, path: str, lines: dict[tuple, int]) -> None:
    """Cross-section checks: effect names and parameters, thermometer node, logger vs ODR."""
    from twin.effects import get_effect

    axes = scenario.device.axes
    groups = [(("device", "effects"), scenario.device.effects)] if axes is None else [
        (("device", "axes", a, "effects"), getattr(axes, a).effects) for a in AXES]
    for prefix, effects in groups:
        key = ".".join(prefix)
        for name, params in effects.items():
            loc = prefix + (name,)
            try:
                effect = get_effect(name)(**(params or {}))
            except ModelError as exc:
                raise ScenarioError(f"{where(path, lines, loc)}: {key}: {exc}") from None
            except (Exception, SystemExit) as exc:  # noqa: BLE001 - a plugin effect's own failure, in one line
                raise ScenarioError(f"{where(path, lines, loc)}: {key}: effect {name!r} failed to build: "
                                    f"{type(exc).__name__}: {' '.join(str(exc).split())[:200]}") from None
            if effect.slot == "temperature":
                raise ScenarioError(
                    f"{where(path, lines, loc)}: {key}: {name!r} is the twin's model of the die-thermometer lag; a "
                    "simulated device gets its lag from the thermal chain (set chamber.thermometer.attached_to and tau_s)")
            if axes is not None and effect.acts_on_thermometer:
                raise ScenarioError(
                    f"{where(path, lines, loc)}: {key}: {name!r} acts on the thermometer, which the three axes share; "
                    "it cannot be given per axis")
    _check_orientations(scenario, path, lines)
    for i, name in enumerate(scenario.twin.effects):
        try:
            get_effect(name)
        except ModelError as exc:
            raise ScenarioError(f"{where(path, lines, ('twin', 'effects', i))}: twin.effects[{i}]: {exc}") from None
    c = scenario.chamber
    nodes = ["air", "board", "die"] if c.model == "lumped" else ["air"] + [layer.name for layer in c.conduction_1d.layers]
    if c.thermometer.attached_to not in nodes:
        hint = did_you_mean(c.thermometer.attached_to, nodes, label=None)
        loc = ("chamber", "thermometer", "attached_to")
        raise ScenarioError(
            f"{where(path, lines, loc)}: chamber.thermometer.attached_to {c.thermometer.attached_to!r} is not a node "
            f"of the {c.model} model (nodes: {', '.join(nodes)}){hint}"
        )
    from sim.microstructure import GeometryError, check_gaps

    geometry = CombGeometry(**_dataclass_kwargs(scenario.device.geometry, CombGeometry))
    try:
        check_gaps(geometry, scenario.device.sensor.full_scale_g)
    except GeometryError as exc:
        raise ScenarioError(f"{where(path, lines, ('device', 'geometry'))}: device.{exc}") from None
    tp = scenario.test_plan
    if tp.logger_rate_hz > scenario.device.sensor.odr_hz:
        raise ScenarioError(
            f"{where(path, lines, ('test_plan', 'logger_rate_hz'))}: test_plan.logger_rate_hz {tp.logger_rate_hz:g} Hz "
            f"exceeds the sensor ODR {scenario.device.sensor.odr_hz:g} Hz"
        )
    if not math.isfinite(tp.logger_rate_hz):
        raise ScenarioError(f"{where(path, lines, ('test_plan',))}: test_plan.logger_rate_hz must be finite")


def _check_orientations(scenario: Scenario, path: str, lines: dict[tuple, int]) -> None:
    """A one-axis device takes applied_g orientations, a three-axis device gravity vectors."""
    tp = scenario.test_plan
    if scenario.device.axes is None:
        if tp.six_position is not None:
            raise ScenarioError(f"{where(path, lines, ('test_plan', 'six_position'))}: test_plan.six_position needs a "
                                "three-axis device (device.axes); a one-axis device takes orientations or tumble")
        bad = [i for i, o in enumerate(tp.orientations) if o.gravity_g is not None]
        what, expect = "gravity_g", "needs a three-axis device (device.axes); a one-axis device takes applied_g [g]"
    else:
        for key in ("tumble", "run_applied_g"):
            if getattr(tp, key) is not None:
                raise ScenarioError(f"{where(path, lines, ('test_plan', key))}: test_plan.{key} gives one-axis "
                                    "applied_g; a three-axis device (device.axes) takes six_position or orientations "
                                    "with gravity_g")
        bad = [i for i, o in enumerate(tp.orientations) if o.applied_g is not None] \
            if "orientations" in tp.model_fields_set else []
        what, expect = "applied_g", "is one-axis; a three-axis device (device.axes) takes gravity_g [gx, gy, gz]"
    if bad:
        loc = ("test_plan", "orientations", bad[0], what)
        raise ScenarioError(f"{where(path, lines, loc)}: test_plan.orientations[{bad[0]}].{what} {expect}")


def scenario_json_schema() -> dict:
    """JSON Schema of the scenario file, for editors.

    Returns
    -------
    dict
        Draft 2020-12 schema.
    """
    schema = Scenario.model_json_schema()
    schema["$schema"] = "https://json-schema.org/draft/2020-12/schema"
    schema["title"] = "tde-twin scenario"
    return schema
