"""Rate-independent memory of the temperature path: a play operator (Prandtl–Ishlinskii hysteron)."""

import numpy as np

from sim.play import play_operator
from twin.effects.base import Contribution, Effect, Parameter
from twin.effects.registry import register


@register
class ThermalHysteresis(Effect):
    """Rate-independent memory of the temperature path: a play operator (Prandtl–Ishlinskii hysteron)."""

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
        """Bias per unit k: play_r(T) − T, per run.

        Parameters
        ----------
        inputs : EffectInputs
            Reads ``die_c`` [°C].

        Returns
        -------
        dict of str to Contribution
            ``k_mg_per_c``: bias [g] per mg/°C.

        References
        ----------
        Krasnosel'skii & Pokrovskii (1989), *Systems with Hysteresis*.
        """
        r = self.values["half_width_c"]
        die = np.asarray(inputs.die_c, float)
        state = inputs.per_run(lambda x: play_operator(x, r), die)
        return {"k_mg_per_c": Contribution(bias_g=(state - die) * 1e-3)}
