"""The diagnosis in plain language: residual signatures and the finding.

The sentences of ``twin compare``'s finding live here (the audit's remedies in
:mod:`twin.diagnosis.remedies`); the diagnosis decides, this module says.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from twin.diagnosis.axes import SHARED_TAU_SPREAD, tau_spread
from twin.diagnosis.records import PER_RUN_OFFSETS, FamilyChoice
from twin.diagnosis.remedies import REMEDY
from twin.diagnosis.structure import both_directions

if TYPE_CHECKING:
    from twin.diagnosis.diagnose import Diagnosis
    from twin.discovery.search import Discovery
    from twin.finding.result import CompareResult

SIGNATURE = {
    "thermal_lag": "The residual follows −dT/dt, changes sign between heating and cooling and settles in dwells",
    "hysteresis": "Heating and cooling branches of the residual differ at the same temperature (a loop in residual vs "
                  "temperature)",
    "scale_factor": "The residual flips sign with the orientation (odd in the applied g) and grows with temperature",
    "bias_tc": "The residual is a smooth function of temperature, the same on heating and cooling",
    "aging": "The residual drifts steadily in time, whatever the temperature",
    "warmup": "The residual has a transient after each power-on",
}

# the signatures that set heating against cooling, said for data holding one thermal direction only
# (a heating-only warm-up cannot show a sign change or a loop between the two)
ONE_DIRECTION_SIGNATURE = {
    "thermal_lag": "The residual follows −dT/dt and settles in dwells (the data hold one thermal direction only)",
    "hysteresis": "The residual depends on the temperature's path, not on its value alone (the data hold one "
                  "thermal direction only, so no loop in residual vs temperature can be seen)",
    "bias_tc": "The residual is a smooth function of temperature",
}

def _fmt_mg(x_g: float) -> str:
    return f"{x_g * 1e3:.3g} mg"


def finding_text(d: Diagnosis, discovery: Discovery | None = None, plugin_path: str | None = None) -> str:
    """A plain-language finding for the report and the CLI.

    Parameters
    ----------
    d : Diagnosis
    discovery : Discovery, optional
        What ``--discover`` found.
    plugin_path : str, optional
        Where the discovered term was written as an effect.

    Returns
    -------
    str
        The finding, then what cannot be separated or tested and how to fix it.
    """
    rms = d.rms_residual_g
    parts = [f"This data cannot separate {' from '.join(a.effects)}: {a.remedy}." for a in d.aliases
             if a.aliased_with == PER_RUN_OFFSETS]
    if d.selected:
        top = d.selected[0]
        signatures = SIGNATURE if both_directions(d.problem) else {**SIGNATURE, **ONE_DIRECTION_SIGNATURE}
        sig = signatures.get(top.family, f"The residual has the signature of {top.family}")
        values = top.refined_values or top.grid_values
        param = ", ".join(f"{k} ≈ {v:.3g}" for k, v in values.items())
        phys = {"thermal_lag": f"the die lags the thermometer by ≈{values.get('tau_s', float('nan')):.0f} s"}.get(
            top.effect, f"best explanation: {top.effect}" + (f" ({param})" if param else ""))
        parts.append(f"{sig}: {phys}. Adding {top.effect} lowers the RMS from {_fmt_mg(rms)} to "
                     f"{_fmt_mg(top.rms_residual_g)}; noise floor {_fmt_mg(d.noise_floor_g)} "
                     f"(ΔBIC {top.delta_bic:.0f}, held-out gain {100 * top.heldout_gain:.0f} %).")
        parts += [family_choice_text(ch) for ch in d.family_choices]
        parts.append(_attribution_text(top.family, top.effect))
        if len(d.selected) > 1:
            parts.append("Also missing: " + ", ".join(c.effect for c in d.selected[1:]) + ".")
        if d.confidence == "uncertain":
            parts.append("Confidence is limited: " + ("structure remains after adding it (it removes "
                                                      f"{100 * (d.slow_share or 0):.0f} % of the slow residual)"
                                                      if (d.slow_share or 0) < 0.5 else "its coefficient differs between runs"
                                                      if d.run_consistent is False else
                                                      f"this data cannot tell it from {' / '.join(d.rivals)}"
                                                      if d.rivals else
                                                      "temperature is confounded with the per-run offsets") + ".")
    elif d.withheld:
        w = d.withheld[0]
        parts.append(f"{w.effect} passes the significance tests, but {w.outranked_by} ({w.outranked_by_family}) "
                     f"explains more of the residual (ΔBIC {w.delta_bic[1]:.0f} vs {w.delta_bic[0]:.0f}) without "
                     f"passing them: the data do not say which effect is missing, so none is named. To separate "
                     f"them: {REMEDY.get(w.outranked_by_family, 'a different test plan')}.")
    elif d.structure or (discovery is not None and discovery.proposed):
        parts.append(f"No library effect explains the residual, but it is not white noise: RMS {_fmt_mg(rms)}, "
                     f"{rms / d.noise_floor_g:.2f}× the white-noise floor of {_fmt_mg(d.noise_floor_g)}.")
    else:
        parts.append(f"No missing effect found: residual RMS {_fmt_mg(rms)} against a noise floor of "
                     f"{_fmt_mg(d.noise_floor_g)}.")
        if d.above_noise_floor:
            parts.append(f"The residual is {rms / d.noise_floor_g:.2f}× the white-noise floor, without structure in "
                         "temperature, rate or time beyond the noise model: slow correlated noise (see the Allan "
                         "deviation and dwell plots).")
    parts += _structure_and_discovery(d, discovery, plugin_path)
    remedies: dict[str, list[str]] = {}
    top_effects = {c.effect for c in d.selected}
    separated = {s.effects: s for s in d.separated}
    for a in d.aliases:
        if a.aliased_with == PER_RUN_OFFSETS:
            continue
        if a.effects in separated:  # alike in shape, yet the evidence tells them apart: say so, not "not separable"
            s = separated[a.effects]
            parts.append(f"{' / '.join(a.effects)} are alike in shape with this test plan, but the evidence "
                         f"separates them here: {s.named} ΔBIC {s.named_delta_bic:.0f} against "
                         f"{s.partner_delta_bic:.0f} for {s.partner}.")
            continue
        if not a.among_candidates or top_effects & set(a.effects):
            remedies.setdefault(a.remedy, []).append(" / ".join(a.effects) +
                                                     ("" if a.among_candidates else f" (with {a.aliased_with})"))
    for u in d.untestable:
        if u.family in ("scale_factor", "probe"):
            remedies.setdefault(u.remedy, []).append(u.effect)
    for remedy, what in remedies.items():
        parts.append(f"Not separable or not testable with this data: {', '.join(dict.fromkeys(what))}. To fix: {remedy}.")
    return " ".join(parts)


GROUPING = {"temperature": "in temperature", "rate": "between heating, cooling and dwells",
            "temperature_direction": "between heating and cooling at the same temperature", "time": "in time"}


#: why one effect of a family is named (``reason`` of a family choice)
FAMILY_CHOICE_REASON = {
    "fewest_parameters": "it needs the fewest parameters, and no richer model is lower by more than 10 in BIC "
                         "and 1 % in residual RMS",
    "decisively_better": "against the simpler models it is lower by more than 10 in BIC and 1 % in residual RMS",
    "lowest_bic": "its BIC is the lowest",
}


def family_choice_text(choice: FamilyChoice) -> str:
    """Why one effect of a family is named over the others, calibrated whole.

    Parameters
    ----------
    choice : FamilyChoice

    Returns
    -------
    str
    """
    fits = "; ".join(f"{m.effect} {m.free_parameters} parameters, residual {m.rss_over_best:.4f}× the best"
                     + (f", BIC {m.bic_minus_named:+.1f}" if m.effect != choice.named else "")
                     for m in choice.models)
    return f"Calibrated whole: {fits}. {choice.named} is named: {FAMILY_CHOICE_REASON[choice.reason]}."


def _attribution_text(family: str, effect: str | None) -> str:
    """Whether the named effect is a mechanism or only a signature, and its look-alikes."""
    from twin.finding.lookalikes import attribution, lookalikes_sentence

    if attribution(family, effect) == "mechanism":
        return "Attribution: to a mechanism (no mechanism outside the library shares this signature)."
    return "Attribution: to a signature, not a mechanism. " + lookalikes_sentence(family, effect)


def structure_text(structure: list, both_directions: bool = True) -> str:
    """Where the residual departs from the noise model and by how much ('' when nowhere); with one
    thermal direction in the data the rate grouping is named without setting heating against cooling.

    Parameters
    ----------
    structure : list
        Residual structures (grouping, RMS [g], where, departure [g], ΔBIC [1]).
    both_directions : bool
        Whether the data hold both heating and cooling.

    Returns
    -------
    str
        One sentence, or ``""`` when ``structure`` is empty.
    """
    if not structure:
        return ""
    names = GROUPING if both_directions else {**GROUPING, "rate": "between ramps and dwells"}
    items = "; ".join(f"{names.get(s.grouping, s.grouping)} ({_fmt_mg(s.rms_g)} RMS, largest at {s.where}: "
                      f"{s.departure_g * 1e3:+.3g} mg; ΔBIC {s.delta_bic:.0f})" for s in structure)
    return f"The residual has structure white noise would not make: {items}."


def _structure_and_discovery(d: Diagnosis, disc: Discovery | None, plugin_path: str | None) -> list[str]:
    """The honesty rule and the discovery: what remains, where, and the term found for it."""
    out = []
    if d.structure and (disc is None or not disc.proposed):
        out.append(structure_text(d.structure, both_directions(d.problem)))
    if disc is None:
        if d.structure:
            out.append("The library leaves this structure: `twin compare ... --discover` searches a dictionary of "
                       "terms built from the temperature history and time for the missing one.")
        return out
    if disc.proposed:
        beat = ", ".join(f"{b.feature} (ΔBIC {b.delta_bic:.0f})" for b in disc.beaten[:3])
        out.append(f"Discovery ({disc.features_tried} terms tried, searched on blocks it does not score): "
                   f"{disc.equation()}; held-out gain {100 * disc.heldout_gain:.0f} %, ΔBIC {disc.delta_bic:.0f}; "
                   f"RMS {_fmt_mg(disc.rms_before_g)} → {_fmt_mg(disc.rms_predicted_g)}"
                   + (f"; it beat {beat}" if beat else "") + ".")
        from twin.finding.lookalikes import FEATURE_FAMILY

        fam = FEATURE_FAMILY.get(disc.terms[0].spec.kind, "discovered")
        out.append("Attribution: to a signature only (a term outside the library). " + lookalike_hint(fam))
        if plugin_path:
            also = "".join(f" --with-effect {c.effect}" for c in d.selected)
            out.append(f"Written as an effect: {plugin_path} (add it with --plugin {plugin_path}{also}).")
    elif disc.preferred_library:
        out.append(f"Discovery prefers the library: {disc.preferred_library} explains the residual as well as any "
                   f"term of the dictionary; add it with --with-effect {disc.preferred_library}.")
    else:
        out.append(f"Discovery proposes nothing: {disc.reason}.")
    return out


def lookalike_hint(family: str) -> str:
    """Mechanisms that could make a discovered term's signature.

    Parameters
    ----------
    family : str
        The family whose look-alikes the term shares.

    Returns
    -------
    str
        One sentence, or ``""`` when the family has no catalogued mechanism.
    """
    from twin.finding.lookalikes import lookalikes

    mechs = lookalikes(family)
    if not mechs:
        return ""
    return "Mechanisms with a like signature: " + "; ".join(f"{m.name} (to tell: {m.test})" for m in mechs) + "."


def joint_finding(results: dict[str, CompareResult]) -> str:
    """One sentence per effect named on more than one axis, with its τ per axis and whether they agree.

    Parameters
    ----------
    results : dict of str to CompareResult
        Axis → its compare result.

    Returns
    -------
    str
    """
    named: dict[str, list[tuple[str, dict[str, float]]]] = {}
    for axis, r in results.items():
        for effect in r.selected[:1]:
            c = r.candidate(effect)
            named.setdefault(effect, []).append((axis, c.parameters_refined or c.parameters))
    parts = []
    for effect, hits in named.items():
        axes = ", ".join(a for a, _ in hits)
        taus = [p["tau_s"] for _, p in hits if "tau_s" in p]
        if len(hits) > 1 and len(taus) == len(hits):
            spread = tau_spread(taus)
            agree = ("consistent with one thermal path" if spread <= SHARED_TAU_SPREAD else
                     f"they differ by {100 * spread:.0f} %: not one thermal path, or the data cannot fix τ")
            what = "the die lags the sensor" if effect == "thermal_lag" else f"{effect}, τ"
            parts.append(f"{what} by ≈{' / '.join(f'{t:.0f}' for t in taus)} s on {axes} ({agree}).")
        else:
            parts.append(f"{effect} named on {axes}.")
    return " ".join(parts) or "No effect is named on any axis."
