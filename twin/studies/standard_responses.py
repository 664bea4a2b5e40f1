"""The built-in DOE responses (documented in docs/doe.md)."""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    from twin.studies.responses import RunContext


def chamber_hours(run: RunContext) -> float:
    """Chamber time of the scenario: program duration × runs [h].

    Parameters
    ----------
    run : RunContext
        The run.

    Returns
    -------
    float
        Chamber time [h].
    """
    return run.program.duration_s * run.scenario.test_plan.runs / 3600


def drift_pp_mg(run: RunContext) -> float:
    """Peak-to-peak true drift in the output [mg].

    Parameters
    ----------
    run : RunContext
        The run.

    Returns
    -------
    float
        Max − min of ``truth/drift_g`` [mg].
    """
    drift = run.dataset["truth/drift_g"]
    return float((drift.max() - drift.min()) * 1e3)


def residual_rms_mg(run: RunContext) -> float:
    """Residual RMS of the calibrated twin on the blind measurement [mg].

    Parameters
    ----------
    run : RunContext
        The run.

    Returns
    -------
    float
        Residual RMS [mg].
    """
    return run.diagnosis.rms_residual_g * 1e3


def noise_floor_mg(run: RunContext) -> float:
    """Noise floor estimated from the measurement [mg].

    Parameters
    ----------
    run : RunContext
        The run.

    Returns
    -------
    float
        Noise floor [mg].
    """
    return run.diagnosis.noise_floor_g * 1e3


def hidden_detected(run: RunContext) -> float:
    """Whether the diagnosis detects a missing effect [1].

    Parameters
    ----------
    run : RunContext
        The run.

    Returns
    -------
    float
        1.0 if detected, else 0.0 [1].
    """
    return float(run.diagnosis.missing_effect_detected)


def _families(run: RunContext) -> list[str]:
    return [c.family for c in run.diagnosis.candidates]


def hidden_rank(run: RunContext) -> float:
    """Rank of the hidden effect's family in the diagnosis ranking [1].

    Parameters
    ----------
    run : RunContext
        The run.

    Returns
    -------
    float
        1 = named first; 0 if absent (or no effect is hidden) [1].
    """
    fams, hidden = _families(run), run.hidden_family
    return float(fams.index(hidden) + 1) if hidden in fams else 0.0


def hidden_separated(run: RunContext) -> float:
    """Whether the hidden effect's family is named first and in no alias group with another family [1].

    Parameters
    ----------
    run : RunContext
        The run.

    Returns
    -------
    float
        1.0 if so, else 0.0 [1].
    """
    from twin.effects import REGISTRY

    fams, hidden = _families(run), run.hidden_family
    # separated: named first, and in no alias group with an effect of another family
    mixed = any(hidden in fs and len(fs) > 1 for fs in
                ({REGISTRY[e].family for e in a.effects if e in REGISTRY} for a in run.diagnosis.aliases))
    return float(bool(fams) and fams[0] == hidden and not mixed)


def compensated_mse_ratio(run: RunContext) -> float:
    """MSE of a polynomial-in-T compensation on the last cycle of every run / noise-only MSE [1].

    The polynomial (order 1..4 by validation, :class:`fitting.PolynomialCompensator`) is trained on
    the other cycles (:func:`twin.compensation.splits.last_cycle_test`, the benchmark's split).

    Parameters
    ----------
    run : RunContext
        The run.

    Returns
    -------
    float
        Variance of the compensation error on the test samples (the mean, an offset, is not drift)
        over the mean square of the sensor noise there [1]; a perfect compensation gives ≈ 1.
    """
    from fitting import FeatureSet, PolynomialCompensator

    ds, test, noise = run.dataset, run.test_mask, run.noise_g
    X = FeatureSet(("T",)).transform(ds["temperature/thermometer_c"], ds["time_s"])
    y = ds["output/output_g"] - ds["test/applied_g"]
    model = PolynomialCompensator(max_order=4).fit(X[~test], y[~test])
    err = y[test] - model.predict(X[test])
    return float(np.var(err) / np.mean(noise[test] ** 2))  # the mean (offset) is not drift


#: (name, description, unit, function) of each built-in response, registered by
#: :mod:`twin.studies.responses` in this order
BUILTIN = (
    ("chamber_hours", "chamber time of the scenario: program duration × runs",
     "h", chamber_hours),
    ("drift_pp_mg", "peak-to-peak true drift in the output",
     "mg", drift_pp_mg),
    ("residual_rms_mg", "residual RMS of the calibrated twin on the blind measurement",
     "mg", residual_rms_mg),
    ("noise_floor_mg", "noise floor estimated from the measurement",
     "mg", noise_floor_mg),
    ("hidden_detected", "1 if the diagnosis detects a missing effect, else 0",
     "", hidden_detected),
    ("hidden_rank", "rank (1 = first) of the hidden effect's family in the diagnosis "
     "ranking; 0 if absent",
     "", hidden_rank),
    ("hidden_separated", "1 if the hidden effect's family is first and in no alias group "
     "with another family, else 0",
     "", hidden_separated),
    ("compensated_mse_ratio", "MSE of a polynomial-in-T compensation on the last cycle "
     "of every run (the benchmark's split) / noise-only MSE",
     "", compensated_mse_ratio),
)
