"""Design-of-experiment studies: sweep scenario parameters, locally or on a dask cluster.

A study YAML names a base scenario, factors (dotted paths into it with a range or levels), a
design (full factorial, Latin hypercube, Sobol/Saltelli from ``scipy.stats.qmc``), replicates and
responses from the response registry (:data:`RESPONSES`, extended by the study's ``plugins``).
Every run is seeded from the study seed and its index, so the executor does not change the
results; each finished run is appended durably (fsync) to ``runs.jsonl`` keyed by a hash of its
resolved scenario, so a killed study resumes without losing or duplicating runs; a failing run is
recorded with its error and the others go on.

This module gathers the public names of the package's modules: :mod:`~twin.studies.spec` (the
study file), :mod:`~twin.studies.design` (points and runs), :mod:`~twin.studies.responses` (the
registry), :mod:`~twin.studies.runner` (execution), :mod:`~twin.studies.analysis` (table and
analysis), :mod:`~twin.studies.result` (the analysis and ``twin doe --json``, typed) and
:mod:`~twin.studies.plots`.
"""

from twin.studies.analysis import interactions, main_effects, numeric_responses, sobol_indices, table, write_outputs
from twin.studies.design import design_points, plan, resolve, set_path
from twin.studies.plots import write_plots
from twin.studies.responses import (
    RESPONSES,
    Response,
    ResponseError,
    RunContext,
    get_response,
    load_plugin,
    register_response,
)
from twin.studies.result import DoeResult, MainEffect, SobolIndex, StudyAnalysis
from twin.studies.runner import evaluate_run, read_runs, run_design_points
from twin.studies.spec import DesignSpec, FactorSpec, Study, StudyError, load_study

__all__ = ["RESPONSES", "DesignSpec", "DoeResult", "FactorSpec", "MainEffect", "Response", "ResponseError", "RunContext",
           "SobolIndex", "Study", "StudyAnalysis", "StudyError",
           "design_points", "evaluate_run", "get_response", "interactions", "load_plugin", "load_study",
           "main_effects", "numeric_responses", "plan", "read_runs", "register_response", "resolve", "run_design_points",
           "set_path", "sobol_indices", "table", "write_outputs", "write_plots"]
