"""``twin doe`` as a function: options in, the typed result out; the runs, table and plots written.

:func:`run_study` runs every design point not yet in the output folder's ``runs.jsonl`` (a killed
study resumes), then writes the table, ``analysis.json`` and the plots. It takes two optional
callbacks from its caller, as :mod:`twin.workflows.fleet` does: ``progress(done, total)``, called
once the total is known (``done`` = 0) and after every run, and ``check_paths(inputs, outputs)``,
the caller's guard against writing over an input (the CLI adds its ``--json`` target).
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

from pydantic import Field

from twin.errors import TwinError
from twin.studies.result import DoeResult
from twin.workflows.options import Options

Progress = Callable[[int, int], None]
CheckPaths = Callable[[list, list], None]

#: what a study writes in its output folder
STUDY_OUTPUTS = ("runs.jsonl", "table.csv", "table.h5", "analysis.json", "main_effects.png", "response_surface.png",
                 "sobol.png")


class StudyOptions(Options):
    """What ``twin doe`` is asked to do.

    Attributes
    ----------
    study : Path
        Study YAML.
    output : Path
        Output folder (``runs.jsonl``, the table, ``analysis.json``, plots).
    workers : int
        Runs in parallel (1..256).
    executor : str
        ``local`` or ``dask``; anything else is refused by :func:`run_study` before the study is read.
    scheduler : str, optional
        Address of a Dask scheduler (default: a local cluster).
    """

    study: Path
    output: Path
    workers: int = Field(1, ge=1, le=256)
    executor: str = "local"
    scheduler: str | None = None


def run_study(opts: StudyOptions, progress: Progress | None = None,
              check_paths: CheckPaths | None = None) -> DoeResult:
    """Run a design-of-experiment study (resuming where it stopped) and analyse it.

    Parameters
    ----------
    opts : StudyOptions
    progress : callable, optional
        ``progress(runs done, runs planned)``.
    check_paths : callable, optional
        ``check_paths(inputs, outputs)``: refuses an output that would replace an input.

    Returns
    -------
    DoeResult

    Raises
    ------
    TwinError
        A bad study file or output folder, or every run failed (nothing to analyse).
    """
    from twin.studies import doe

    if opts.executor not in ("local", "dask"):
        raise TwinError(f"--executor must be 'local' or 'dask', got {opts.executor!r}")
    st, base, folder = doe.load_study(opts.study)
    output = opts.output
    if check_paths is not None:
        check_paths([opts.study, folder / st.base, *(output / n for n in STUDY_OUTPUTS)], [])
    if output.resolve() in (opts.study.resolve(), (folder / st.base).resolve()):
        raise TwinError(f"-o {output}: the output folder would overwrite an input; choose another path")
    total = len(doe.plan(st, base))
    done = 0

    def tick(_record) -> None:
        nonlocal done
        done += 1
        progress(done, total)

    if progress is not None:
        progress(0, total)
    runs = doe.run_design_points(st, base, output, opts.workers, opts.executor, opts.scheduler,
                         progress=tick if progress is not None else None)
    failed = [r for r in runs if r["status"] != "ok"]
    if runs and len(failed) == len(runs):  # nothing to analyse: say why instead of an empty "success"
        raise TwinError(f"{opts.study}: all {len(runs)} runs failed (kept in {output / 'runs.jsonl'}); the first: "
                        f"{failed[0].get('error', '?')}")
    analysis = doe.write_outputs(st, runs, output)
    return DoeResult(output=str(output), runs=len(runs), planned=total, failed=analysis.failed,
                     main_effects=analysis.main_effects, interactions=analysis.interactions, sobol=analysis.sobol)
