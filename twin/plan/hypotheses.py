"""The rival explanations a plan must separate, read from a compare finding, each calibrated to the
data the finding came from (docs/plan.md §1).

A :class:`Hypothesis` is the twin plus one registered effect at the values the finding estimated
(its screening grid point and amplitudes, with their 95 % intervals), the twin alone (``none``:
nothing is missing, what looked like an effect is the model's own tempco), or the twin with a
wandering bias (``bias_random_walk``: no effect is missing, the sensor's bias drifts at random by as
much as the named effect explained). A temperature-slot effect (the die lag) is simulated through
the thermal chain, as a device gets its lag.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from twin.effects import get_effect
from twin.errors import TwinError

#: the hypothesis "nothing is missing"
NONE = "none"
#: the hypothesis "the bias wanders": no effect, a Gauss–Markov bias (a random walk over times
#: shorter than its correlation time) as large as what the finding's named effect explained
WALK = "bias_random_walk"
#: hypotheses that add no effect: when one is true, the diagnosis is right to name nothing
NULLS = (NONE, WALK)
#: the wander's correlation time without a finding's effect to match [s]: hours, as creep and aging
WALK_TAU_S = 10800.0
#: spread of a nonlinear parameter's draws around the finding's grid point: the screening grids step
#: by about ×3, so the estimate is known to within about ×√3 either way
NONLINEAR_SPREAD = 1.7


@dataclass(frozen=True)
class Hypothesis:
    """One rival: the twin plus ``effect`` at ``values``, or the twin alone (``effect == "none"``).

    Attributes
    ----------
    effect : str
        A registered effect, or ``none``.
    values : dict of str to float
        Its parameters, in each one's unit (screening grid point and amplitudes).
    amplitude_sd : dict of str to float
        Standard deviation of each amplitude from the finding's 95 % interval [its unit].
    source : str
        Why it is a rival (``named``, ``rival``, ``withheld``, ``alias``, ``untestable``, ``given``).
    """

    effect: str
    values: dict[str, float] = field(default_factory=dict)
    amplitude_sd: dict[str, float] = field(default_factory=dict)
    source: str = "given"

    def draw(self, rng: np.random.Generator) -> dict[str, float]:
        """Parameter values drawn from their uncertainty: amplitudes normal within their interval,
        nonlinear parameters log-uniform within ×/÷ :data:`NONLINEAR_SPREAD`, clipped to bounds.

        Parameters
        ----------
        rng : numpy.random.Generator

        Returns
        -------
        dict of str to float
        """
        if self.effect == NONE:
            return {}
        if self.effect == WALK:  # both scales are uncertain by about as much as a grid step
            return {k: float(v * NONLINEAR_SPREAD ** rng.uniform(-1.0, 1.0)) for k, v in self.values.items()}
        out = dict(self.values)
        for p in get_effect(self.effect).parameters:
            if p.name not in out:
                continue
            if p.role == "amplitude" and p.name in self.amplitude_sd:
                out[p.name] = float(out[p.name] + rng.normal(0.0, self.amplitude_sd[p.name]))
            elif p.role == "nonlinear" and out[p.name] > 0:
                out[p.name] = float(out[p.name] * NONLINEAR_SPREAD ** rng.uniform(-1.0, 1.0))
            out[p.name] = float(np.clip(out[p.name], *p.bounds))
        return out


def named_when_true(effect: str) -> str:
    """What the diagnosis should name first when ``effect`` is true: the effect, or ``none`` for a
    hypothesis that adds no effect (:data:`NULLS`).

    Parameters
    ----------
    effect : str

    Returns
    -------
    str
    """
    return NONE if effect in NULLS else effect


def walk_hypothesis(finding: dict | None, source: str = "given") -> Hypothesis:
    """A wandering bias as large as what the finding's named effect explained.

    The wander's standard deviation is the residual the effect removed, √(rms_twin² − rms_after²)
    (``rms_residual_g``, ``rms_after_selected_g``); its correlation time is the named effect's time
    constant where it has one (``tau_s``), else :data:`WALK_TAU_S`. Without a finding: 1 mg over
    :data:`WALK_TAU_S`.

    Parameters
    ----------
    finding : dict, optional
        A ``twin compare --json`` result of one axis.
    source : str

    Returns
    -------
    Hypothesis
    """
    sigma_mg, tau_s = 1.0, WALK_TAU_S
    if finding:
        before, after = finding.get("rms_residual_g"), finding.get("rms_after_selected_g")
        if before and after and before > after:
            sigma_mg = 1e3 * float(np.sqrt(before ** 2 - after ** 2))
        selected = finding.get("selected") or [None]
        named = next((c for c in finding.get("candidates", []) if c["effect"] == selected[0]), {})
        tau_s = float((named.get("parameters_refined") or named.get("parameters") or {}).get("tau_s") or tau_s)
    return Hypothesis(WALK, {"bias_instability_mg": sigma_mg, "bias_instability_tau_s": tau_s}, source=source)


def default_hypothesis(effect: str, source: str = "given") -> Hypothesis:
    """``effect`` at its registered defaults (an effect the finding did not screen).

    Parameters
    ----------
    effect : str
        A registered effect or ``none``.
    source : str

    Returns
    -------
    Hypothesis

    Raises
    ------
    TwinError
        An unknown effect (the message lists the registered ones).
    """
    if effect == NONE:
        return Hypothesis(NONE, source=source)
    if effect == WALK:
        return walk_hypothesis(None, source)
    try:
        cls = get_effect(effect)
    except Exception as exc:  # noqa: BLE001 - the registry's one-line "did you mean"
        raise TwinError(f"--rivals: {exc}") from None
    return Hypothesis(effect, {p.name: p.default for p in cls.parameters if p.role != "fixed"}, source=source)


def _from_candidate(cand: dict, source: str) -> Hypothesis:
    """A hypothesis from one candidate record of the compare JSON."""
    values = dict(cand.get("parameters_refined") or cand.get("parameters") or {})
    sd = {}
    for name, a in (cand.get("amplitudes") or {}).items():
        values[name] = float(a["value"])
        sd[name] = float(a["ci95_half_width"]) / 1.96
    known = {p.name for p in get_effect(cand["effect"]).parameters}
    return Hypothesis(cand["effect"], {k: v for k, v in values.items() if k in known}, sd, source)


def hypotheses_from_finding(finding: dict, rivals: list[str] | None = None) -> list[Hypothesis]:
    """The rivals a finding leaves open, each calibrated to its data.

    With a named effect: it, its rivals of other families, the candidates it was withheld for and
    the significant members of its alias group. With nothing named: the significant candidates and,
    when none, the untestable identifiable effects (one per family) against ``none``. ``rivals``
    overrides the choice (any registered effects, plugins included, or ``none``).

    Parameters
    ----------
    finding : dict
        A ``twin compare --json`` result of one axis.
    rivals : list of str, optional
        Effects to separate instead (``none`` and ``bias_random_walk`` allowed).

    Returns
    -------
    list of Hypothesis
        At least two.

    Raises
    ------
    TwinError
        Fewer than two rivals, or an unknown effect.
    """
    cands = {c["effect"]: c for c in finding.get("candidates", [])}
    model = set(finding.get("effects", []))

    def hyp(effect: str, source: str) -> Hypothesis:
        if effect == WALK:
            return walk_hypothesis(finding, source)
        if effect in model:
            raise TwinError(f"--rivals: {effect} is already in the twin's model; name effects it lacks, or none")
        return _from_candidate(cands[effect], source) if effect in cands else default_hypothesis(effect, source)

    if rivals:
        out = [hyp(e, "given") for e in dict.fromkeys(rivals)]
    else:
        out = _open_rivals(finding, cands, hyp)
    if len(out) < 2:
        raise TwinError("the finding leaves fewer than two rivals open "
                        f"({', '.join(h.effect for h in out) or 'none'}); name them with --rivals A,B")
    return out


def _open_rivals(finding: dict, cands: dict, hyp) -> list[Hypothesis]:
    """The rivals of :func:`hypotheses_from_finding` without ``--rivals``."""
    sources: dict[str, str] = {}
    named = list(finding.get("selected", []))[:1]
    for e in named:
        sources[e] = "named"
    for e in finding.get("rivals", []):
        sources.setdefault(e, "rival")
    for w in finding.get("withheld", []):
        sources.setdefault(w["effect"], "withheld")
        sources.setdefault(w["outranked_by"], "withheld")
    for a in finding.get("aliases", []):
        if a.get("aliased_with") is None and set(named) & set(a["effects"]):
            for e in a["effects"]:
                if cands.get(e, {}).get("significant"):
                    sources.setdefault(e, "alias")
    if not sources:
        for e, c in cands.items():
            if c.get("significant"):
                sources.setdefault(e, "significant")
    if not sources:
        # this data could not test them, so their values are the library's defaults, not a fit
        by_family: dict[str, list[str]] = {}
        for u in finding.get("untestable", []):
            cls = get_effect(u["effect"])
            if cls.identifiable and cls.screened:
                by_family.setdefault(u["family"], []).append(u["effect"])
        out = [default_hypothesis(min(names, key=_simplest), "untestable") for names in by_family.values()]
        return out + [Hypothesis(NONE, source="none")] if out else []
    return [Hypothesis(NONE, source=s) if e == NONE else hyp(e, s) for e, s in sources.items()]


def _simplest(effect: str) -> tuple:
    """Sort key of a family's representative: amplitudes fitted by default first (a microstructure
    effect takes its amplitude from geometry), then the fewest parameters."""
    params = get_effect(effect).parameters
    return (not all(p.free for p in params if p.role == "amplitude"), len(params), effect)
