"""Self-contained HTML report of a compare run (plots embedded as PNG), and the ledger.

matplotlib is imported here only, so ``import twin`` stays light. Plots follow
diagnosis-methods §1 step 2: measured vs twin, residual with its noise band, residual vs
temperature (heating/cooling), ±1 g half-sum/half-difference, dwell settling, ACF and Allan
deviation against a noise-only reference, the ranking, and the error falling over the ledger.
"""

from __future__ import annotations

import base64
import datetime as _dt
import hashlib
import html
import io
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


def _png(fig) -> str:
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=90, bbox_inches="tight")
    import matplotlib.pyplot as plt

    plt.close(fig)
    return base64.b64encode(buf.getvalue()).decode()


def _figures(d: Diagnosis, ledger: list[dict]) -> list[tuple[str, str]]:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from twin.diagnosis.noise import allan_deviation

    p, cal, m = d.problem, d.calibration, d.problem.m
    t_h = m.time_s / 3600
    stride = max(1, p.n // 20000)  # plotting 20k points shows the same picture
    pred = p.applied + cal.prediction_minus_applied
    r_mg = cal.residual * 1e3
    figs = []
    kind = d.segments["kind"]

    fig, ax = plt.subplots(figsize=(10, 3.6))
    ax.plot(t_h[::stride], m.output_g[::stride] * 1e3, ",", color="0.6", label="measured")
    ax.plot(t_h[::stride], pred[::stride] * 1e3, "-", color="C0", lw=1, label="twin")
    for k, c in (("heating", "C3"), ("cooling", "C0")):
        sel = kind == k
        if sel.any():
            ax.fill_between(t_h[::stride], 0, 1, where=sel[::stride], transform=ax.get_xaxis_transform(), color=c,
                            alpha=0.07, label=k)
    ax.set_xlabel("time [h]")
    ax.set_ylabel("output [mg]")
    ax2 = ax.twinx()
    ax2.plot(t_h[::stride], m.temperature_c[::stride], color="C1", lw=0.8)
    ax2.set_ylabel("temperature [°C]", color="C1")
    ax.legend(loc="upper left", fontsize=8, ncol=4)
    figs.append(("Measured vs twin (heating/cooling shaded; temperature on the right)", _png(fig)))

    fig, ax = plt.subplots(figsize=(10, 3.2))
    ax.plot(t_h[::stride], r_mg[::stride], ",", color="0.5")
    w = max(1, int(600 * p.rate_hz))
    from scipy.ndimage import uniform_filter1d

    ax.plot(t_h, uniform_filter1d(r_mg, w, mode="nearest"), color="C3", lw=1.2, label="10-min mean")
    ax.axhspan(-2 * d.noise_floor_g * 1e3, 2 * d.noise_floor_g * 1e3, color="C2", alpha=0.12, label="±2σ noise floor")
    ax.set_xlabel("time [h]")
    ax.set_ylabel("residual [mg]")
    ax.legend(fontsize=8)
    figs.append(("Residual (measured − twin) with the noise band", _png(fig)))

    fig, ax = plt.subplots(figsize=(6.5, 4.2))
    ravg, tavg = p.avg(cal.residual) * 1e3, p.avg(p.inputs.die_c)
    kavg = np.array(kind)[p.avg.starts]
    for k, c in (("heating", "C3"), ("cooling", "C0"), ("dwell", "0.5")):
        sel = kavg == k
        ax.plot(tavg[sel], ravg[sel], ".", ms=3, color=c, label=k)
    area = ", ".join(f"run {k}: {v:.2f}" for k, v in d.segments["loop_area_mg_c"].items())
    ax.set_title(f"loop area ∮r dT [mg·°C]: {area}", fontsize=9)
    ax.set_xlabel("temperature [°C]")
    ax.set_ylabel(f"residual, {p.config.average_s:g}-s mean [mg]")
    ax.legend(fontsize=8)
    figs.append(("Hysteresis view: residual vs temperature", _png(fig)))

    if m.applied_known and np.any(np.isclose(p.applied, 1)) and np.any(np.isclose(p.applied, -1)):
        fig, ax = plt.subplots(figsize=(6.5, 4))
        bins = np.linspace(tavg.min(), tavg.max(), 25)
        aavg = p.avg(p.applied)
        rp = [np.mean(ravg[(aavg > 0.9) & (tavg >= a) & (tavg < b)]) if np.any((aavg > 0.9) & (tavg >= a) & (tavg < b)) else np.nan
              for a, b in zip(bins[:-1], bins[1:])]
        rn = [np.mean(ravg[(aavg < -0.9) & (tavg >= a) & (tavg < b)]) if np.any((aavg < -0.9) & (tavg >= a) & (tavg < b)) else np.nan
              for a, b in zip(bins[:-1], bins[1:])]
        mid = 0.5 * (bins[1:] + bins[:-1])
        ax.plot(mid, 0.5 * (np.array(rp) + rn), "o-", label="half-sum (bias-like)")
        ax.plot(mid, 0.5 * (np.array(rp) - rn), "s-", label="half-difference (scale-factor-like)")
        ax.set_xlabel("temperature [°C]")
        ax.set_ylabel("residual [mg]")
        ax.legend(fontsize=8)
        figs.append(("±1 g half-sum and half-difference", _png(fig)))

    # dwell settling: residual after each dwell start
    dwell = kind == "dwell"
    starts = np.flatnonzero(np.diff(dwell.astype(int)) == 1) + 1
    if starts.size:
        fig, ax = plt.subplots(figsize=(6.5, 3.8))
        w = max(1, int(60 * p.rate_hz))
        for s in starts[:8]:
            e = s
            while e < dwell.size and dwell[e]:
                e += 1
            seg = uniform_filter1d(r_mg[s:e], w, mode="nearest")
            ax.plot((m.time_s[s:e] - m.time_s[s]) / 60, seg, lw=1)
        ax.set_xlabel("time since dwell start [min]")
        ax.set_ylabel("residual, 1-min mean [mg]")
        figs.append(("Dwell settling (minutes: lag; hours: creep; flat: static)", _png(fig)))

    fig, axes = plt.subplots(1, 2, figsize=(11, 3.8))
    ra = p.avg(cal.residual)
    lags = np.arange(1, min(60, ra.size // 4))
    acf = [np.corrcoef(ra[:-k], ra[k:])[0, 1] for k in lags]
    axes[0].bar(lags * p.config.average_s / 60, acf, width=p.config.average_s / 60 * 0.8)
    axes[0].axhline(1.96 / np.sqrt(ra.size), color="k", ls=":")
    axes[0].axhline(-1.96 / np.sqrt(ra.size), color="k", ls=":")
    axes[0].set_xlabel("lag [min]")
    axes[0].set_ylabel("residual ACF")
    taus, adev = allan_deviation(cal.residual, p.rate_hz)
    axes[1].loglog(taus, adev * 1e3, label="residual")
    axes[1].loglog(taus, d.noise_floor_g * 1e3 / np.sqrt(taus * p.rate_hz), "--", label="white noise at the floor")
    if d.noise_floor_model_g:
        axes[1].loglog(taus, d.noise_floor_model_g * 1e3 / np.sqrt(taus * p.rate_hz), ":", label="sensor model")
    axes[1].set_xlabel("averaging time [s]")
    axes[1].set_ylabel("Allan deviation [mg]")
    axes[1].legend(fontsize=8)
    figs.append(("Residual autocorrelation and Allan deviation against a noise-only reference", _png(fig)))

    top = d.candidates[:8]
    if top:
        fig, ax = plt.subplots(figsize=(7, 3.6))
        vals = [max(c.delta_bic, 0.1) for c in top]
        colors = ["C3" if c.significant else "0.6" for c in top]
        ax.barh([f"{c.effect} ({c.family})" for c in top][::-1], vals[::-1], color=colors[::-1])
        ax.set_xscale("log")
        ax.axvline(p.config.min_delta_bic, color="k", ls=":")
        ax.set_xlabel("ΔBIC (red: significant)")
        figs.append(("Candidate ranking", _png(fig)))

    if len(ledger) > 1:
        fig, ax = plt.subplots(figsize=(7, 3.6))
        labels = ["+".join(e["model"]) if len(e["model"]) < 4 else f"… +{e['model'][-1]}" for e in ledger]
        ax.plot(range(len(ledger)), [e["rms_residual_g"] * 1e3 for e in ledger], "o-", label="residual RMS")
        ax.plot(range(len(ledger)), [e["noise_floor_g"] * 1e3 for e in ledger], "--", label="noise floor")
        ax.set_xticks(range(len(ledger)), labels, rotation=20, ha="right", fontsize=7)
        ax.set_ylabel("mg")
        ax.legend(fontsize=8)
        figs.append(("The error falling as effects are added (ledger)", _png(fig)))
    return figs


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
<h2>Test-plan audit: what this data cannot tell apart</h2>{_table(audit, ['effects', 'aliased with / why', 'what would separate them'])}
<h2>Candidates (best first)</h2>{_table(cands, ['effect', 'family', 'significant', 'ΔBIC', 'p (Bonferroni)', 'held-out gain', 'explained', 'RMS after [mg]', 'grid'])}
<h2>Parameters (95 % intervals)</h2>{_table(params, ['effect', 'parameter', 'value', 'unit', '95 % CI', 'flag'])}
<h2>Ledger: the error step by step</h2>{_table(led, ['time', 'model', 'RMS [mg]', 'held-out [mg]', 'floor [mg]', 'ΔBIC vs previous'])}
<h2>Where it fails</h2>{_table(seg_rows, ['group', 'value', 'RMS [mg]'])}
{imgs}
</body></html>"""
    return atomic_write_text(directory / "report.html", page)
