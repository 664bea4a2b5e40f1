"""Self-contained HTML report of a compare run (plots embedded as PNG), and the ledger.

matplotlib is imported here only, so ``import twin`` stays light. Plots follow
docs/diagnosis.md §1 step 2: measured vs twin, residual with its noise band, residual vs
temperature (heating/cooling), ±1 g half-sum/half-difference, dwell settling, ACF and Allan
deviation against a noise-only reference, the ranking, and the error falling over the ledger.
"""

from __future__ import annotations

import datetime as _dt
import hashlib
import html
import json
from pathlib import Path

import numpy as np

from twin.diagnosis.diagnose import Diagnosis
from twin.io import atomic_write_text

LEDGER = "ledger.jsonl"


def data_fingerprint(d: Diagnosis) -> str:
    m = d.problem.m
    h = hashlib.sha256()
    for a in (m.time_s, m.temperature_c, m.output_g):
        h.update(np.ascontiguousarray(a).tobytes())
    return h.hexdigest()[:16]


def append_ledger(directory: Path, d: Diagnosis, result: dict) -> list[dict]:
    """Append this model's errors to ``ledger.jsonl`` and return the entries for this data."""
    directory.mkdir(parents=True, exist_ok=True)
    path = directory / LEDGER
    fp = data_fingerprint(d)
    entries = []
    if path.is_file():
        for line in path.read_text().splitlines():
            try:
                e = json.loads(line)
            except json.JSONDecodeError:
                continue
            if e.get("data") == fp:
                entries.append(e)
    cal = d.calibration
    ya = d.problem.avg(d.problem.y - cal.fixed_full)
    A = d.problem.avg(cal.X_full)
    rw = cal.ar.prewhiten(ya - A @ cal.beta, d.problem.run_avg)
    entry = {
        "time_utc": _dt.datetime.now(_dt.timezone.utc).isoformat(timespec="seconds"),
        "data": fp,
        "model": result["effects"],
        "rms_residual_g": result["rms_residual_g"],
        "heldout_rms_g": result["heldout_rms_g"],
        "noise_floor_g": result["noise_floor_g"],
        "rss_prewhitened": float(rw @ rw),
        "n_blocks": int(rw.size),
        "n_parameters": int(A.shape[1]),
    }
    prev = entries[-1] if entries else None
    if prev and prev.get("n_blocks") == entry["n_blocks"]:
        n = entry["n_blocks"]
        entry["delta_bic"] = float(n * np.log(prev["rss_prewhitened"] / entry["rss_prewhitened"])
                                   - (entry["n_parameters"] - prev["n_parameters"]) * np.log(n))
    else:
        entry["delta_bic"] = None
    with path.open("a") as f:
        f.write(json.dumps(entry) + "\n")
    return entries + [entry]


def _figures(d: Diagnosis, ledger: list[dict]) -> list[tuple[str, str]]:
    """(title, base64 PNG) of every display of the report."""
    from twin.reporting.plots import diagnosis_displays, png_base64

    return [(disp.title, png_base64(disp.plot())) for disp in diagnosis_displays(d, ledger)]


def _table(rows: list[list], header: list[str]) -> str:
    head = "".join(f"<th>{html.escape(h)}</th>" for h in header)
    body = "".join("<tr>" + "".join(f"<td>{html.escape(str(c))}</td>" for c in r) + "</tr>" for r in rows)
    return f"<table><tr>{head}</tr>{body}</table>"


def write_report(directory: Path, d: Diagnosis, result: dict, ledger: list[dict], title: str = "twin compare") -> Path:
    """Write ``report.html`` (self-contained) into ``directory``."""
    directory.mkdir(parents=True, exist_ok=True)
    figs = _figures(d, ledger)
    mg = lambda g: f"{g * 1e3:.3f}"  # noqa: E731
    params = []
    for eff, entry in result["parameters"].items():
        if eff == "nuisance":
            continue
        for name, item in entry.items():
            if item["role"] == "fixed":
                continue
            ci = item.get("ci95")
            flag = ("ON BOUND" if item["on_bound"] else "OUTSIDE RANGE" if item["outside_physical_range"]
                    else item.get("pinned", ""))
            params.append([eff, name, f"{item['value']:.4g}", item["unit"],
                           f"[{ci[0]:.4g}, {ci[1]:.4g}]" if ci else "-", flag])
    cands = [[c["effect"], c["family"], "yes" if c["significant"] else "no", f"{c['delta_bic']:.1f}",
              f"{c['p_adjusted']:.2g}", f"{100 * c['heldout_gain']:.1f} %", f"{100 * c['explained_fraction']:.1f} %",
              mg(c["rms_residual_g"]), ", ".join(f"{k}={v:.3g}" for k, v in c["parameters"].items())]
             for c in result["candidates"]]
    seg = result["residual"]
    seg_rows = [[group, k, mg(v)] for group in ("segment", "orientation", "run", "temperature_bin_c")
                for k, v in seg.get(group, {}).items()]
    led = [[e["time_utc"], " + ".join(e["model"]), mg(e["rms_residual_g"]), mg(e["heldout_rms_g"]), mg(e["noise_floor_g"]),
            "-" if e.get("delta_bic") is None else f"{e['delta_bic']:.1f}"] for e in ledger]
    audit = ([[", ".join(a["effects"]), a.get("aliased_with", "each other"), a["remedy"]] for a in result["aliases"]]
             + [[u["effect"], u["reason"], u["remedy"]] for u in result["untestable"]])
    imgs = "".join(f"<h3>{html.escape(t)}</h3><img src='data:image/png;base64,{b}'>" for t, b in figs)
    page = f"""<!doctype html><html><head><meta charset="utf-8"><title>{html.escape(title)}</title>
<style>body{{font-family:sans-serif;max-width:1150px;margin:auto;padding:1em}} table{{border-collapse:collapse;margin:.5em 0}}
td,th{{border:1px solid #ccc;padding:2px 6px;font-size:13px}} .finding{{background:#f4f7ff;padding:.8em;border-left:4px solid #36c}}
img{{max-width:100%}}</style></head><body>
<h1>{html.escape(title)}</h1>
<p class="finding">{html.escape(result['finding'])}</p>
<p>Residual RMS <b>{mg(result['rms_residual_g'])} mg</b> at {result['sample_rate_hz']:.3g} Hz;
noise floor {mg(result['noise_floor_g'])} mg from the data{'' if result['noise_floor_model_g'] is None else f", {mg(result['noise_floor_model_g'])} mg from the sensor model"};
held-out RMS ({result['noise_model']['average_s']:g}-s means) {mg(result['heldout_rms_g'])} mg.
Missing effect detected: <b>{result['missing_effect_detected']}</b> ({result['confidence']}). Model: {', '.join(result['effects'])}.
Noise model AR({result['noise_model']['ar_order']}).</p>
{_finding_sections(result)}
<h2>Test-plan audit: what this data cannot tell apart</h2>{_table(audit, ['effects', 'aliased with / why', 'what would separate them'])}
<h2>Candidates (best first)</h2>{_table(cands, ['effect', 'family', 'significant', 'ΔBIC', 'p (Bonferroni)', 'held-out gain', 'explained', 'RMS after [mg]', 'grid'])}
<h2>Parameters (95 % intervals)</h2>{_table(params, ['effect', 'parameter', 'value', 'unit', '95 % CI', 'flag'])}
<h2>The calibrated twin</h2><pre>{html.escape(d.calibration.equation(d.problem.nuisance_names))}</pre>
<h2>Ledger: the error step by step</h2>{_table(led, ['time', 'model', 'RMS [mg]', 'held-out [mg]', 'floor [mg]', 'ΔBIC vs previous'])}
<h2>Where it fails</h2>{_table(seg_rows, ['group', 'value', 'RMS [mg]'])}
{imgs}
</body></html>"""
    return atomic_write_text(directory / "report.html", page)


def _finding_sections(result: dict) -> str:
    """Look-alike mechanisms, residual structure and the discovery, when the result has them."""
    out = []
    if result.get("lookalikes"):
        rows = [[m["name"], "yes" if m["in_library"] else "no", m["effect"] or "-", m["reason"], m["test"]]
                for m in result["lookalikes"]]
        out.append(f"<h2>Look-alike mechanisms (attribution to a {html.escape(result.get('attribution', '-'))})</h2>"
                   + _table(rows, ["mechanism", "in library", "effect", "why it makes this signature", "test that separates"]))
    if result.get("structure"):
        rows = [[s["grouping"], f"{s['rms_g'] * 1e3:.3f}", s["where"], f"{s['departure_g'] * 1e3:+.3f}",
                 f"{s['delta_bic']:.1f}", f"{s['p_adjusted']:.2g}"] for s in result["structure"]]
        out.append("<h2>Structure the model leaves (not white noise)</h2>"
                   + _table(rows, ["grouping", "RMS [mg]", "largest at", "departure [mg]", "ΔBIC", "p (Bonferroni)"]))
    disc = result.get("discovery")
    if disc:
        rows = [[t["feature"]["label"], f"{t['coefficient_mg']:.4g} ± {t['ci95_half_width_mg']:.2g}",
                 t["feature"]["unit"], f"{t['delta_bic']:.1f}", f"{t['p_adjusted']:.2g}"] for t in disc["terms"]]
        head = (f"<p><b>{html.escape(disc['equation'] or 'nothing proposed')}</b> — {html.escape(disc['reason'])}; "
                f"{disc['features_tried']} terms tried; held-out gain {100 * disc['heldout_gain']:.1f} %; "
                f"ΔBIC {disc['delta_bic']:.1f}; RMS {disc['rms_before_g'] * 1e3:.3f} → "
                f"{disc['rms_predicted_g'] * 1e3:.3f} mg; plugin: {html.escape(str(disc.get('plugin') or '-'))}</p>")
        beaten = _table([[b["feature"], f"{b['delta_bic']:.1f}"] for b in disc["beaten"]], ["feature it beat", "ΔBIC"])
        out.append("<h2>Discovery: a term outside the library</h2>" + head
                   + (_table(rows, ["term", "coefficient [mg per unit]", "unit", "ΔBIC", "p (× terms tried)"]) if rows else "")
                   + beaten)
    return "\n".join(out)


def _ledger(ledger_dir: Path | None, report: Path | None, d, result: dict, title: str) -> None:
    """Append to the ledger beside the report (or the JSON) and write the report; adds ``ledger`` to ``result``."""
    if ledger_dir is None:
        return
    ledger = append_ledger(ledger_dir, d, result)
    result["ledger"] = [{k: e[k] for k in ("model", "rms_residual_g", "heldout_rms_g", "noise_floor_g", "delta_bic")}
                        for e in ledger]
    if report is not None:
        write_report(report, d, result, ledger, title=title)


def _finish(d, result: dict, discover: bool, plugin_path: Path | None, sources: list[str]) -> None:
    """The finding's extra fields (look-alikes, structure) and, with ``discover``, the discovery."""
    from twin.diagnosis.discover_report import discover_into, extras_json

    if discover:
        discover_into(d, result, plugin_path, sources)
    else:
        result.update(extras_json(d))


def _plugin_target(discover_plugin: Path | None, report: Path | None, suffix: str = "") -> Path | None:
    from twin.diagnosis.discover_report import PLUGIN_NAME

    if discover_plugin is not None:
        return discover_plugin if not suffix else discover_plugin.with_name(f"{discover_plugin.stem}_{suffix}.py")
    return None if report is None else (report / suffix / PLUGIN_NAME if suffix else report / PLUGIN_NAME)


def run_compare(scenario: Path, measurements: list[Path], cmap, with_effects: list[str], applied,
                skip_bad_rows: bool, average_s: float, report: Path | None, json_out: str | None,
                axes: list[str] | None = None, imu: str | None = None, discover: bool = False,
                discover_plugin: Path | None = None, plugins: list[str] | None = None) -> dict:
    """``twin compare`` on files: one axis (the classic result), or ``axes`` of every IMU in ``imu``
    (``"all"`` or an instance number), each with its report in ``REPORT/imu{n}_{axis}``.

    ``plugins``: effect modules to load; the effects they register are added to the twin.
    ``discover``: search for a term outside the library; a proposed one is written as a plugin to
    ``discover_plugin`` (or ``REPORT/discovered_effect.py``)."""
    from twin.diagnosis.axes import compare_imu
    from twin.diagnosis.compare import compare_measurement
    from twin.effects import load_plugin
    from twin.measurement import imu_logs_by_instance, load_measurements
    from twin.model.scenario import load_scenario

    loaded = load_scenario(scenario)
    with_effects = list(with_effects)
    for spec in plugins or []:
        with_effects += [n for n in load_plugin(spec) if n not in with_effects]
    ledger_dir = report if report is not None else (Path(json_out).parent if json_out not in (None, "-") else None)
    names = ", ".join(p.name for p in measurements)
    sources = [str(p) for p in measurements]
    if not axes:
        m = load_measurements(measurements, cmap, skip_bad_rows=skip_bad_rows, applied_g=applied)
        d, result = compare_measurement(loaded, m, with_effects, average_s)
        _finish(d, result, discover, _plugin_target(discover_plugin, report), sources)
        _ledger(ledger_dir, report, d, result, f"twin compare: {names}")
        return result
    per_instance = imu_logs_by_instance(measurements, cmap, imu, skip_bad_rows=skip_bad_rows)
    out = []
    for instance, logs in sorted(per_instance.items()):
        joint = compare_imu(loaded, logs, axes, with_effects, average_s, applied)
        for axis, d in joint.diagnoses.items():
            sub = lambda base: None if base is None else base / f"imu{instance}_{axis}"  # noqa: E731
            _finish(d, joint.results[axis], discover, _plugin_target(discover_plugin, report, f"imu{instance}_{axis}"),
                    sources)
            _ledger(sub(ledger_dir), sub(report), d, joint.results[axis], f"twin compare: {names}, IMU {instance} {axis}")
        out.append(joint.json())
    return {"imus": out, "finding": " ".join(f"IMU {j['instance']}: {j['finding']}" for j in out)}
