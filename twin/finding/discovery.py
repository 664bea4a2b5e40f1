"""A discovered term as an effect plugin file.

The plugin is a generated ``.py`` file holding one :class:`~twin.effects.Effect` whose basis is the
discovered features (computed by :func:`~twin.discovery.features.feature_full`, the code
the discovery used) and whose amplitudes are the discovered coefficients with units and bounds;
``twin compare --plugin FILE`` loads it and adds it to the twin.
"""

from __future__ import annotations

import hashlib
import json
from pathlib import Path

from twin.discovery.search import Discovery
from twin.io import atomic_write_text

PLUGIN_NAME = "discovered_effect.py"


def effect_name(disc: Discovery) -> str:
    """A stable name for the discovered effect (from its terms).

    Parameters
    ----------
    disc : Discovery
        The discovery whose terms (feature and coefficient [mg]) name it.

    Returns
    -------
    str
        ``discovered_`` and the first 8 hex digits of the SHA-1 of the terms.
    """
    key = json.dumps([[t.spec.to_dict(), round(t.coef_mg, 6)] for t in disc.terms], sort_keys=True)
    return "discovered_" + hashlib.sha1(key.encode()).hexdigest()[:8]


def plugin_source(disc: Discovery, sources: list[str], with_effects: list[str] | None = None) -> str:
    """The Python source of the plugin module for ``disc`` (proposed terms only).

    Parameters
    ----------
    disc : Discovery
        A proposed discovery; its coefficients [mg per feature unit] become the amplitudes.
    sources : list of str
        Measurement files, quoted in the plugin's docstring.
    with_effects : list of str, optional
        The library effects named before it, part of the model its prediction assumes.

    Returns
    -------
    str
        The module's source text.
    """
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

from twin.discovery.features import FeatureSpec, feature_full
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


def write_plugin(path: Path, disc: Discovery, sources: list[str], with_effects: list[str]) -> Path:
    """Write the discovered term as an effect plugin, atomically.

    Parameters
    ----------
    path : Path
        The plugin file to write.
    disc : Discovery
        A proposed discovery.
    sources : list of str
        Measurement files, quoted in the plugin's docstring.
    with_effects : list of str
        The library effects named before it, part of the model its prediction assumes.

    Returns
    -------
    Path
        The file written.
    """
    path.parent.mkdir(parents=True, exist_ok=True)
    return atomic_write_text(path, plugin_source(disc, sources, with_effects))


__all__ = ["PLUGIN_NAME", "effect_name", "plugin_source", "write_plugin"]
