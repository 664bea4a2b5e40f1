"""Built-in effects of the minimal drift law (bias and scale factor against die temperature)."""

from __future__ import annotations

from sim.drift import bias_tc_g, scale_factor_tc
from twin.effects.base import Contribution, Effect, EffectInputs, Parameter, register

_REFERENCE = Parameter("reference_c", "degC", 25.0, (-40.0, 105.0), "convention", "temperature of zero drift")


@register
class NullEffect(Effect):
    """Nothing: the explicit absent effect."""

    name = "null"
    family = "null"
    description = "contributes nothing (the explicit 'absent' effect)"

    def contribution(self, inputs: EffectInputs) -> Contribution:
        return Contribution()


@register
class StaticBiasTC(Effect):
    """Zero-g level against die temperature, linear + quadratic (TCOff)."""

    name = "static_bias_tc"
    family = "bias_tc"
    description = "bias vs die temperature, b1·ΔT + b2·ΔT² (TCOff)"
    reads = ("die_c",)
    parameters = (
        Parameter("tc1_mg_per_c", "mg/degC", 0.8, (-5.0, 5.0), "paper eq. (34), attributed to the datasheet; unverified"),
        Parameter("tc2_mg_per_c2", "mg/degC^2", 0.0, (-0.1, 0.1), "typical: small curvature (physics-notes §2.5)"),
        _REFERENCE,
    )

    def contribution(self, inputs: EffectInputs) -> Contribution:
        v = self.values
        return Contribution(bias_g=bias_tc_g(inputs.die_c, v["tc1_mg_per_c"], v["tc2_mg_per_c2"], v["reference_c"]))


@register
class ScaleFactorTC(Effect):
    """Sensitivity against die temperature, linear + quadratic (TCSo)."""

    name = "scale_factor_tc"
    family = "scale_factor"
    description = "relative sensitivity vs die temperature, s1·ΔT + s2·ΔT² (TCSo)"
    reads = ("die_c", "applied_g")
    parameters = (
        Parameter("tc1_ppm_per_c", "ppm/degC", 100.0, (-1000.0, 1000.0), "TCSo ±0.01 %/°C, recalled (family datasheets)"),
        Parameter("tc2_ppm_per_c2", "ppm/degC^2", 0.0, (-10.0, 10.0), "typical: +0.07 ppm/°C² from E(T) (physics-notes §2.5)"),
        _REFERENCE,
    )

    def contribution(self, inputs: EffectInputs) -> Contribution:
        v = self.values
        return Contribution(scale_factor=scale_factor_tc(inputs.die_c, v["tc1_ppm_per_c"], v["tc2_ppm_per_c2"], v["reference_c"]))
