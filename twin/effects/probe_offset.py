"""Reference-thermometer offset: the probe reads δ above the true temperature."""

import numpy as np

from twin.effects.base import Contribution, Effect, Parameter, register


@register
class ProbeOffset(Effect):
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
        return self.values["offset_c"]

    def basis(self, inputs):
        return {"offset_c": Contribution(bias_g=-self.values["tc_mg_per_c"] * 1e-3 * np.ones(np.shape(inputs.time_s)))}
