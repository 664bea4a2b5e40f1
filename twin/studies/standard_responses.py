"""The built-in DOE responses (documented in docs/doe.md)."""

from __future__ import annotations

import numpy as np

from twin.studies.responses import RunContext, register_response


@register_response("chamber_hours", description="chamber time of the scenario: program duration × runs", unit="h")
def chamber_hours(run: RunContext) -> float:
    return run.program.duration_s * run.scenario.test_plan.runs / 3600


@register_response("drift_pp_mg", description="peak-to-peak true drift in the output", unit="mg")
def drift_pp_mg(run: RunContext) -> float:
    drift = run.dataset["truth/drift_g"]
    return float((drift.max() - drift.min()) * 1e3)


@register_response("residual_rms_mg", description="residual RMS of the calibrated twin on the blind measurement",
                   unit="mg")
def residual_rms_mg(run: RunContext) -> float:
    return run.diagnosis["rms_residual_g"] * 1e3


@register_response("noise_floor_mg", description="noise floor estimated from the measurement", unit="mg")
def noise_floor_mg(run: RunContext) -> float:
    return run.diagnosis["noise_floor_g"] * 1e3


@register_response("hidden_detected", description="1 if the diagnosis detects a missing effect, else 0")
def hidden_detected(run: RunContext) -> float:
    return float(run.diagnosis["missing_effect_detected"])


def _families(run: RunContext) -> list[str]:
    return [c["family"] for c in run.diagnosis["candidates"]]


@register_response("hidden_rank", description="rank (1 = first) of the hidden effect's family in the diagnosis "
                   "ranking; 0 if absent")
def hidden_rank(run: RunContext) -> float:
    fams, hidden = _families(run), run.hidden_family
    return float(fams.index(hidden) + 1) if hidden in fams else 0.0


@register_response("hidden_separated", description="1 if the hidden effect's family is first and in no alias group "
                   "with another family, else 0")
def hidden_separated(run: RunContext) -> float:
    from twin.effects import REGISTRY

    fams, hidden = _families(run), run.hidden_family
    # separated: named first, and in no alias group with an effect of another family
    mixed = any(hidden in fs and len(fs) > 1 for fs in
                ({REGISTRY[e].family for e in a["effects"] if e in REGISTRY} for a in run.diagnosis["aliases"]))
    return float(bool(fams) and fams[0] == hidden and not mixed)


@register_response("compensated_mse_ratio", description="MSE of a polynomial-in-T compensation on the last cycle "
                   "of every run (the benchmark's split) / noise-only MSE")
def compensated_mse_ratio(run: RunContext) -> float:
    from fitting import FeatureSet, PolynomialCompensator

    ds, test, noise = run.dataset, run.test_mask, run.noise_g
    X = FeatureSet(("T",)).transform(ds["temperature/thermometer_c"], ds["time_s"])
    y = ds["output/output_g"] - ds["test/applied_g"]
    model = PolynomialCompensator(max_order=4).fit(X[~test], y[~test])
    err = y[test] - model.predict(X[test])
    return float(np.var(err) / np.mean(noise[test] ** 2))  # the mean (offset) is not drift
