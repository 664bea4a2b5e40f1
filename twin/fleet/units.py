"""One unit's analysis, run in a worker process: compare (the twin against its logs) or
calibrate (its IMUs), summarised as one :class:`~twin.fleet.result.FleetRow`. A unit whose logs
are bad is recorded with its one-line error; nothing a unit does stops the fleet."""

from __future__ import annotations

import functools
import json
import time
from pathlib import Path

from twin.errors import TwinError
from twin.fleet.result import FleetRow, ParameterValue, UnitReports
from twin.io import atomic_write_text, strict_json


@functools.lru_cache(maxsize=4)
def _scenario(path: str):
    from twin.model.scenario import load_scenario

    return load_scenario(Path(path))


def _column_map(columns: dict):
    from twin.measurement import ColumnMap

    return ColumnMap(**columns)


def _effect_units(name: str) -> dict[str, str]:
    from twin.effects import get_effect

    return {p.name: p.unit for p in get_effect(name).parameters}


def fitted_parameters(result) -> dict[str, ParameterValue]:
    """``effect.parameter`` → value, unit, 95 % interval for the twin's fitted parameters.

    Parameters
    ----------
    result : CompareResult

    Returns
    -------
    dict of str to ParameterValue
        In each parameter's unit.
    """
    return {f"{eff}.{name}": ParameterValue(float(item.value), item.unit, (float(item.ci95[0]), float(item.ci95[1])))
            for eff, entry in result.parameters.items() for name, item in entry.items()
            if item.role != "fixed" and item.ci95 is not None}


def compare_parameters(result) -> dict[str, ParameterValue]:
    """``effect.parameter`` → value, unit, 95 % interval (when fitted) for the twin's free
    parameters, and for each named effect its refined nonlinear parameters and amplitudes.

    Parameters
    ----------
    result : CompareResult

    Returns
    -------
    dict of str to ParameterValue
        In each parameter's unit.
    """
    out = fitted_parameters(result)
    for effect in result.selected:
        c = result.candidate(effect)
        units = _effect_units(effect)
        for name, v in {**c.parameters, **(c.parameters_refined or {})}.items():
            if name in units and units[name] and not (name.endswith("2_s") and v == 0):
                out.setdefault(f"{effect}.{name}", ParameterValue(float(v), units[name], None))
        for name, a in c.amplitudes.items():
            out.setdefault(f"{effect}.{name}", ParameterValue(
                float(a.value), units.get(name, ""),
                (float(a.value - a.ci95_half_width), float(a.value + a.ci95_half_width))))
    return out


def _compare(unit: dict, settings: dict, unit_dir: Path, rel: str) -> FleetRow:
    from twin.diagnosis.axes import check_applied_measurement
    from twin.effects import get_effect
    from twin.finding.build import compare_measurement
    from twin.measurement import load_measurements
    from twin.results import to_json

    opt = settings["options"]
    loaded = _scenario(settings["scenario"])
    m = load_measurements([Path(f) for f in unit["files"]], _column_map(settings["columns"]),
                          skip_bad_rows=opt["skip_bad_rows"], applied_g=opt["applied_g"])
    if isinstance(opt["applied_g"], (int, float)):  # as twin compare: a given g the still rows contradict is refused
        check_applied_measurement(m, float(opt["applied_g"]))
    d, result = compare_measurement(loaded, m, list(opt["with_effects"]), float(opt["average_s"]))
    params = compare_parameters(result)
    doc = result.to_json()
    if opt["refit"] and result.selected:  # the named effects calibrated whole: intervals for τ, widths
        _, refit = compare_measurement(loaded, m, list(opt["with_effects"]) + list(result.selected),
                                       float(opt["average_s"]))
        params.update(fitted_parameters(refit))
        doc["refit"] = {"rms_residual_g": refit.rms_residual_g, "heldout_rms_g": refit.heldout_rms_g,
                        "effects": list(refit.effects), "parameters": to_json(refit.parameters)}
    html = None
    if opt["report"]:
        from twin.reporting.compare_report import ledger_and_report

        recorded = ledger_and_report(unit_dir, unit_dir, d, result, f"twin fleet: unit {unit['unit']}")
        doc["ledger"] = to_json(recorded.ledger)
        html = f"{rel}/report.html"
    atomic_write_text(unit_dir / "compare.json", json.dumps(strict_json(doc), indent=1) + "\n")
    floor = result.noise_floor_g
    return FleetRow(
        unit=unit["unit"], files=tuple(unit["files"]), command="compare",
        named=tuple(result.selected), families=tuple(get_effect(n).family for n in result.selected),
        confidence=result.confidence, detected=result.missing_effect_detected, withheld=tuple(result.withheld),
        finding=result.finding, parameters=params, rms_residual_mg=result.rms_residual_g * 1e3,
        noise_floor_mg=floor * 1e3, residual_over_floor=result.rms_residual_g / floor if floor else None,
        heldout_rms_mg=result.heldout_rms_g * 1e3, samples=result.samples,
        reports=UnitReports(f"{rel}/compare.json", html), status="ok", seconds=0.0)


def _calibrate(unit: dict, settings: dict, unit_dir: Path, rel: str) -> FleetRow:
    from twin import __version__
    from twin.calibration.document import calibration_document, file_provenance
    from twin.calibration.workflow import calibrate_imu
    from twin.measurement import imu_logs_by_instance

    opt = settings["options"]
    files = [Path(f) for f in unit["files"]]
    per = imu_logs_by_instance(files, _column_map(settings["columns"]), opt["imu"], skip_bad_rows=opt["skip_bad_rows"])
    results = [calibrate_imu(group, reverse=opt["reverse"]) for _, group in sorted(per.items())]
    doc = calibration_document(results, file_provenance(files), __version__).to_json()
    atomic_write_text(unit_dir / "cal.json", json.dumps(doc, indent=1, allow_nan=False) + "\n")
    params, rms = {}, []
    for c in results:
        rec = c.recommended()
        for target, method in rec.items():
            per_axis = c.heldout_rms_mg(method)
            for axis, v in zip("xyz", per_axis):
                params[f"imu{c.instance}.{target}.heldout_rms_mg.{axis}"] = ParameterValue(float(v), "mg", None)
        best = min(c.fitted, key=lambda m: float((c.heldout_rms_mg(m) ** 2).sum()))
        rms.append(float((c.heldout_rms_mg(best) ** 2).mean() ** 0.5))
        for axis, v in zip("xyz", c.validation.noise_floor_mg):
            params[f"imu{c.instance}.noise_floor_mg.{axis}"] = ParameterValue(float(v), "mg", None)
    return FleetRow(
        unit=unit["unit"], files=tuple(unit["files"]), command="calibrate", named=(), families=(), withheld=(),
        finding="; ".join(f"IMU {c.instance}: " + ", ".join(f"{t} {m}" for t, m in c.recommended().items())
                          for c in results),
        recommended={str(c.instance): c.recommended() for c in results}, parameters=params,
        rms_residual_mg=max(rms) if rms else None, heldout_rms_mg=max(rms) if rms else None,
        samples=sum(c.samples for c in results), reports=UnitReports(f"{rel}/cal.json"), status="ok", seconds=0.0)


def evaluate_unit(unit: dict, settings: dict, out_dir: str) -> FleetRow:
    """Analyse one unit as ``settings`` say; its files go to ``out_dir/units/<id>/``.

    Never raises for a unit's own failure: the row says ``error``.

    Parameters
    ----------
    unit : dict
        ``{"unit": id, "files": [...]}``.
    settings : dict
        :meth:`twin.fleet.spec.FleetSpec.settings` (plain data: it crosses to worker processes).
    out_dir : str
        The fleet's output folder.

    Returns
    -------
    FleetRow
        Its ``seconds`` the wall time of the analysis [s].
    """
    from dataclasses import replace

    t0 = time.perf_counter()
    rel = f"units/{unit['unit']}"
    try:
        unit_dir = Path(out_dir) / rel
        unit_dir.mkdir(parents=True, exist_ok=True)
        run = _compare if settings["command"] == "compare" else _calibrate
        row = run(unit, settings, unit_dir, rel)
    except (TwinError, OSError, ValueError) as exc:  # a bad log: recorded, the fleet goes on
        row = _failed(unit, settings, " ".join(f"{exc}".split())[:400])
    except Exception as exc:  # noqa: BLE001  (an internal failure on one unit must not stop the others)
        row = _failed(unit, settings, f"internal: {type(exc).__name__}: " + " ".join(f"{exc}".split())[:300])
    return replace(row, seconds=time.perf_counter() - t0)


def _failed(unit: dict, settings: dict, error: str) -> FleetRow:
    return FleetRow(unit=unit["unit"], files=tuple(unit["files"]), command=settings["command"], status="error",
                    error=error, seconds=0.0)
