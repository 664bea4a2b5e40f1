"""The diagnosis in plain language: remedies, residual signatures, the finding.

Every English sentence of ``twin compare`` lives here; the other modules decide, this one says.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from twin.diagnosis.selection import cross_family_partners
from twin.diagnosis.structure import both_directions

if TYPE_CHECKING:
    from twin.diagnosis.diagnose import Diagnosis

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


def _fmt_mg(x_g: float) -> str:
    return f"{x_g * 1e3:.3g} mg"


def finding_text(d: Diagnosis) -> str:
    """A plain-language finding for the report and the CLI.

    Parameters
    ----------
    d : Diagnosis

    Returns
    -------
    str
        The finding, then what cannot be separated or tested and how to fix it.
    """
    rms = d.rms_residual_g
    parts = [f"This data cannot separate {' from '.join(a['effects'])}: {a['remedy']}." for a in d.aliases
             if a.get("aliased_with") == "per-run offsets"]
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
        parts.append(f"{w['effect']} passes the significance tests, but {w['outranked_by']} ({w['outranked_by_family']}) "
                     f"explains more of the residual (ΔBIC {w['delta_bic'][1]:.0f} vs {w['delta_bic'][0]:.0f}) without "
                     f"passing them: the data do not say which effect is missing, so none is named. To separate "
                     f"them: {REMEDY.get(w['outranked_by_family'], 'a different test plan')}.")
    elif d.structure or (d.discovery is not None and d.discovery.proposed):
        parts.append(f"No library effect explains the residual, but it is not white noise: RMS {_fmt_mg(rms)}, "
                     f"{rms / d.noise_floor_g:.2f}× the white-noise floor of {_fmt_mg(d.noise_floor_g)}.")
    else:
        parts.append(f"No missing effect found: residual RMS {_fmt_mg(rms)} against a noise floor of "
                     f"{_fmt_mg(d.noise_floor_g)}.")
        if rms > 1.1 * d.noise_floor_g:
            parts.append(f"The residual is {rms / d.noise_floor_g:.2f}× the white-noise floor, without structure in "
                         "temperature, rate or time beyond the noise model: slow correlated noise (see the Allan "
                         "deviation and dwell plots).")
    parts += _structure_and_discovery(d)
    remedies: dict[str, list[str]] = {}
    top_effects = {c.effect for c in d.selected}
    for a in d.aliases:
        if a.get("aliased_with") == "per-run offsets":
            continue
        if d.selected and not d.rivals:
            top = d.selected[0]
            others = cross_family_partners(top, [a], d.candidates)
            if others:  # alike in shape, yet the evidence tells them apart: say so, not "not separable"
                best = max(others, key=others.get)
                parts.append(f"{' / '.join(a['effects'])} are alike in shape with this test plan, but the evidence "
                             f"separates them here: {top.effect} ΔBIC {top.delta_bic:.0f} against "
                             f"{others[best]:.0f} for {best}.")
                continue
        if "aliased_with" in a or top_effects & set(a["effects"]):
            remedies.setdefault(a["remedy"], []).append(" / ".join(a["effects"]) +
                                                        (f" (with {a['aliased_with']})" if "aliased_with" in a else ""))
    for u in d.untestable:
        if u["family"] in ("scale_factor", "probe"):
            remedies.setdefault(u["remedy"], []).append(u["effect"])
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


def family_choice_text(choice: dict) -> str:
    """Why one effect of a family is named over the others, calibrated whole."""
    fits = "; ".join(f"{m['effect']} {m['free_parameters']} parameters, residual {m['rss_over_best']:.4f}× the best"
                     + (f", BIC {m['bic_minus_named']:+.1f}" if m['effect'] != choice['named'] else "")
                     for m in choice["models"])
    return f"Calibrated whole: {fits}. {choice['named']} is named: {FAMILY_CHOICE_REASON[choice['reason']]}."


def _attribution_text(family: str, effect: str | None) -> str:
    """Whether the named effect is a mechanism or only a signature, and its look-alikes."""
    from twin.diagnosis.lookalikes import attribution, lookalikes_sentence

    if attribution(family, effect) == "mechanism":
        return "Attribution: to a mechanism (no mechanism outside the library shares this signature)."
    return "Attribution: to a signature, not a mechanism. " + lookalikes_sentence(family, effect)


def structure_text(structure: list, both_directions: bool = True) -> str:
    """Where the residual departs from the noise model and by how much ('' when nowhere); with one
    thermal direction in the data the rate grouping is named without setting heating against cooling."""
    if not structure:
        return ""
    names = GROUPING if both_directions else {**GROUPING, "rate": "between ramps and dwells"}
    items = "; ".join(f"{names.get(s.grouping, s.grouping)} ({_fmt_mg(s.rms_g)} RMS, largest at {s.where}: "
                      f"{s.departure_g * 1e3:+.3g} mg; ΔBIC {s.delta_bic:.0f})" for s in structure)
    return f"The residual has structure white noise would not make: {items}."


def _structure_and_discovery(d: Diagnosis) -> list[str]:
    """The honesty rule and the discovery: what remains, where, and the term found for it."""
    out = []
    disc = d.discovery
    if d.structure and (disc is None or not disc.proposed):
        out.append(structure_text(d.structure, both_directions(d.problem)))
    if disc is None:
        if d.structure:
            out.append("The library leaves this structure: `twin compare ... --discover` searches a dictionary of "
                       "terms built from the temperature history and time for the missing one.")
        return out
    if disc.proposed:
        beat = ", ".join(f"{b['feature']} (ΔBIC {b['delta_bic']:.0f})" for b in disc.beaten[:3])
        out.append(f"Discovery ({disc.features_tried} terms tried, searched on blocks it does not score): "
                   f"{disc.equation()}; held-out gain {100 * disc.heldout_gain:.0f} %, ΔBIC {disc.delta_bic:.0f}; "
                   f"RMS {_fmt_mg(disc.rms_before_g)} → {_fmt_mg(disc.rms_predicted_g)}"
                   + (f"; it beat {beat}" if beat else "") + ".")
        from twin.diagnosis.lookalikes import FEATURE_FAMILY

        fam = FEATURE_FAMILY.get(disc.terms[0].spec.kind, "discovered")
        out.append("Attribution: to a signature only (a term outside the library). " + lookalike_hint(fam))
        if d.plugin_path:
            also = "".join(f" --with-effect {c.effect}" for c in d.selected)
            out.append(f"Written as an effect: {d.plugin_path} (add it with --plugin {d.plugin_path}{also}).")
    elif disc.preferred_library:
        out.append(f"Discovery prefers the library: {disc.preferred_library} explains the residual as well as any "
                   f"term of the dictionary; add it with --with-effect {disc.preferred_library}.")
    else:
        out.append(f"Discovery proposes nothing: {disc.reason}.")
    return out


def lookalike_hint(family: str) -> str:
    """Mechanisms that could make a discovered term's signature."""
    from twin.diagnosis.lookalikes import lookalikes

    mechs = lookalikes(family)
    if not mechs:
        return ""
    return "Mechanisms with a like signature: " + "; ".join(f"{m.name} (to tell: {m.test})" for m in mechs) + "."
