"""Young's modulus vs temperature → spring stiffness → open-loop sensitivity."""

from sim.materials import KELVIN, silicon_youngs_modulus_pa
from twin.effects._common import REFERENCE_C
from twin.effects.base import Contribution, Effect, Parameter
from twin.effects.registry import register


@register
class StiffnessTC(Effect):
    """Young's modulus vs temperature → spring stiffness → open-loop sensitivity."""

    name = "stiffness_tc"
    family = "scale_factor"
    description = ("spring k ∝ E(T) (Wachtman/Gysin): sensitivity ∝ 1/k, ≈ +67.9 ppm/°C at 25 °C "
                   "(docs/physics.md §1.3); from material, no free amplitude")
    reads = ("die_c", "applied_g")
    parameters = (
        Parameter("scale", "1", 1.0, (0.0, 100.0), "material (Gysin et al. 2004); 1 = as computed; ASIC trim lowers it",
                  free=False),
        REFERENCE_C,
    )

    def basis(self, inputs):
        """Scale factor E(T_ref)/E(T_die) − 1 per unit ``scale`` (sensitivity ∝ 1/k ∝ 1/E).

        Parameters
        ----------
        inputs : EffectInputs
            Reads ``die_c`` [°C].

        Returns
        -------
        dict of str to Contribution
            ``scale``: relative scale-factor change [1] per unit scale.

        References
        ----------
        Gysin et al., Phys. Rev. B 69, 045403 (2004) (Wachtman form), as
        :func:`sim.materials.silicon_youngs_modulus_pa`.
        """
        e_ref = silicon_youngs_modulus_pa(self.values["reference_c"] + KELVIN)
        return {"scale": Contribution(scale_factor=e_ref / silicon_youngs_modulus_pa(inputs.die_c + KELVIN) - 1.0)}
