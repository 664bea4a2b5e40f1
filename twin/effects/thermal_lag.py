"""The twin's model of the die lagging the reference thermometer (one or two RC nodes)."""

import numpy as np

from sim.drift import lowpass
from twin.effects.base import Contribution, Effect, Parameter
from twin.effects.registry import register


@register
class ThermalLag(Effect):
    """The twin's model of the die lagging the reference thermometer (one or two RC nodes)."""

    name = "thermal_lag"
    family = "thermal_lag"
    slot = "temperature"
    description = ("die = one- or two-node lag of the measured temperature (τ dT_d/dt = T_m − T_d). In the twin "
                   "it feeds every temperature effect; its screening column is LP_τ(T) − T times a bias tempco. "
                   "Generated data get their lag from the thermal chain, not from this effect.")
    reads = ("thermometer_c",)
    parameters = (
        Parameter("tau_s", "s", 120.0, (1.0, 7200.0), "board in chamber air: 1-10 min (docs/diagnosis.md §2a)",
                  role="nonlinear", grid=(15.0, 30.0, 60.0, 120.0, 240.0, 480.0, 960.0, 1920.0)),
        Parameter("tau2_s", "s", 0.0, (0.0, 7200.0), "second node (package behind board); 0 = one node",
                  role="nonlinear", grid=(0.0,)),
        Parameter("tc_mg_per_c", "mg/degC", 0.8, (-5.0, 5.0),
                  "bias tempco the lag acts through: amplitude of the screening column only"),
    )

    def die_temperature(self, inputs):
        """Die temperature: the thermometer through one or two first-order lags, per run.

        Parameters
        ----------
        inputs : EffectInputs
            Reads ``thermometer_c`` [°C].

        Returns
        -------
        ndarray
            Die temperature [°C].

        References
        ----------
        Standard first-order lag τ dT_d/dt = T_m − T_d (:func:`sim.drift.lowpass`).
        """
        dt, t1, t2 = inputs.dt_s, self.values["tau_s"], self.values["tau2_s"]
        return inputs.per_run(lambda x: lowpass(lowpass(x, dt, t1), dt, t2), inputs.thermometer_c)

    def basis(self, inputs):
        """Screening column: bias per unit tempco, LP_τ(T) − T.

        Parameters
        ----------
        inputs : EffectInputs
            Reads ``thermometer_c`` [°C].

        Returns
        -------
        dict of str to Contribution
            ``tc_mg_per_c``: bias [g] per mg/°C.

        References
        ----------
        Standard first-order lag τ dT_d/dt = T_m − T_d; docs/diagnosis.md §2a.
        """
        lagged = self.die_temperature(inputs)
        return {"tc_mg_per_c": Contribution(bias_g=(lagged - np.asarray(inputs.thermometer_c)) * 1e-3)}
