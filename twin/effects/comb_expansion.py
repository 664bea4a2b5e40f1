"""The paper's microstructure mechanism: comb thermal expansion → sensitivity (reading S)."""

from functools import lru_cache

import numpy as np

from sim.microstructure import CombGeometry, drift_g
from twin.effects._common import REFERENCE_C
from twin.effects.base import Contribution, Effect, Parameter
from twin.effects.registry import register

_GRID_C = np.arange(-60.0, 150.0 + 1e-9, 0.05)  # fixed, so a sample never depends on others (causal)


@lru_cache(maxsize=32)
def _scale_factor_table(geometry: CombGeometry, reference_c: float) -> np.ndarray:
    return drift_g(geometry, _GRID_C, 1.0, "S", reference_c)["scale_factor"]


@register
class CombExpansion(Effect):
    """The paper's microstructure mechanism: comb thermal expansion → sensitivity (reading S)."""

    name = "comb_expansion"
    family = "scale_factor"
    description = ("comb fingers grow with the silicon strain ε(T) while anchors stay (paper eq. 15 with ε, "
                   "reading S): ≈ +15 ppm/°C with the default geometry; from geometry, no free amplitude")
    reads = ("die_c", "applied_g")
    parameters = (
        Parameter("scale", "1", 1.0, (0.0, 100.0), "geometry and material (docs/physics.md §2.5); 1 = as computed",
                  free=False),
        REFERENCE_C,
    )

    def basis(self, inputs):
        """Scale factor of the default-geometry comb against die temperature, per unit ``scale``.

        Parameters
        ----------
        inputs : EffectInputs
            Reads ``die_c`` [°C] (geometry from the context).

        Returns
        -------
        dict of str to Contribution
            ``scale``: relative scale-factor change [1] per unit scale.

        References
        ----------
        Qi et al. (2022), Micromachines 13, 2156, eq. (15) with the silicon strain ε(T), differential
        signal of eqs. (16)–(19) (:func:`sim.microstructure.drift_g`).
        """
        geometry = self.context.get("geometry") or CombGeometry()
        die = np.asarray(inputs.die_c, float)
        if die.size and (die.min() < _GRID_C[0] or die.max() > _GRID_C[-1]):
            sf = drift_g(geometry, die, 1.0, "S", self.values["reference_c"])["scale_factor"]
        else:
            # smooth (quadratic) in T: linear interpolation on 0.05 °C loses < 1e-12 relative
            sf = np.interp(die, _GRID_C, _scale_factor_table(geometry, self.values["reference_c"]))
        return {"scale": Contribution(scale_factor=sf)}
