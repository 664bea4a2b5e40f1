"""One unit's analysis, run in a worker process: compare (the twin against its logs) or
calibrate (its IMUs), summarised as one ledger record. A unit whose logs are bad is recorded with
its one-line error; nothing a unit does stops the fleet."""

from __future__ import annotations

import functools
import json
import time
from pathlib import Path

from twin.errors import TwinError
from twin.io import atomic_write_text


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


def compare_parameters(result: dict) -> dict[str, dict]:
    """``effect.parameter`` → value, unit, 95 % interval (when fitted) for the twin's free
    parameters, and for each named effect its refined nonlinear parameters and amplitudes."""
    out: dict[str, dict] = {}
    for eff, entry in result["parameters"].items():
        if eff == "nuisance":
            continue
        for name, item in entry.items():
            if item["role"] == "fixed" or "ci95" not in item:
                continue
            out[f"{eff}.{name}"] = {"value": item["value"], "unit": item["unit"], "ci95": item["ci95"]}
    for c in result["candidates"]:
        if c["effect"] not in result["selected"]:
            continue
        units = _effect_units(c["effect"])
        values = {**c["parameters"], **c.get("parameters_refined", {})}
        for name, v in values.items():
            if name in units and units[name] and not (name.endswith("2_s") and v == 0):
                out.setdefault(f"{c['effect']}.{name}", {"value": v, "unit": units[name], "ci95": None})
        for name, a in c["amplitudes"].items():
            half = a["ci95_half_width"]
            out.setdefault(f"{c['effect']}.{name}", {"value": a["value"], "unit": units.get(name, ""),
                                                     "ci95": [a["value"] - half, a["value"] + half]})
    return out


def _compare(unit: dict, settings: dict, unit_dir: Path, rel: str) -> dict:
    from twin.diagnosis.axes import check_applied_measurement
    from twin.diagnosis.compare import compare_measurement
    from twin.effects import get_effect
    from twin.measurement import load_measurements

    opt = settings["options"]
    loaded = _scenario(settings["scenario"])
    m = load_measurements([Path(f) for f in unit["files"]], _column_map(settings["columns"]),
                          skip_bad_rows=opt["skip_bad_rows"], applied_g=opt["applied_g"])
    if isinstance(opt["applied_g"], (int, float)):  # as twin compare: a given g the still rows contradict is refused
        check_applied_measurement(m, float(opt["applied_g"]))
    d, result = compare_measurement(loaded, m, list(opt["with_effects"]), float(opt["average_s"]))
    params = compare_parameters(result)
    if opt["refit"] and result["selected"]:  # the named effects calibrated whole: intervals for τ, widths
        _, refit = compare_measurement(loaded, m, list(opt["with_effects"]) + result["selected"], float(opt["average_s"]))
        params.update(compare_parameters({**refit, "candidates": [], "selected": []}))
        result["refit"] = {k: refit[k] for k in ("rms_residual_g", "heldout_rms_g", "effects", "parameters")}
    reports = {"json": f"{rel}/compare.json"}
    atomic_write_text(unit_dir / "compare.json", json.dumps(result, indent=1, default=float) + "\n")
    if opt["report"]:
        from twin.reporting.compare_report import append_ledger, write_report

        ledger = append_ledger(unit_dir, d, result)
        write_report(unit_dir, d, result, ledger, title=f"twin fleet: unit {unit['unit']}")
        reports["html"] = f"{rel}/report.html"
    floor = result["noise_floor_g"]
    return {
        "named": list(result["selected"]),
        "families": [get_effect(n).family for n in result["selected"]],
        "confidence": result["confidence"],
        "detected": result["missing_effect_detected"],
        "withheld": result["withheld"],
        "finding": result["finding"],
        "parameters": params,
        "rms_residual_mg": result["rms_residual_g"] * 1e3,
        "noise_floor_mg": floor * 1e3,
        "residual_over_floor": result["rms_residual_g"] / floor if floor else None,
        "heldout_rms_mg": result["heldout_rms_g"] * 1e3,
        "samples": result["samples"],
        "reports": reports,
    }


def _calibrate(unit: dict, settings: dict, unit_dir: Path, rel: str) -> dict:
    from twin import __version__
    from twin.calibration.document import calibration_json, file_provenance
    from twin.calibration.workflow import calibrate_imu
    from twin.measurement import imu_logs_by_instance

    opt = settings["options"]
    files = [Path(f) for f in unit["files"]]
    per = imu_logs_by_instance(files, _column_map(settings["columns"]), opt["imu"], skip_bad_rows=opt["skip_bad_rows"])
    results = [calibrate_imu(group, reverse=opt["reverse"]) for _, group in sorted(per.items())]
    doc = calibration_json(results, file_provenance(files), __version__)
    atomic_write_text(unit_dir / "cal.json", json.dumps(doc, indent=1, default=float) + "\n")
    params, rms = {}, []
    for c in results:
        rec = c.recommended()
        for target, method in rec.items():
            per_axis = c.heldout_rms_mg(method)
            for axis, v in zip("xyz", per_axis):
                params[f"imu{c.instance}.{target}.heldout_rms_mg.{axis}"] = {"value": float(v), "unit": "mg", "ci95": None}
        best = min(c.fitted, key=lambda m: float((c.heldout_rms_mg(m) ** 2).sum()))
        rms.append(float((c.heldout_rms_mg(best) ** 2).mean() ** 0.5))
        for axis, v in zip("xyz", c.validation.noise_floor_mg):
            params[f"imu{c.instance}.noise_floor_mg.{axis}"] = {"value": float(v), "unit": "mg", "ci95": None}
    return {"named": [], "families": [], "confidence": None, "detected": None, "withheld": [],
            "finding": "; ".join(f"IMU {c.instance}: " + ", ".join(f"{t} {m}" for t, m in c.recommended().items())
                                 for c in results),
            "recommended": {str(c.instance): c.recommended() for c in results},
            "parameters": params, "rms_residual_mg": max(rms) if rms else None, "noise_floor_mg": None,
            "residual_over_floor": None, "heldout_rms_mg": max(rms) if rms else None,
            "samples": sum(c.samples for c in results), "reports": {"json": f"{rel}/cal.json"}}


def evaluate_unit(unit: dict, settings: dict, out_dir: str) -> dict:
    """Analyse one unit (``{"unit": id, "files": [...]}``) as ``settings`` say; its files go to
    ``out_dir/units/<id>/``. Never raises for a unit's own failure: the record says ``error``."""
    t0 = time.perf_counter()
    rel = f"units/{unit['unit']}"
    out = {"unit": unit["unit"], "files": list(unit["files"]), "command": settings["command"]}
    try:
        unit_dir = Path(out_dir) / rel
        unit_dir.mkdir(parents=True, exist_ok=True)
        run = _compare if settings["command"] == "compare" else _calibrate
        out.update(run(unit, settings, unit_dir, rel))
        out["status"] = "ok"
    except (TwinError, OSError, ValueError) as exc:  # a bad log: recorded, the fleet goes on
        out.update(status="error", error=" ".join(f"{exc}".split())[:400])
    except Exception as exc:  # noqa: BLE001  (an internal failure on one unit must not stop the others)
        out.update(status="error", error=f"internal: {type(exc).__name__}: " + " ".join(f"{exc}".split())[:300])
    out["seconds"] = time.perf_counter() - t0
    return out
