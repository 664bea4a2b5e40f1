"""The paper's microstructure mechanism: comb thermal expansion → sensitivity (reading S)."""

import numpy as np

from sim.microstructure import CombGeometry, drift_g
from twin.effects._common import REFERENCE_C
from twin.effects.base import Contribution, Effect, Parameter, register


@register
class CombExpansion(Effect):
    name = "comb_expansion"
    family = "scale_factor"
    description = ("comb fingers grow with the silicon strain ε(T) while anchors stay (paper eq. 15 with ε, "
                   "reading S): ≈ +15 ppm/°C with the default geometry; from geometry, no free amplitude")
    reads = ("die_c", "applied_g")
    parameters = (
        Parameter("scale", "1", 1.0, (0.0, 100.0), "geometry and material (physics-notes §2.5); 1 = as computed",
                  free=False),
        REFERENCE_C,
    )

    def basis(self, inputs):
        geometry = self.context.get("geometry") or CombGeometry()
        die = np.asarray(inputs.die_c, float)
        # Smooth (quadratic) in T: evaluate on a 0.05 °C grid and interpolate (error < 1e-12 relative).
        grid = np.arange(np.floor(die.min()) - 0.05, np.ceil(die.max()) + 0.1, 0.05)
        sf = drift_g(geometry, grid, 1.0, "S", self.values["reference_c"])["scale_factor"]
        return {"scale": Contribution(scale_factor=np.interp(die, grid, sf))}
