"""Zero-g level against die temperature, linear + quadratic (TCOff)."""

from sim.drift import bias_tc_g
from twin.effects._common import REFERENCE_C
from twin.effects.base import Contribution, Effect, Parameter
from twin.effects.registry import register


@register
class StaticBiasTC(Effect):
    """Zero-g level against die temperature, linear + quadratic + cubic (TCOff)."""

    name = "static_bias_tc"
    family = "bias_tc"
    description = "bias vs die temperature, b1·ΔT + b2·ΔT² + b3·ΔT³ (TCOff; docs/diagnosis.md §2b/e/f)"
    reads = ("die_c",)
    parameters = (
        Parameter("tc1_mg_per_c", "mg/degC", 0.8, (-5.0, 5.0), "paper eq. (34), attributed to the datasheet; unverified"),
        Parameter("tc2_mg_per_c2", "mg/degC^2", 0.0, (-0.1, 0.1), "typical 1e-5..1e-3 (docs/diagnosis.md §2e)"),
        Parameter("tc3_mg_per_c3", "mg/degC^3", 0.0, (-0.01, 0.01),
                  "cubic term (docs/diagnosis.md §2e; PX4 fits 3rd-order offset polynomials)"),
        REFERENCE_C,
    )

    def basis(self, inputs):
        """Bias per unit tempco of each order, ΔT, ΔT², ΔT³.

        Parameters
        ----------
        inputs : EffectInputs
            Reads ``die_c`` [°C].

        Returns
        -------
        dict of str to Contribution
            ``tc1_mg_per_c``, ``tc2_mg_per_c2``, ``tc3_mg_per_c3``: bias [g] per mg/°C, mg/°C², mg/°C³.

        References
        ----------
        IEEE Std 1293 model equation (as :func:`sim.drift.bias_tc_g`); cubic term of PX4's
        TemperatureCompensation offset polynomial; docs/diagnosis.md §2b/e/f.
        """
        ref = self.values["reference_c"]
        dT = inputs.die_c - ref
        return {"tc1_mg_per_c": Contribution(bias_g=bias_tc_g(inputs.die_c, 1.0, 0.0, ref)),
                "tc2_mg_per_c2": Contribution(bias_g=bias_tc_g(inputs.die_c, 0.0, 1.0, ref)),
                "tc3_mg_per_c3": Contribution(bias_g=dT * dT * dT * 1e-3)}  # not dT**3: pow is 90× slower
