"""The JSON contract of ``twin compare`` (the report, the ledger and the tests read it)."""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    from twin.diagnosis.diagnose import Diagnosis


def result_json(d: Diagnosis) -> dict:
    """The JSON contract of ``twin compare``.

    Parameters
    ----------
    d : Diagnosis

    Returns
    -------
    dict
        JSON-serialisable: residual, noise floors, parameters with intervals, candidates, aliases,
        the finding.
    """
    cal = d.calibration
    params: dict[str, dict] = {}
    nn = d.problem.nuisance.shape[1]
    for e in cal.composition.effects:
        entry = {}
        for p in e.parameters:
            v = e.values[p.name]
            item = {"value": v, "unit": p.unit, "role": p.role, "free": p.free}
            if (e.name, p.name) in cal.names:
                j = nn + cal.names.index((e.name, p.name))
                half = 1.96 * float(np.sqrt(max(cal.cov[j, j], 0.0)))
                item["ci95"] = [v - half, v + half]
            if (e.name, p.name) in cal.nonlinear_ci:
                item["ci95"] = list(cal.nonlinear_ci[(e.name, p.name)])
            partner = next((pt for (en, an), pt in cal.pinned if (en, an) == (e.name, p.name)), None)
            if partner is not None:
                item["pinned"] = f"held at its default: aliased with {partner} in this data"
            lo, hi = p.bounds
            fitted = (e.name, p.name) in cal.names or (e.name, p.name) in cal.nonlinear_ci
            item["on_bound"] = bool(fitted and (np.isclose(v, lo, rtol=1e-6, atol=1e-12)
                                                                       or np.isclose(v, hi, rtol=1e-6, atol=1e-12)))
            item["outside_physical_range"] = bool(not lo <= v <= hi)
            entry[p.name] = item
        params[e.name] = entry
    params["nuisance"] = {name: {"value": float(cal.beta[j]), "unit": "g" if name.startswith("offset") else "1"}
                          for j, name in enumerate(d.problem.nuisance_names)}
    cands = [{
        "effect": c.effect, "family": c.family, "significant": c.significant, "rms_residual_g": c.rms_residual_g,
        "explained_fraction": c.explained_fraction, "delta_bic": c.delta_bic, "p_adjusted": c.p_adjusted,
        "heldout_gain": c.heldout_gain, "novelty": c.novelty, "parameters": c.grid_values,
        **({"parameters_refined": c.refined_values} if c.refined_values else {}),
        "amplitudes": {k: {"value": v, "ci95_half_width": w} for k, (v, w) in c.amplitudes.items()},
    } for c in d.candidates]
    seg = {k: v for k, v in d.segments.items() if k != "kind"}
    return {
        "rms_residual_g": d.rms_residual_g,
        "noise_floor_g": d.noise_floor_g,
        "noise_floor_model_g": d.noise_floor_model_g,
        "heldout_rms_g": d.heldout_rms_g,
        "effects": [e.name for e in cal.composition.effects],
        "parameters": params,
        "missing_effect_detected": bool(d.selected),
        "selected": [c.effect for c in d.selected],
        "withheld": d.withheld,
        "rivals": d.rivals,
        "family_choices": d.family_choices,
        "confidence": d.confidence,
        "candidates": cands,
        "aliases": d.aliases,
        "untestable": d.untestable,
        "finding": d.finding,
        "noise_model": {"ar_order": cal.ar.order, "average_s": d.problem.config.average_s},
        "residual": seg,
        "samples": d.problem.n,
        "sample_rate_hz": d.problem.rate_hz,
        "runs": d.problem.m.runs,
    }
