"""Rate-independent memory of the temperature path: a play operator (Prandtl–Ishlinskii hysteron)."""

import numpy as np

from sim.drift import play_operator
from twin.effects.base import Contribution, Effect, Parameter, register


@register
class ThermalHysteresis(Effect):
    name = "thermal_hysteresis"
    family = "hysteresis"
    description = ("bias = k·(play_r(T) − T): opposite offsets on heating and cooling whatever the ramp rate, "
                   "loop width 2r in temperature")
    reads = ("die_c",)
    parameters = (
        Parameter("k_mg_per_c", "mg/degC", 0.2, (-10.0, 10.0), "stick-slip of attach/mould; device-specific"),
        Parameter("half_width_c", "degC", 2.0, (0.01, 30.0), "play half-width r", role="nonlinear",
                  grid=(0.5, 1.0, 2.0, 4.0, 8.0)),
    )

    def basis(self, inputs):
        r = self.values["half_width_c"]
        die = np.asarray(inputs.die_c, float)
        state = inputs.per_run(lambda x: play_operator(x, r), die)
        return {"k_mg_per_c": Contribution(bias_g=(state - die) * 1e-3)}
