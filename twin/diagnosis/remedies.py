"""What the audit says an effect needs to become testable or separable (docs/diagnosis.md §2).

The audit's reasons and remedies are part of its result, so they live beside it.
"""

from __future__ import annotations

# What would make an effect testable or separable (docs/diagnosis.md §2).
REMEDY = {
    "scale_factor": "add orientations: a +1 g / -1 g (tumble) run makes scale-factor drift odd in g",
    "bias_tc": "bias tempcos of MEMS, package and ASIC share one signature: only another package/board or "
               "self-test data separate them",
    "thermal_lag": "add a second probe on the PCB and a second ramp rate (lag and gradient respond differently)",
    "hysteresis": "add a second ramp rate and long dwells (lag scales with rate, hysteresis does not)",
    "aging": "return to the same temperature at start and end and repeat identical cycles",
    "warmup": "power-cycle the device 2-3 times at different chamber temperatures, keeping the first samples",
    "probe": "glue a calibrated reference probe to the package: a probe offset is absorbed by the fitted offset",
}

# reasons and remedies of the audit
UNIDENTIFIABLE = "structurally unidentifiable from residuals"
ORIENTATION_NOT_LOGGED = "orientation not logged"
OFFSET_ALIAS_REMEDY = ("the temperature is nearly constant within each run and the runs differ in "
                       "orientation/offset: temperature and orientation cannot be separated; log the "
                       "orientation and ramp the temperature within a run")


def absorbed_reason(novelty: float) -> str:
    """Why a candidate with this novelty is untestable.

    Parameters
    ----------
    novelty : float
        1 − R² of the candidate on the calibrated model's design [1] (docs/diagnosis.md §1 step 0).

    Returns
    -------
    str
    """
    return f"novelty {novelty:.3g}: what it would add, the calibrated model already absorbs"


def confounding_remedy(span_c: float, between_c: float) -> str:
    """The remedy when the per-run offsets absorb orientation and temperature together.

    Parameters
    ----------
    span_c : float
        Largest within-run temperature span (5th–95th percentile) [°C].
    between_c : float
        Spread of the runs' median temperatures [°C].

    Returns
    -------
    str
    """
    return (f"each run sits at a nearly constant temperature (within-run span ≤ {span_c:.1f} °C, "
            f"{between_c:.1f} °C between runs) and the orientation is not logged, so the per-run "
            "offsets absorb gravity projection and temperature together: this data cannot separate "
            "orientation from temperature; log the orientation, or ramp the temperature within a run "
            "in a fixed orientation")
