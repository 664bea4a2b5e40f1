"""Empirical sensitivity drift against die temperature, linear + quadratic (TCSo)."""

from sim.drift import scale_factor_tc
from twin.effects._common import REFERENCE_C
from twin.effects.base import Contribution, Effect, Parameter
from twin.effects.registry import register


@register
class ScaleFactorTC(Effect):
    """Empirical sensitivity drift against die temperature, linear + quadratic (TCSo)."""

    name = "scale_factor_tc"
    family = "scale_factor"
    description = "relative sensitivity vs die temperature, s1·ΔT + s2·ΔT² (TCSo; odd in the applied g)"
    reads = ("die_c", "applied_g")
    parameters = (
        Parameter("tc1_ppm_per_c", "ppm/degC", 100.0, (-1000.0, 1000.0), "TCSo ±0.01 %/°C, recalled (family datasheets)"),
        Parameter("tc2_ppm_per_c2", "ppm/degC^2", 0.0, (-10.0, 10.0), "typical: +0.07 ppm/°C² from E(T) (docs/physics.md §2.5)"),
        REFERENCE_C,
    )

    def basis(self, inputs):
        """Scale factor per unit linear and quadratic tempco, s·ΔT and s·ΔT².

        Parameters
        ----------
        inputs : EffectInputs
            Reads ``die_c`` [°C].

        Returns
        -------
        dict of str to Contribution
            ``tc1_ppm_per_c``: scale factor [1] per ppm/°C; ``tc2_ppm_per_c2``: per ppm/°C².

        References
        ----------
        IEEE Std 1293 model equation (as :func:`sim.drift.scale_factor_tc`).
        """
        ref = self.values["reference_c"]
        return {"tc1_ppm_per_c": Contribution(scale_factor=scale_factor_tc(inputs.die_c, 1.0, 0.0, ref)),
                "tc2_ppm_per_c2": Contribution(scale_factor=scale_factor_tc(inputs.die_c, 0.0, 1.0, ref))}
