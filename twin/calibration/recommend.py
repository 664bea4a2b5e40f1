"""Which compensation a vehicle gets by default: the rule, stated once.

The default of ``twin apply`` and of the C export is the method with the lowest held-out error on
the folds that can validate it, if it beats the PX4 cubic there by more than ``tolerance`` (2 %),
and never one that is worse than the cubic on any such fold and axis by more than that. Errors are
taken on each fold's held-out samples inside its training temperatures: a compensation is used
within the span it was calibrated on, and outside its range PX4 clamps while the others
extrapolate, which would judge the cubic by what it never does.

A rate-dependent method (a lag, a gradient, a relaxation: anything with thermal state) is
validated only by folds whose training rows both heat and cool — on one direction at one ramp
rate, its rate term is absorbed by the static curve and says nothing about the other direction. A
static polynomial is validated by any fold. When no method qualifies beyond the cubic, the cubic is
the default, with the reason; so too when a validated model that no firmware can run (one with a
drift in time) beats the best candidate held out: the candidates' thermal terms then carry a drift
that will not repeat.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np

from twin.calibration.branches import Protocol
from twin.calibration.models import AXES
from twin.calibration.validate import IN_RANGE, ValidationResult

TOLERANCE = 0.02  # "worse than the cubic" means by more than this fraction, on any validating fold and axis
REFERENCE = "px4"  # the cubic every flight controller already runs


@dataclass(frozen=True)
class Verdict:
    """What the data could say about one method.

    Attributes
    ----------
    method : str
    folds : tuple of str
        The folds that can validate it.
    rms_mg : (float, float, float) or None
        Held-out RMS per axis pooled over those folds [mg].
    worst_ratio : float or None
        Its largest RMS ratio to the cubic over those folds and axes.
    eligible : bool
    reason : str
        One sentence: validated and how, or why not.
    """

    method: str
    folds: tuple[str, ...]
    rms_mg: tuple[float, float, float] | None
    worst_ratio: float | None
    eligible: bool
    reason: str


@dataclass(frozen=True)
class Recommendation:
    """The default method and why, with every candidate's verdict.

    Attributes
    ----------
    method : str or None
        The default method (None: none).
    reason : str
        Why.
    verdicts : tuple of Verdict
        Every candidate's verdict.
    cubic_rms_mg : tuple of 3 floats or None
        The cubic on the default's folds, pooled [mg].
    reference : str or None
        The cubic's method name.
    """

    method: str | None
    reason: str
    verdicts: tuple[Verdict, ...]
    cubic_rms_mg: tuple[float, float, float] | None = None  # the cubic on the default's folds, pooled
    reference: str | None = None  # the cubic's method name

    def custom_firmware_gain(self) -> str | None:
        """What only custom firmware removes: the default against the cubic PX4 and ArduPilot run.

        Returns
        -------
        str or None
            Held-out RMS [mg] of both and the change [%]; None when the default is the cubic.
        """
        mine = next((v for v in self.verdicts if v.method == self.method), None)
        if mine is None or mine.rms_mg is None or self.cubic_rms_mg is None or self.method == self.reference:
            return None
        share = [100 * (1 - m / c) if c > 0 else 0.0 for m, c in zip(mine.rms_mg, self.cubic_rms_mg)]
        return (f"only custom firmware removes this: {self.method} leaves "
                + " / ".join(f"{v:.2f}" for v in mine.rms_mg) + " mg held out where the cubic PX4 and ArduPilot run "
                + "leaves " + " / ".join(f"{v:.2f}" for v in self.cubic_rms_mg) + " mg ("
                + " / ".join(f"{-s:+.0f} %" for s in share) + ")")


def validating_folds(protocol: Protocol, rate_dependent: bool) -> tuple[str, ...]:
    """Folds that can validate a method: all of them for a static one, two-direction ones otherwise.

    Parameters
    ----------
    protocol : Protocol
        The validation protocol.
    rate_dependent : bool
        Whether the method has thermal state.

    Returns
    -------
    tuple of str
        Fold names.
    """
    return tuple(f.name for f in protocol.folds if f.both_directions or not rate_dependent)


def recommend(validation: ValidationResult, protocol: Protocol, candidates: list[str], rate_dependent: set[str],
              reference: str = REFERENCE, tolerance: float = TOLERANCE,
              undeployable: dict[str, list[str]] | None = None) -> Recommendation:
    """Apply the rule (module docstring) to ``candidates`` (deployable, unflagged method names).

    Parameters
    ----------
    validation : ValidationResult
        Scores per fold, method and test.
    protocol : Protocol
        The folds scored, with the directions each fold's training rows hold.
    candidates : list of str
        Methods the target can run that are not flagged.
    rate_dependent : set of str
        The candidates with thermal state.
    reference : str
        The cubic the rule compares against; when it is not among the scored methods the first
        candidate scored on every fold stands in, and the reason says so.
    undeployable : dict of str → list of str, optional
        Validated methods no firmware can run, with the effects that stop it (a drift in time since
        the device was made, say). When one of them beats every candidate held out, the log holds
        something the candidates absorbed into their thermal terms; that does not carry to another
        day, so the default is the cubic.

    Returns
    -------
    Recommendation
        The default method, why, and every candidate's verdict (RMS in mg).
    """
    scored = set(validation.methods)
    if reference not in scored:
        stand_in = next((m for m in candidates if m in scored and m not in rate_dependent), None)
        if stand_in is None:
            return Recommendation(None, f"no cubic ({reference}) was validated to compare against", ())
        reference = stand_in
    verdicts = [_verdict(validation, protocol, m, m in rate_dependent, reference, tolerance) for m in candidates]
    eligible = [v for v in verdicts if v.eligible]
    if not eligible:
        if reference in candidates:  # when in doubt, the cubic
            return Recommendation(reference, f"{reference}: the cubic, as no candidate could be validated on this data",
                                  tuple(verdicts))
        return Recommendation(None, "no candidate was validated", tuple(verdicts))
    shared = tuple(f for f in eligible[0].folds if all(f in v.folds for v in eligible))
    best = min(eligible, key=lambda v: _power(validation, v.method, shared or v.folds))  # ranked alike
    others = [v for v in verdicts if v.method != best.method and not v.eligible]
    cubic = next((v for v in verdicts if v.method == reference), None)
    margin = (1 - tolerance) ** 2  # on the summed squares: "better by more than the tolerance"
    if best is not cubic and cubic is not None and \
            _power(validation, best.method, best.folds) > margin * _power(validation, reference, best.folds):
        # when in doubt, the cubic: a gain inside the tolerance is no evidence
        doubt = dataclasses.replace(best, eligible=False, reason=f"{best.method}: not better than the cubic by more "
                                    f"than {100 * tolerance:g} % held out")
        verdicts = [doubt if v is best else v for v in verdicts]
        others.append(doubt)
        best = cubic
    for name, effects in (undeployable or {}).items():
        common = tuple(f for f in best.folds if any(s.method == name and s.fold == f and s.test == IN_RANGE
                                                    for s in validation.scores))
        if best is not cubic and cubic is not None and common and \
                _power(validation, name, common) < margin * _power(validation, best.method, common):
            why = (f"{reference}: the cubic, because {name} (with {', '.join(effects)}, which no firmware can run) "
                   f"beats {best.method} held out: the log drifts in a way {best.method}'s thermal terms absorbed, "
                   "and that does not carry to another day")
            vetoed = dataclasses.replace(best, eligible=False, reason=f"{best.method}: {why.split(': ', 1)[1]}")
            verdicts = [vetoed if v is best else v for v in verdicts]
            return Recommendation(reference, why, tuple(verdicts), _pooled(validation, reference, cubic.folds),
                                  reference)
    if best.method == reference:
        why = f"{reference}: the cubic, " + ("; ".join(v.reason for v in others) if others else
                                             "no other method does better on every validating fold")
    else:
        why = (f"{best.method}: lowest held-out RMS on the folds that validate it "
               f"({', '.join(best.folds)}), at most {best.worst_ratio:.2f}× the cubic on any of them and any axis")
    return Recommendation(best.method, why, tuple(verdicts), _pooled(validation, reference, best.folds), reference)


def _power(validation: ValidationResult, method: str, folds: tuple[str, ...]) -> float:
    """Held-out mean square summed over the axes [mg²], pooled over ``folds``."""
    return float(np.sum(np.square(validation.rms_mg(method, IN_RANGE, folds))))


def _pooled(validation: ValidationResult, method: str, folds: tuple[str, ...]) -> tuple[float, float, float]:
    return tuple(float(v) for v in validation.rms_mg(method, IN_RANGE, folds))


def _verdict(validation: ValidationResult, protocol: Protocol, method: str, rate_dependent: bool, reference: str,
             tolerance: float) -> Verdict:
    folds = validating_folds(protocol, rate_dependent)
    have = {s.fold for s in validation.scores if s.method == method and s.test == IN_RANGE}
    ref = {s.fold for s in validation.scores if s.method == reference and s.test == IN_RANGE}
    usable = tuple(f for f in folds if f in have and f in ref)
    if not usable:
        one_way = ", ".join(sorted({d for f in protocol.folds for d in f.directions})) or "no direction"
        why = (f"{method}: unvalidated: it has thermal state, and no fold's training rows both heat and cool "
               f"(they hold {one_way} only), so its rate term cannot be told from the static curve"
               if rate_dependent and not any(f.both_directions for f in protocol.folds) else
               f"{method}: unvalidated: not fitted on any fold that can validate it")
        return Verdict(method, (), None, None, False, why)
    ratios = np.array([validation.rms_mg(method, IN_RANGE, f) / np.maximum(validation.rms_mg(reference, IN_RANGE, f),
                                                                            1e-12) for f in usable])
    worst = float(ratios.max())
    k, a = np.unravel_index(int(np.argmax(ratios)), ratios.shape)
    pooled = tuple(float(v) for v in validation.rms_mg(method, IN_RANGE, usable))
    if worst > 1 + tolerance:
        why = (f"{method}: {100 * (worst - 1):.0f} % worse than the cubic on {AXES[a]} in fold '{usable[k]}' "
               f"(the rule allows {100 * tolerance:g} %)")
        return Verdict(method, usable, pooled, worst, False, why)
    return Verdict(method, usable, pooled, worst, True, f"{method}: validated on {', '.join(usable)}")
