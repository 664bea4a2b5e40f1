"""Discovery into a compare result: the finding reworded, the JSON fields, and the plugin file.

The plugin is a generated ``.py`` file holding one :class:`~twin.effects.Effect` whose basis is the
discovered features (computed by :func:`~twin.diagnosis.discover_features.feature_full`, the code
the discovery used) and whose amplitudes are the discovered coefficients with units and bounds;
``twin compare --plugin FILE`` loads it and adds it to the twin.
"""

from __future__ import annotations

import hashlib
import json
from pathlib import Path

from twin.diagnosis.discover import Discovery, discover
from twin.diagnosis.language import finding_text
from twin.diagnosis.lookalikes import FEATURE_FAMILY, attribution, lookalikes_json
from twin.diagnosis.noise import white_noise_sigma_from_differences
from twin.io import atomic_write_text

PLUGIN_NAME = "discovered_effect.py"


def extras_json(d) -> dict:
    """What the finding adds to the compare JSON: look-alikes, attribution, structure, discovery.

    Parameters
    ----------
    d : Diagnosis

    Returns
    -------
    dict
    """
    out: dict = {"rms_after_selected_g": d.rms_after_selected_g, "structure": [s.json() for s in d.structure]}
    if d.selected:
        top = d.selected[0]
        out["attribution"] = attribution(top.family, top.effect)
        out["lookalikes"] = lookalikes_json(top.family, top.effect)
    disc = d.discovery
    if disc is not None:
        out["discovery"] = disc.json()
        if disc.proposed:
            fam = FEATURE_FAMILY.get(disc.terms[0].spec.kind, "discovered")
            out["discovery"]["attribution"] = "signature"
            out["discovery"]["lookalikes"] = lookalikes_json(fam, None)
            out["discovery"]["plugin"] = d.plugin_path
    return out


def effect_name(disc: Discovery) -> str:
    """A stable name for the discovered effect (from its terms)."""
    key = json.dumps([[t.spec.to_dict(), round(t.coef_mg, 6)] for t in disc.terms], sort_keys=True)
    return "discovered_" + hashlib.sha1(key.encode()).hexdigest()[:8]


def plugin_source(disc: Discovery, sources: list[str], with_effects: list[str] | None = None) -> str:
    """The Python source of the plugin module for ``disc`` (proposed terms only); ``with_effects``:
    the library effects named before it, part of the model its prediction assumes."""
    name = effect_name(disc)
    params = []
    for i, t in enumerate(disc.terms):
        bound = 10 * abs(t.coef_mg) + 1.0  # wide: the refit may move it, never to another order of magnitude
        unit = f"mg/{t.spec.unit}" if t.spec.unit not in ("", "1") else "mg"
        params.append(f"        Parameter({f'c{i + 1}_mg'!r}, {unit!r}, {t.coef_mg!r}, ({-bound!r}, {bound!r}),\n"
                      f"                  source='twin compare --discover', role='amplitude',\n"
                      f"                  description={t.spec.label!r}),")
    features = json.dumps([t.spec.to_dict() for t in disc.terms], ensure_ascii=False, indent=1)
    return f'''"""Effect discovered by ``twin compare --discover`` (generated; edit freely).

Data: {", ".join(sources) or "-"}
{disc.equation()}
held-out gain {100 * disc.heldout_gain:.1f} %, ΔBIC {disc.delta_bic:.1f}, {disc.features_tried} terms tried;
RMS {disc.rms_before_g * 1e3:.4f} mg -> {disc.rms_predicted_g * 1e3:.4f} mg predicted, with the twin's effects
plus {", ".join(with_effects or []) or "nothing else"}: twin compare ... --plugin THIS_FILE{"".join(" --with-effect " + e for e in with_effects or [])}
"""

import json

from twin.diagnosis.discover_features import FeatureSpec, feature_full
from twin.effects import Contribution, Effect, Parameter, register

FEATURES = [FeatureSpec.from_dict(f) for f in json.loads({features!r})]
AVERAGE_S = {disc.average_s!r}
PREDICTED_RMS_G = {disc.rms_predicted_g!r}
PREDICTED_WITH = {list(with_effects or [])!r}


@register
class DiscoveredEffect(Effect):
    name = {name!r}
    family = "discovered"
    reads = ("time_s", "die_c", "run_index", "time_since_power_on_s")
    description = {disc.equation()!r}
    parameters = (
{chr(10).join(params)}
    )

    def basis(self, inputs):
        out = {{}}
        for p, spec in zip(self.parameters, FEATURES):
            col = feature_full(spec, inputs.time_s, inputs.die_c, inputs.run_index, inputs.time_since_power_on_s,
                               AVERAGE_S)
            out[p.name] = Contribution(bias_g=1e-3 * col)
        return out
'''


def discover_into(d, result: dict, plugin_path: Path | None = None, sources: list[str] | None = None) -> dict:
    """Run discovery on a diagnosis, reword its finding, add the JSON fields; write the plugin.

    Parameters
    ----------
    d : Diagnosis
    result : dict
        The compare JSON (updated in place).
    plugin_path : Path, optional
        Where to write the plugin when a term is proposed (not written when None).
    sources : list of str, optional
        Measurement files, quoted in the plugin's docstring.

    Returns
    -------
    dict
        ``result``.
    """
    # the floor on the problem's own rows: a fast log is diagnosed on k-sample means (diagnosis.decimate),
    # and d.noise_floor_g is then the full-rate floor, not comparable with residuals on the means
    floor = white_noise_sigma_from_differences(d.calibration.residual, d.problem.m.run_index)
    d.discovery = discover(d.problem, d.calibration, d.selected, d.candidates, floor)
    if d.discovery.proposed and plugin_path is not None:
        Path(plugin_path).parent.mkdir(parents=True, exist_ok=True)
        atomic_write_text(Path(plugin_path), plugin_source(d.discovery, sources or [], [c.effect for c in d.selected]))
        d.plugin_path = str(plugin_path)
    d.finding = finding_text(d)
    result["finding"] = d.finding
    result.update(extras_json(d))
    return result


__all__ = ["PLUGIN_NAME", "discover_into", "effect_name", "extras_json", "plugin_source"]
