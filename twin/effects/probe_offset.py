"""Reference-thermometer offset: the probe reads δ above the true temperature."""

import numpy as np

from twin.effects.base import Contribution, Effect, Parameter
from twin.effects.registry import register


@register
class ProbeOffset(Effect):
    """Reference-thermometer offset: the probe reads δ above the true temperature (unidentifiable)."""

    name = "probe_offset"
    family = "probe"
    identifiable = False
    acts_on_thermometer = True
    description = ("thermometer reads T + δ. In a simulated device it shifts the logged temperature, not the "
                   "output; in the twin its column is a constant −b1·δ, absorbed exactly by the calibrated "
                   "offset: structurally unidentifiable (docs/diagnosis.md §2h)")
    reads = ("thermometer_c",)
    parameters = (
        Parameter("offset_c", "degC", 0.5, (-10.0, 10.0), "0.2-2 °C is common (docs/diagnosis.md §2h)"),
        Parameter("tc_mg_per_c", "mg/degC", 0.8, (-5.0, 5.0), "bias tempco through which the offset shows",
                  role="fixed", free=False),
    )

    def thermometer_shift_c(self):
        """What the reading gains in a simulated device: the offset δ.

        Returns
        -------
        float
            δ [°C].
        """
        return self.values["offset_c"]

    def basis(self, inputs):
        """Bias per °C of probe offset, −b1 through the bias tempco (constant in time).

        Parameters
        ----------
        inputs : EffectInputs
            Reads ``time_s`` [s] (for the shape only).

        Returns
        -------
        dict of str to Contribution
            ``offset_c``: bias [g] per °C of offset.

        References
        ----------
        docs/diagnosis.md §2h.
        """
        return {"offset_c": Contribution(bias_g=-self.values["tc_mg_per_c"] * 1e-3 * np.ones(np.shape(inputs.time_s)))}
