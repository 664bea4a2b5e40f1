"""``twin compare`` as a function: options in, the typed result out; the report and ledger written.

One axis gives a :class:`~twin.finding.result.CompareResult`; ``axes`` give an
:class:`~twin.finding.result.AxesCompareResult` with each IMU's axes and a report per axis in
``REPORT/imu{n}_{axis}``.
"""

from __future__ import annotations

from pathlib import Path
from typing import Literal

from pydantic import Field, model_validator

from twin.diagnosis.axes import check_applied_measurement, compare_imu
from twin.diagnosis.diagnose import Diagnosis
from twin.finding.build import compare_measurement, finished_result, imu_result
from twin.finding.discovery import PLUGIN_NAME
from twin.finding.result import AxesCompareResult, CompareResult
from twin.measurement import ColumnMap
from twin.workflows.options import Options

Axis = Literal["x", "y", "z"]


class CompareOptions(Options):
    """What ``twin compare`` is asked to do.

    Attributes
    ----------
    scenario : Path
        Scenario YAML: its ``twin``, ``device.sensor`` and ``test_plan`` are read.
    measurements : list of Path
        Measurement files; several = several runs.
    columns : ColumnMap
        How to read a delimited log.
    with_effects : list of str
        Effects added to the twin.
    plugins : list of str
        Effect modules (.py paths or module names) loaded; their effects are added to the twin.
    applied_g : float, ``"unknown"`` or None
        Acceleration along the axis when not logged [g], checked against the static rows; None:
        1 g on one axis (unchecked), and with ``axes`` the g of each static stretch's face.
    axes : list of str, optional
        Compare these axes of a three-axis log, per IMU.
    imu : str
        With ``axes``: an IMU instance, or ``all``.
    skip_bad_rows : bool
    average_s : float
        Screening block length [s].
    discover : bool
        Search a dictionary of terms for one outside the library.
    discover_plugin : Path, optional
        Where to write a discovered term (default: ``REPORT/discovered_effect.py``).
    report : Path, optional
        Directory for ``report.html`` and the ledger.
    ledger_dir : Path, optional
        Where the ledger goes without a report (the ``--json`` file's directory).
    """

    scenario: Path
    measurements: list[Path] = Field(min_length=1)
    columns: ColumnMap = Field(default_factory=ColumnMap)
    with_effects: list[str] = []
    plugins: list[str] = []
    applied_g: float | Literal["unknown"] | None = None
    axes: list[Axis] | None = None
    imu: str = "all"
    skip_bad_rows: bool = False
    average_s: float = Field(10.0, ge=0.1, le=1e7)
    discover: bool = False
    discover_plugin: Path | None = None
    report: Path | None = None
    ledger_dir: Path | None = None

    @model_validator(mode="after")
    def _consistent(self) -> CompareOptions:
        if self.discover_plugin is not None and not self.discover:
            raise ValueError("--discover-plugin needs --discover")
        return self

    def plugin_target(self, sub: str = "") -> Path | None:
        """Where a discovered term is written.

        Parameters
        ----------
        sub : str
            The IMU and axis of a multi-axis compare (``""`` for one axis).

        Returns
        -------
        Path or None
            ``discover_plugin`` (with ``_sub`` added), else the report's ``discovered_effect.py``;
            None without either.
        """
        if self.discover_plugin is not None:
            return self.discover_plugin if not sub else self.discover_plugin.with_name(
                f"{self.discover_plugin.stem}_{sub}.py")
        return None if self.report is None else (self.report / sub / PLUGIN_NAME if sub else self.report / PLUGIN_NAME)


def _record(opts: CompareOptions, d: Diagnosis, result: CompareResult, sub: str, title: str) -> CompareResult:
    """Append to the ledger beside the report (or the JSON) and write the report; the result with its ledger."""
    from twin.reporting.compare_report import ledger_and_report

    ledger_dir = opts.report if opts.report is not None else opts.ledger_dir
    if ledger_dir is None:
        return result
    return ledger_and_report(ledger_dir / sub if sub else ledger_dir,
                             None if opts.report is None else opts.report / sub if sub else opts.report, d, result, title)


def run_compare(opts: CompareOptions) -> CompareResult | AxesCompareResult:
    """Compare the twin with the measurements: calibrate, show where it fails, name the missing effect.

    Parameters
    ----------
    opts : CompareOptions

    Returns
    -------
    CompareResult or AxesCompareResult
        One axis, or (with ``axes``) every IMU asked for.
    """
    from twin.effects import load_plugin
    from twin.measurement import imu_logs_by_instance, load_measurements
    from twin.model.scenario import load_scenario

    loaded = load_scenario(opts.scenario)
    with_effects = list(opts.with_effects)
    for spec in opts.plugins:
        with_effects += [n for n in load_plugin(spec) if n not in with_effects]
    names = ", ".join(p.name for p in opts.measurements)
    sources = [str(p) for p in opts.measurements]
    if not opts.axes:
        applied = 1.0 if opts.applied_g is None else opts.applied_g
        m = load_measurements(opts.measurements, opts.columns, skip_bad_rows=opts.skip_bad_rows, applied_g=applied)
        if isinstance(opts.applied_g, float):
            # a given --applied-g is checked against the static rows before any fit is made on it
            check_applied_measurement(m, opts.applied_g)
        d, result = compare_measurement(loaded, m, with_effects, opts.average_s, opts.discover, opts.plugin_target())
        return _record(opts, d, result, "", f"twin compare: {names}")
    per_instance = imu_logs_by_instance(opts.measurements, opts.columns, opts.imu, skip_bad_rows=opts.skip_bad_rows)
    imus = []
    for instance, logs in sorted(per_instance.items()):
        joint = compare_imu(loaded, logs, opts.axes, with_effects, opts.average_s, opts.applied_g)
        results = {}
        for axis, d in joint.diagnoses.items():
            sub = f"imu{instance}_{axis}"
            results[axis] = _record(opts, d, finished_result(d, opts.discover, opts.plugin_target(sub), sources), sub,
                                    f"twin compare: {names}, IMU {instance} {axis}")
        imus.append(imu_result(joint, results))
    return AxesCompareResult(tuple(imus), " ".join(f"IMU {r.instance}: {r.finding}" for r in imus))
