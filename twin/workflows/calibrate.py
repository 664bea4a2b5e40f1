"""``twin calibrate`` as a function: logs in, validated calibrations and the document out.

The CLI maps its options onto :class:`CalibrateOptions`; :func:`run_calibrate` reads the logs,
fits and validates every method per IMU, builds the versioned calibration document (the file
``twin firmware`` and ``twin apply`` read) and writes the report when asked.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

from pydantic import Field

from twin.errors import TwinError
from twin.measurement import ColumnMap
from twin.workflows.options import Options

if TYPE_CHECKING:
    from twin.calibration.result import CalibrationDocument


class CalibrateOptions(Options):
    """What ``twin calibrate`` is asked to do.

    Attributes
    ----------
    logs : list of Path
        Logs of one vehicle or tester (several = several runs).
    columns : ColumnMap
        How to read a delimited log.
    imu : str
        IMU instance to calibrate, or ``all``.
    reverse : bool
        Also validate cooling → heating (not only heating → cooling).
    device_id : int, optional
        The accelerometer's device id when the log does not record it.
    with_effects : list of str
        Library effects the composed twin adds on every axis.
    effects_from : Path, optional
        A ``twin compare --axes … --json`` result: the effects it named, per IMU and axis.
    plugins : list of str
        Effect modules to load for ``with_effects``.
    part : str
        Part set whose datasheet TCOff/TCSo bound a plausible fit.
    workers : int, optional
        Processes calibrating IMUs side by side (default: one per IMU, at most one per CPU).
    """

    logs: list[Path] = Field(min_length=1)
    columns: ColumnMap = Field(default_factory=ColumnMap)
    imu: str = "all"
    reverse: bool = True
    device_id: int | None = None
    with_effects: list[str] = []
    effects_from: Path | None = None
    plugins: list[str] = []
    part: str = "IIS328DQ"
    workers: int | None = Field(default=None, ge=1)


@dataclass(frozen=True, eq=False)
class CalibrationRun:
    """What a calibration produced.

    Attributes
    ----------
    calibrations : list of ImuCalibration
        One per IMU calibrated, with its validation and recommendation.
    skipped : dict of int to str
        IMU instance → why it was not calibrated.
    document : CalibrationDocument
        The versioned calibration document (``-o CAL.json``; ``document.to_json()`` is its JSON).
    logs : dict of int to list of ImuLog
        Each IMU's logs, as calibrated (for the report's plots).
    """

    calibrations: list
    skipped: dict[int, str]
    document: CalibrationDocument
    logs: dict

    def write_report(self, folder: Path) -> Path:
        """Write ``report.html`` into ``folder`` (after the document: a failed report loses no calibration).

        Parameters
        ----------
        folder : Path

        Returns
        -------
        Path
        """
        from twin.calibration.report import write_calibration_report

        return write_calibration_report(folder, self.calibrations, self.logs)


def composed_methods(with_effects: list[str], effects_from: Path | None, plugins: list[str]):
    """The composed twins asked for: extra methods for every IMU, and per IMU the effects compare named.

    Parameters
    ----------
    with_effects : list of str
    effects_from : Path, optional
    plugins : list of str
        Loaded first (their effects may be named).

    Returns
    -------
    extra : dict of str to ComposedCompensator
    compared : dict of int to dict of str to list of str
        IMU instance → axis → effect names.
    """
    if not (with_effects or effects_from or plugins):
        return {}, {}
    from twin.calibration.composed import ComposedCompensator, effects_named_by_compare
    from twin.effects import get_effect
    from twin.io import read_json
    from twin.plugins import import_plugin

    for spec in plugins:
        import_plugin(spec)
    for name in with_effects:
        get_effect(name)  # an unknown name: "did you mean", before any fitting
    names = tuple(dict.fromkeys(with_effects))
    extra = {"twin+" + "+".join(names): ComposedCompensator(names)} if names else {}
    compared = (effects_named_by_compare(read_json(effects_from, "compare result", TwinError), str(effects_from))
                if effects_from else {})
    for named in compared.values():
        for axis, effect_names in named.items():
            for name in effect_names:
                try:
                    get_effect(name)
                except TwinError as exc:
                    raise TwinError(f"{effects_from}: axis {axis}: {exc} (load its plugin with --plugin)") from None
    return extra, compared


def run_calibrate(opts: CalibrateOptions) -> CalibrationRun:
    """Fit and validate every method per IMU, and build the calibration document.

    Parameters
    ----------
    opts : CalibrateOptions

    Returns
    -------
    CalibrationRun
    """
    from twin import __version__
    from twin.measurement import imu_logs_by_instance

    extra, compared = composed_methods(opts.with_effects, opts.effects_from, opts.plugins)
    per = imu_logs_by_instance(opts.logs, opts.columns, opts.imu)
    from twin.calibration.document import calibration_document, file_provenance
    from twin.calibration.plausibility import limits_for_part
    from twin.calibration.workflow import calibrate_imus

    if opts.device_id is not None and len(per) > 1:
        raise TwinError(f"--device-id names one sensor, but the logs hold IMU instances {sorted(per)}; "
                        "choose one with --imu")
    results, skipped = calibrate_imus(per, reverse=opts.reverse, device_id=opts.device_id,
                                      limits=limits_for_part(opts.part), extra_methods=extra, compared=compared,
                                      workers=opts.workers)
    document = calibration_document(results, file_provenance(opts.logs), __version__, skipped)
    return CalibrationRun(results, skipped, document, per)
