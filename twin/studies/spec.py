"""A study file: its schema (:class:`Study`), factor paths, and :func:`load_study`."""

from __future__ import annotations

import difflib
import math
from pathlib import Path
from typing import Literal

import yaml
from pydantic import BaseModel, ConfigDict, Field, ValidationError, model_validator

from twin.errors import ScenarioError, TwinError
from twin.io import read_text
from twin.studies.responses import get_response, load_plugin
from twin.text import format_path, load_yaml_mapping, where

MAX_RUNS = 1_000_000  # the largest max_runs a study may set


class StudyError(TwinError):
    """A study that cannot be run or resumed (its files, not its YAML)."""


class FactorSpec(BaseModel):
    """One factor of a study: a range or explicit levels of one scenario value.

    Attributes
    ----------
    range : list of float, optional
        [low, high], in the unit of the scenario key the factor sets.
    levels : list of int, float or str, optional
        Explicit levels, in that unit.
    log : bool
        Sample the range on a log scale (low > 0).
    """

    model_config = ConfigDict(extra="forbid", frozen=True, allow_inf_nan=False)
    range: list[float] | None = Field(None, min_length=2, max_length=2, description="[low, high]")
    levels: list[int | float | str] | None = Field(None, min_length=1, description="explicit levels")
    log: bool = Field(False, description="sample the range on a log scale")

    @model_validator(mode="after")
    def _one(self) -> FactorSpec:
        if (self.range is None) == (self.levels is None):
            raise ValueError("give either range: [low, high] or levels: [...]")
        if self.range is not None and not self.range[0] < self.range[1]:
            raise ValueError(f"empty range {self.range}: need low < high")
        if self.log and self.range is not None and self.range[0] <= 0:
            raise ValueError("a log range needs low > 0")
        return self


class DesignSpec(BaseModel):
    """A study's design.

    Attributes
    ----------
    type : {"full_factorial", "latin_hypercube", "sobol", "saltelli"}
        The design.
    points : int
        Samples (Latin hypercube, Sobol) or base samples N (Saltelli: N (d + 2) runs for d factors).
    levels : int
        Levels per ranged factor in a full factorial.
    """

    model_config = ConfigDict(extra="forbid", frozen=True, allow_inf_nan=False)
    type: Literal["full_factorial", "latin_hypercube", "sobol", "saltelli"] = "full_factorial"
    points: int = Field(8, ge=1, le=MAX_RUNS, description="samples (LHS/Sobol) or base samples N (Saltelli: N(d+2) runs)")
    levels: int = Field(3, ge=2, le=MAX_RUNS, description="levels per ranged factor in a full factorial")


class Study(BaseModel):
    """A study file (YAML), validated.

    Attributes
    ----------
    name, description : str
        For people.
    base : str
        The base scenario YAML, relative to the study file.
    seed : int
        Seeds the design and, with each run's index and replicate, the run.
    factors : dict of str to FactorSpec
        Dotted scenario path → its range or levels.
    design : DesignSpec
    replicates : int
        Runs per design point.
    responses : list of str
        Registered responses, each listed once.
    max_runs : int
        Designs with more runs (points × replicates) are refused.
    logger_rate_hz : float, optional
        Overrides the base scenario's logger rate [Hz] (faster studies).
    plugins : list of str
        Response modules (``.py`` relative to the study, or module names) loaded before the
        responses are looked up; loading one runs its code.
    """

    model_config = ConfigDict(extra="forbid", frozen=True, allow_inf_nan=False)
    name: str = ""
    description: str = ""
    base: str = Field(description="base scenario YAML, relative to the study file")
    seed: int = Field(0, ge=0, le=2**63 - 1)
    factors: dict[str, FactorSpec] = Field(min_length=1)
    design: DesignSpec = DesignSpec()
    replicates: int = Field(1, ge=1, le=MAX_RUNS)
    responses: list[str] = Field(min_length=1)
    max_runs: int = Field(500, ge=1, le=MAX_RUNS, description="refuse designs larger than this")
    logger_rate_hz: float | None = Field(None, gt=0, description="override the base logger rate (faster studies)")
    plugins: list[str] = Field(default_factory=list, description="response modules (.py relative to the study, or "
                               "module names) to load before the responses are looked up; runs their code")

    @model_validator(mode="after")
    def _responses_once(self) -> Study:
        twice = sorted({r for r in self.responses if self.responses.count(r) > 1})
        if twice:  # the table would have two columns of one name
            raise ValueError(f"response {twice[0]!r} is listed twice; list each response once")
        return self


def design_size(study: Study) -> int:
    """The number of design points, computed without building them (a factorial can be huge).

    Parameters
    ----------
    study : Study

    Returns
    -------
    int
        Points (replicates not included).
    """
    d, t = len(study.factors), study.design.type
    if t == "full_factorial":
        return math.prod(len(f.levels) if f.levels is not None else study.design.levels for f in study.factors.values())
    return study.design.points * (d + 2) if t == "saltelli" else study.design.points


def _leaf_paths(data, prefix="") -> list[str]:
    out = []
    if isinstance(data, dict):
        for k, v in data.items():
            p = f"{prefix}.{k}" if prefix else str(k)
            out.append(p)
            out += _leaf_paths(v, p)
    elif isinstance(data, list):
        for i, v in enumerate(data):
            p = f"{prefix}.{i}"
            out.append(p)
            out += _leaf_paths(v, p)
    return out


def _schema_paths() -> list[str]:
    """Every settable dotted path of a scenario, from the schema (for "did you mean")."""
    import typing

    from twin.model.scenario import Scenario

    paths = []

    def walk(model, prefix):
        for name, f in model.model_fields.items():
            p = f"{prefix}.{name}" if prefix else name
            paths.append(p)
            for t in [f.annotation, *typing.get_args(f.annotation)]:
                for tt in [t, *typing.get_args(t)]:
                    if isinstance(tt, type) and issubclass(tt, BaseModel):
                        walk(tt, p)

    walk(Scenario, "")
    return paths


def _check_factor_path(path: str, base: dict) -> None:
    """A factor path must name something in the base scenario or the scenario schema; effect
    parameters (device.effects.<effect>.<param>) are checked against the registry."""
    from twin.effects import get_effect

    keys = path.split(".")
    if keys[:2] == ["device", "effects"] and len(keys) == 4:
        cls = get_effect(keys[2])  # raises with "did you mean"
        names = [p.name for p in cls.parameters]
        if keys[3] not in names:
            close = difflib.get_close_matches(keys[3], names, n=1)
            raise ScenarioError(f"factor {path!r}: effect {keys[2]!r} has no parameter {keys[3]!r}"
                                + (f"; did you mean {close[0]!r}?" if close else f"; parameters: {', '.join(names)}"))
        return
    known = set(_leaf_paths(base)) | set(_schema_paths())
    if path not in known:
        close = difflib.get_close_matches(path, sorted(known), n=1)
        raise ScenarioError(f"unknown factor path {path!r}" + (f"; did you mean {close[0]!r}?" if close else ""))


def _resolve_plugin(spec: str, folder: Path) -> str:
    """A ``.py`` plugin path made absolute (workers may run elsewhere); module names as given."""
    return str((folder / spec).resolve()) if spec.endswith(".py") else spec


def load_study(path: str | Path) -> tuple[Study, dict, Path]:
    """Validate a study file and load its plugins; return it (plugin paths made absolute), the base
    scenario data, and the study's folder.

    Parameters
    ----------
    path : str or Path
        The study YAML.

    Returns
    -------
    study : Study
    base : dict
        The base scenario's data.
    folder : Path
        The study file's folder.

    Raises
    ------
    ScenarioError
        One line naming the file, line and key: unknown keys, bad values, unknown responses or
        factor paths, a plugin that fails, a design over ``max_runs``, a missing or invalid base,
        a level that gives an invalid scenario.
    """
    p = Path(path)
    data, lines = load_yaml_mapping(read_text(p, "study file", ScenarioError), str(p), "a study is a YAML mapping")
    try:
        study = Study.model_validate(data)
    except ValidationError as exc:
        e = exc.errors(include_url=False)[0]
        loc = tuple(e["loc"])
        if e["type"] == "extra_forbidden":
            valid = list(Study.model_fields) if len(loc) == 1 else list(DesignSpec.model_fields) if loc[0] == "design" \
                else list(FactorSpec.model_fields)
            close = difflib.get_close_matches(str(loc[-1]), valid, n=1)
            hint = f"; did you mean {close[0]!r}?" if close else ""
            raise ScenarioError(f"{where(str(p), lines, loc)}: unknown key {loc[-1]!r}{hint}") from None
        raise ScenarioError(f"{where(str(p), lines, loc)}: {format_path(loc)}: {e['msg']}") from None
    plugins = [_resolve_plugin(spec, p.parent) for spec in study.plugins]
    for i, spec in enumerate(plugins):
        try:
            load_plugin(spec)
        except TwinError as exc:
            raise ScenarioError(f"{where(str(p), lines, ('plugins', i))}: plugins[{i}]: {exc}") from None
    study = study.model_copy(update={"plugins": plugins})
    for i, r in enumerate(study.responses):
        try:
            get_response(r)
        except TwinError as exc:
            raise ScenarioError(f"{where(str(p), lines, ('responses', i))}: {exc}") from None
    n = design_size(study)  # before the points are built, and before the base is read
    if n * study.replicates > study.max_runs:
        raise ScenarioError(f"{p}: the {study.design.type} design needs {n} points × {study.replicates} replicates = "
                            f"{n * study.replicates} runs, more than max_runs {study.max_runs}")
    base_path = (p.parent / study.base).resolve()
    if not base_path.is_file():
        raise ScenarioError(f"{where(str(p), lines, ('base',))}: base scenario {study.base!r} not found (looked in "
                            f"{base_path})")
    base = _check_base(study, base_path)
    for name in study.factors:
        try:
            _check_factor_path(name, base)
        except TwinError as exc:
            raise ScenarioError(f"{where(str(p), lines, ('factors', name))}: {exc}") from None
    _check_levels(study, base, str(p), lines)
    return study, base, p.parent


def _check_levels(study: Study, base: dict, path: str, lines: dict) -> None:
    """Each factor's levels (or range ends), set alone in the base, give a valid scenario: a level
    outside a parameter's bounds is refused now, not recorded as a failed run and skipped."""
    from twin.studies.design import scenario_error

    rate = {"test_plan.logger_rate_hz": study.logger_rate_hz} if study.logger_rate_hz else {}
    for name, f in study.factors.items():
        values = f.levels if f.levels is not None else f.range
        for value in dict.fromkeys(values):
            detail = scenario_error(base, {**rate, name: value})
            if detail is not None:
                kind = "levels" if f.levels is not None else "range"
                raise ScenarioError(f"{where(path, lines, ('factors', name))}: factors.{name}.{kind}: {value!r} "
                                    f"gives an invalid scenario: {detail}")


def _check_base(study: Study, base_path: Path) -> dict:
    """The base scenario's data, validated as the runs will see it (logger rate override applied):
    an invalid base is refused here, not found out run by run."""
    from twin.model.scenario import parse_scenario

    text = read_text(base_path, "base scenario", ScenarioError)
    base, _ = load_yaml_mapping(text, str(base_path), "a scenario is a YAML mapping with a 'program' section")
    plan = base.get("test_plan", {})
    if not (study.logger_rate_hz and isinstance(plan, dict)):
        parse_scenario(text, str(base_path))
        return base
    probe = yaml.safe_dump({**base, "test_plan": {**plan, "logger_rate_hz": study.logger_rate_hz}}, sort_keys=False)
    try:
        parse_scenario(probe, str(base_path))
    except ScenarioError as exc:
        parse_scenario(text, str(base_path))  # the file's own error, with its own line numbers, if it has one
        detail = str(exc).split(": ", 1)[-1]
        raise ScenarioError(f"{base_path}: with the study's logger_rate_hz {study.logger_rate_hz:g} Hz: {detail}") from None
    return base
