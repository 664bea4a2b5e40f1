"""Slow drift in time, independent of temperature."""

import numpy as np

from twin.effects.base import Contribution, Effect, Parameter
from twin.effects.registry import register


@register
class AgingDrift(Effect):
    """Aging: bias = d·t + c·ln(1 + t/t0), t from the first sample, independent of temperature."""

    name = "aging_drift"
    family = "aging"
    description = "bias = d·t + c·ln(1 + t/t0), t from the first sample (docs/diagnosis.md §2j)"
    reads = ("time_s",)
    parameters = (
        Parameter("rate_mg_per_h", "mg/h", 0.05, (-10.0, 10.0), "well under 0.1 mg/h for a settled part (docs/diagnosis.md §2j)"),
        Parameter("log_mg", "mg", 0.0, (-50.0, 50.0), "logarithmic settling amplitude", screen=False),
        Parameter("t0_s", "s", 3600.0, (1.0, 1e7), "logarithmic time scale", role="fixed", free=False),
    )

    def basis(self, inputs):
        """Bias per unit of the linear rate and of the logarithmic amplitude.

        Parameters
        ----------
        inputs : EffectInputs
            Reads ``time_s`` [s].

        Returns
        -------
        dict of str to Contribution
            ``rate_mg_per_h``: bias [g] per mg/h; ``log_mg``: bias [g] per mg.

        References
        ----------
        docs/diagnosis.md §2j (a modelling choice, no further source).
        """
        t = np.asarray(inputs.time_s, float) - float(inputs.time_s[0]) if len(inputs.time_s) else np.zeros(0)
        return {"rate_mg_per_h": Contribution(bias_g=t / 3600.0 * 1e-3),
                "log_mg": Contribution(bias_g=np.log1p(t / self.values["t0_s"]) * 1e-3)}
