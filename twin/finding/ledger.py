"""The ledger: every model compared with the same data, one JSON line each, beside the report.

Adding the named effect and comparing again appends a line; the report and the JSON show the
error falling step by step, with the ΔBIC between consecutive models on the same blocks.
"""

from __future__ import annotations

import datetime as _dt
import hashlib
import json
from pathlib import Path

import numpy as np

from twin.diagnosis.diagnose import Diagnosis
from twin.finding.result import CompareResult, LedgerEntry

LEDGER = "ledger.jsonl"


def data_fingerprint(d: Diagnosis) -> str:
    """A short hash of the data compared (time, temperature, output), so models of other data are apart.

    Parameters
    ----------
    d : Diagnosis

    Returns
    -------
    str
        16 hexadecimal digits.
    """
    m = d.problem.m
    h = hashlib.sha256()
    for a in (m.time_s, m.temperature_c, m.output_g):
        h.update(np.ascontiguousarray(a).tobytes())
    return h.hexdigest()[:16]


def append_ledger(directory: Path, d: Diagnosis, result: CompareResult) -> tuple[list[dict], tuple[LedgerEntry, ...]]:
    """Append this model's errors to ``ledger.jsonl`` in ``directory``.

    Parameters
    ----------
    directory : Path
    d : Diagnosis
    result : CompareResult

    Returns
    -------
    lines : list of dict
        This data's ledger lines as stored (with time and fingerprint), this one last.
    entries : tuple of LedgerEntry
        The same, as the result holds them.
    """
    directory.mkdir(parents=True, exist_ok=True)
    path = directory / LEDGER
    fp = data_fingerprint(d)
    lines = []
    if path.is_file():
        for line in path.read_text().splitlines():
            try:
                e = json.loads(line)
            except json.JSONDecodeError:
                continue
            if e.get("data") == fp:
                lines.append(e)
    cal = d.fit
    entry = {
        "time_utc": _dt.datetime.now(_dt.timezone.utc).isoformat(timespec="seconds"),
        "data": fp,
        "model": list(result.effects),
        "rms_residual_g": result.rms_residual_g,
        "heldout_rms_g": result.heldout_rms_g,
        "noise_floor_g": result.noise_floor_g,
        "rss_prewhitened": cal.rss_prewhitened,
        "n_blocks": int(cal.residual_avg.size),
        "n_parameters": int(cal.X_full.shape[1]),
    }
    prev = lines[-1] if lines else None
    if prev and prev.get("n_blocks") == entry["n_blocks"]:
        n = entry["n_blocks"]
        entry["delta_bic"] = float(n * np.log(prev["rss_prewhitened"] / entry["rss_prewhitened"])
                                   - (entry["n_parameters"] - prev["n_parameters"]) * np.log(n))
    else:
        entry["delta_bic"] = None
    with path.open("a") as f:
        f.write(json.dumps(entry) + "\n")
    lines.append(entry)
    return lines, tuple(LedgerEntry(tuple(e["model"]), e["rms_residual_g"], e["heldout_rms_g"], e["noise_floor_g"],
                                    e.get("delta_bic")) for e in lines)
