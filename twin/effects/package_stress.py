"""CTE mismatch of the die/attach/package/board stack → bias (elastic, instantaneous)."""

import numpy as np

from twin.effects._common import REFERENCE_C
from twin.effects.base import Contribution, Effect, Parameter
from twin.effects.registry import register


@register
class PackageStress(Effect):
    """CTE mismatch of the die/attach/package/board stack → bias (elastic, instantaneous)."""

    name = "package_stress"
    family = "bias_tc"
    description = ("bias = coupling × CTE mismatch × ΔT (docs/diagnosis.md §2b): same signature as a bias "
                   "tempco, so aliased with static_bias_tc in output data")
    reads = ("die_c",)
    parameters = (
        Parameter("coupling_mg_per_ustrain", "mg/microstrain", 0.02, (-1.0, 1.0),
                  "chosen so that 0.2 % of the Si-FR-4 mismatch over a 500 µm span gives ~0.3 mg/°C "
                  "(docs/physics.md §1.4); device-specific"),
        Parameter("cte_mismatch_ppm_per_k", "ppm/K", 14.0, (0.0, 300.0), "FR-4 in-plane 16.6 − Si 2.55 (docs/physics.md §1.4)",
                  role="fixed", free=False),
        REFERENCE_C,
    )

    def basis(self, inputs):
        """Bias per unit coupling: strain = CTE mismatch × (T_die − T_ref).

        Parameters
        ----------
        inputs : EffectInputs
            Reads ``die_c`` [°C].

        Returns
        -------
        dict of str to Contribution
            ``coupling_mg_per_ustrain``: bias [g] per mg/microstrain.

        References
        ----------
        docs/diagnosis.md §2b; thermal strain Δα·ΔT (standard result).
        """
        strain_ue = self.values["cte_mismatch_ppm_per_k"] * (np.asarray(inputs.die_c) - self.values["reference_c"])
        return {"coupling_mg_per_ustrain": Contribution(bias_g=strain_ue * 1e-3)}
