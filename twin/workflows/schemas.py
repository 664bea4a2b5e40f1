"""The JSON Schema of each command's ``--json``, generated from its result types."""

from __future__ import annotations

from typing import Union

from twin.calibration.field_result import ApplyResult, FirmwareResult
from twin.calibration.result import CalibrationDocument
from twin.compensation.benchmark_result import BenchmarkResult
from twin.effects.records import EffectsListing
from twin.errors import TwinError
from twin.finding.result import AxesCompareResult, CompareResult
from twin.fleet.result import FleetResult, SimulatedFleet
from twin.results import json_schema
from twin.model.results import PackagePrediction, RunSummary
from twin.parts.records import PartsListing
from twin.plan.result import PlanResult
from twin.reporting.results import CombReport, DesignReport, ExportResult, PaperReport, RenderResult
from twin.studies.result import DoeResult


def result_types() -> dict[str, object]:
    """Result name (``twin schema --result NAME``) → the type of what ``--json`` writes.

    Returns
    -------
    dict of str to type
    """
    return {"compare": Union[CompareResult, AxesCompareResult], "fleet": FleetResult, "fleet-simulate": SimulatedFleet,
            "doe": DoeResult, "calibration": CalibrationDocument, "run": RunSummary, "test-design": DesignReport,
            "comb": CombReport, "render": RenderResult, "export": ExportResult, "package": PackagePrediction,
            "paper": PaperReport, "effects": EffectsListing, "parts": PartsListing,
            "firmware": FirmwareResult, "apply": ApplyResult, "benchmark": BenchmarkResult, "plan": PlanResult}


def result_schema(name: str) -> dict:
    """The JSON Schema of the result ``name``.

    Parameters
    ----------
    name : str
        One of :func:`result_types`.

    Returns
    -------
    dict
    """
    types = result_types()
    if name not in types:
        raise TwinError(f"--result: expected one of {', '.join(sorted(types))}, got {name!r}")
    schema = json_schema(types[name])
    schema["title"] = f"twin {name} --json"
    return schema
