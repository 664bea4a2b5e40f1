"""Render ``docs/performance.md`` from the benchmarks' JSON, so no figure is copied by hand.

Each ``benchmarks/results/*.json`` is written by a script in ``benchmarks/`` (``make bench``) with
the machine it ran on (CPU model, logical CPUs, BLAS threads, library versions). This page shows,
for each file, that machine and every scalar figure the file holds, by its key path; per-seed and
per-row lists are left in the file. Run at the start of every docs build (``docs/conf.py``).
"""

from __future__ import annotations

import json
import math
from pathlib import Path

#: keys holding per-row detail or the machine, shown elsewhere or left in the file
SKIPPED = {"machine", "rows", "per_seed", "seeds_detail", "runs"}
MAX_DEPTH = 4
MAX_LIST = 6


def _fmt(value) -> str:
    """One figure, as a reader wants it: 4 significant digits, booleans as yes/no, null as —."""
    if value is None:
        return "—"
    if isinstance(value, bool):
        return "yes" if value else "no"
    if isinstance(value, int):
        return f"{value:,}"
    if isinstance(value, float):
        if not math.isfinite(value):
            return "—"
        return f"{value:.4g}"
    return str(value).replace("|", "/")


def _leaves(node, path=()):
    """(key path, value) of every scalar under ``node``; short lists of scalars as one value."""
    if isinstance(node, dict):
        for key, value in node.items():
            if key in SKIPPED or len(path) >= MAX_DEPTH:
                continue
            yield from _leaves(value, path + (str(key),))
    elif isinstance(node, list):
        if len(node) <= MAX_LIST and all(not isinstance(v, (dict, list)) for v in node):
            yield path, ", ".join(_fmt(v) for v in node)
    else:
        yield path, _fmt(node)


def _pivot(name: str, table: dict) -> list[str]:
    """A dict of like records (cases, kinds, sizes) as one table: a row per record, a column per figure."""
    rows = {key: dict((" / ".join(p), v) for p, v in _leaves(rec) if p) for key, rec in table.items()}
    columns = list(dict.fromkeys(c for r in rows.values() for c in r))
    head = f"| {name} | " + " | ".join(columns) + " |"
    return ["", head, "|" + "---|" * (len(columns) + 1)] + \
        [f"| {key} | " + " | ".join(r.get(c, "") for c in columns) + " |" for key, r in rows.items()]


def _is_record_table(value) -> bool:
    return isinstance(value, dict) and len(value) >= 2 and all(isinstance(v, dict) for v in value.values())


def _section(name: str, data: dict) -> list[str]:
    """The Markdown of one benchmark file."""
    machine = data.get("machine", {})
    title = data.get("benchmark", name)
    lines = [f"## {title}", "", f"From `benchmarks/results/{name}.json`."]
    if machine:
        threads = ", ".join(f"{k}={v}" for k, v in machine.get("thread_env", {}).items()) or "library defaults"
        libs = ", ".join(f"{k} {v}" for k, v in sorted(machine.get("libraries", {}).items()))
        lines += ["", f"Measured on **{machine.get('cpu_model', '?')}**, {machine.get('logical_cpus', '?')} logical "
                      f"CPUs, threads: {threads}; Python {machine.get('python', '?')}; {libs}."]
    if isinstance(data.get("wall_s"), (int, float)):
        lines += ["", f"The whole benchmark took {data['wall_s']:.0f} s."]
    rest = {}
    for key, value in data.items():
        if key in ("benchmark", "wall_s") or key in SKIPPED:
            continue
        if _is_record_table(value):
            lines += _pivot(key, value)
        else:
            rest[key] = value
    rows = [(" / ".join(p), v) for p, v in _leaves(rest) if p]
    if rows:
        lines += ["", "| figure | value |", "|---|---|"] + [f"| {p} | {v} |" for p, v in rows]
    return lines + [""]


def _get(data: dict, path: str):
    """``data["a"]["b"]…`` for ``"a/b/…"``, or None where a key is missing."""
    for key in path.split("/"):
        if not isinstance(data, dict) or key not in data:
            return None
        data = data[key]
    return data


#: the speed targets of the issue on calibration and compare at real-log scale: (what, file, path to
#: the measured value, format, target as text, test of the value)
TARGETS = [
    ("2-h 4-IMU PX4 ULog: `twin calibrate` / PX4's script (equivalent), wall", "bench_calibrate_scale",
     "logs/ulog/ratio_wall_to_px4_script", "{:.2f}×", "≤ 1×", lambda v: v <= 1.0),
    ("2-h 4-IMU PX4 ULog: `twin calibrate` / PX4's bare polyfit, wall", "bench_calibrate_scale",
     "logs/ulog/ratio_wall_to_px4", "{:.2f}×", "(lower bound of the script)", None),
    ("6-h tester log, 2.16 M rows: wall", "bench_calibrate_scale", "logs/2.16M/twin_calibrate/wall_s",
     "{:.1f} s", "≤ 30 s", lambda v: v <= 30.0),
    ("6-h tester log, 2.16 M rows: peak memory", "bench_calibrate_scale", "logs/2.16M/twin_calibrate/peak_rss_mb",
     "{:.0f} MB", "≤ 1000 MB", lambda v: v <= 1000.0),
    ("tester log: µs per row at 0.54 M rows", "bench_calibrate_scale", "logs/0.54M/twin_calibrate/us_per_row",
     "{:.2f}", "", None),
    ("tester log: µs per row at 2.16 M rows", "bench_calibrate_scale", "logs/2.16M/twin_calibrate/us_per_row",
     "{:.2f}", "≤ the 0.54 M figure", "per_row"),
    ("24-h 100-Hz log: `twin compare` / pandas read", "bench_long",
     "compare_vs_pandas_read_24h/ratio_compare_over_pandas_read", "{:.2f}×", "≤ 4×", lambda v: v <= 4.0),
    ("24-h 100-Hz log: `twin compare` peak memory", "bench_long", "compare/24h/peak_rss_mb", "{:.0f} MB",
     "≤ 1000 MB", lambda v: v <= 1000.0),
    ("paper export (583,501 rows): `twin compare` / pandas read", "bench_compare",
     "paper_export/ratio_compare_over_pandas_read", "{:.2f}×", "≤ 3×", lambda v: v <= 3.0),
    ("PSO-GA-BPNN (paper's form) / MLPRegressor, wall, median of 3", "bench_fitting",
     "end_to_end/paper_features/psoga_bpnn_wall_ratio", "{:.2f}×", "≤ 1.5×", lambda v: v <= 1.5),
    ("… its population search alone / MLPRegressor's whole fit, wall", "bench_fitting",
     "end_to_end/paper_features/psoga_bpnn_search_alone_over_mlpregressor", "{:.2f}×", "", None),
    ("… its FLOP / MLPRegressor's FLOP", "bench_fitting", "end_to_end/paper_features/psoga_bpnn_flop_over_mlpregressor",
     "{:.1f}×", "", None),
]


def targets(results_dir: Path) -> list[str]:
    """The table of :data:`TARGETS`: each measured value from its JSON, and whether it meets its target."""
    files = {p.stem: json.loads(p.read_text()) for p in Path(results_dir).glob("*.json")}
    rows, per_row = [], {}
    for what, name, path, fmt, target, ok in TARGETS:
        value = _get(files.get(name, {}), path)
        if not isinstance(value, (int, float)):
            continue
        per_row[path] = value
        if ok == "per_row":
            small = per_row.get("logs/0.54M/twin_calibrate/us_per_row")
            met = None if small is None else value <= small
        else:
            met = ok(value) if ok else None
        verdict = "" if met is None else ("met" if met else "**not met**")
        rows.append(f"| {what} | {fmt.format(value)} | {target} | {verdict} |")
    if not rows:
        return []
    return ["## Targets at real-log scale", "",
            "The speed targets of calibration and compare on logs of real length, each read from the JSON "
            "of its section below (one run of `make bench`; ratios measured within that run).", "",
            "| figure | measured | target | |", "|---|---|---|---|", *rows, ""]


def render(results_dir: Path) -> str:
    """The whole page for every JSON in ``results_dir`` (sorted by name)."""
    files = sorted(Path(results_dir).glob("*.json"))
    lines = ["# Performance and accuracy figures", "",
             "Every figure on this page is read from a benchmark's JSON when the docs are built; nothing "
             "is copied by hand. Each section names the CPU it was measured on: a figure from another "
             "machine says nothing about yours. `make bench` re-runs the benchmarks on your machine and "
             "writes the files again; the scripts are in `benchmarks/`, each comparing against what a user "
             "would otherwise pick, side by side in one run.", ""]
    if not files:
        lines += ["No benchmark results are checked in yet: run `make bench`.", ""]
    lines += targets(results_dir)
    for path in files:
        lines += _section(path.stem, json.loads(path.read_text()))
    return "\n".join(lines)


def write_performance_page(results_dir: Path, out: Path) -> None:
    """Write the page only when it changed (Sphinx rebuilds what changed)."""
    text = render(results_dir)
    if not out.exists() or out.read_text() != text:
        out.write_text(text)


def plan_results(path: Path) -> str:
    """The table of ``twin plan`` on the simulated alias pairs (``docs/plan.md`` §6) from
    ``bench_plan.json``: per pair, the starting finding, the plan, and each truth's rate on the plan
    and on the repeated protocol, with 95 % intervals and the predicted rates."""
    if not path.exists():
        return "No `benchmarks/results/bench_plan.json` yet: run `python benchmarks/bench_plan.py`.\n"
    data = json.loads(path.read_text())
    m = data.get("machine", {})
    rate = lambda c: (f"{c['named_first']}/{c['seeds']} ({100 * c['rate']:.0f} %, CI {100 * c['ci95'][0]:.0f}–"  # noqa: E731
                      f"{100 * c['ci95'][1]:.0f} %)" if c else "—")
    pred = lambda c: "—" if not c or c.get("predicted") is None else f"{100 * c['predicted']:.0f} %"  # noqa: E731
    lines = [f"From `benchmarks/results/bench_plan.json` ({m.get('cpu_model', '?')}, {m.get('logical_cpus', '?')} "
             f"CPUs), {data['seeds']} seeds per truth.", "",
             "| pair (budget) | starting log (truth A) | plan | truth | named first, plan | predicted | named first, "
             "protocol repeated |", "|---|---|---|---|---|---|---|"]
    for name, p in data["pairs"].items():
        s = p["starting_log"]
        start = f"{s['confidence']}, named {', '.join(s['named']) or 'nothing'}"
        plan = f"{p['plan']['description']} ({p['plan']['chamber_hours']:.3g} h)"
        repeated = next((b for b in p["baselines"] if b["name"] == "protocol_repeated"), None)
        name = f"{name} ({p.get('budget_h', data['budget_h']):g} h)"
        for k, truth in enumerate(p["truths"]):
            pc, bc = p["plan_check"].get(truth), p["protocol_repeated_check"].get(truth)
            lines.append(f"| {name if k == 0 else ''} | {start if k == 0 else ''} | {plan if k == 0 else ''} | "
                         f"{truth} | {rate(pc)} | {pred(pc)} | {rate(bc)}"
                         + (f" in {repeated['chamber_hours']:.3g} h |" if repeated and bc else " |"))
    timed = [(name, p) for name, p in data["pairs"].items() if p.get("design_wall_s") is not None]
    if timed:
        lines += ["", "Wall-clock time of `twin plan --workers 2` (candidates scored and finalists raced; then the "
                      "check of the plan and of the repeated protocol): "
                  + "; ".join(f"{name} {p['design_wall_s'] / 60:.1f} min, check {p['check_wall_s'] / 60:.1f} min"
                              for name, p in timed) + "."]
    tofu = data.get("tofupilot")
    if tofu:
        f = tofu["finding"][tofu["axis"]]
        lines += ["", f"**The real TofuPilot thermal cycle** (axis {tofu['axis']}, one orientation): the finding names "
                      f"{', '.join(f['named']) or 'nothing'} ({f['confidence']}), rivals {', '.join(f['rivals']) or 'none'}. "
                      f"The plan: {tofu['plan']['description']} ({tofu['plan']['chamber_hours']:.3g} h).", "",
                  "| true rival | over | expected ΔBIC, plan | " + " | ".join(f"{b['name'].replace('_', ' ')} ({b['chamber_hours']:.3g} h)"
                                                                     for b in tofu["baselines"]) + " |",
                  "|---|---|---|" + "---|" * len(tofu["baselines"])]
        for q in tofu["plan"]["pairs"]:
            others = [next((x["expected_delta_bic"] for x in b["pairs"] if (x["truth"], x["rival"]) == (q["truth"], q["rival"])), None)
                      for b in tofu["baselines"]]
            lines.append(f"| {q['truth']} | {q['rival']} | {q['expected_delta_bic']:.3g} | "
                         + " | ".join("—" if v is None else f"{v:.3g}" for v in others) + " |")
        if tofu.get("check"):
            lines += ["", "Checked by simulation: " + "; ".join(f"{c['truth']} true, named first in {c['named_first']}/{c['seeds']}"
                                                            for c in tofu["check"]) + "."]
    return "\n".join(lines) + "\n"


def write_plan_results(path: Path, out: Path) -> None:
    """Write :func:`plan_results` only when it changed."""
    text = plan_results(path)
    if not out.exists() or out.read_text() != text:
        out.write_text(text)
