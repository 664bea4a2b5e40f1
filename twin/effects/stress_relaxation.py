"""Viscoelastic creep of die attach and mould: Maxwell elements (a two-term Prony sum)."""

import numpy as np

from sim.drift import maxwell_relaxation
from twin.effects._common import REFERENCE_C
from twin.effects.base import Contribution, Effect, Parameter
from twin.effects.registry import register


@register
class StressRelaxation(Effect):
    """Viscoelastic creep of die attach and mould: Maxwell elements (a two-term Prony sum)."""

    name = "stress_relaxation"
    family = "hysteresis"
    description = ("bias = Σ k_i·(ΔT − LP_τi(ΔT)): follows temperature changes, relaxes over hours in dwells, "
                   "hysteresis that persists at slow ramps (docs/diagnosis.md §2c)")
    reads = ("die_c",)
    parameters = (
        Parameter("k1_mg_per_c", "mg/degC", 0.1, (-10.0, 10.0), "0.1-few mg amplitude (docs/diagnosis.md §2c)"),
        Parameter("tau_s", "s", 7200.0, (1800.0, 200000.0), "0.5-5 h (docs/diagnosis.md §2c); shorter is a thermal gradient",
                  role="nonlinear",
                  grid=(1800.0, 3600.0, 7200.0, 14400.0, 28800.0)),
        Parameter("k2_mg_per_c", "mg/degC", 0.0, (-10.0, 10.0), "second Prony term", screen=False),
        Parameter("tau2_s", "s", 36000.0, (1800.0, 200000.0), "second Prony time constant", role="nonlinear",
                  grid=(36000.0,)),
        REFERENCE_C,
    )

    def basis(self, inputs):
        """Bias per unit of each Prony amplitude: ΔT − LP_τi(ΔT), per run.

        Parameters
        ----------
        inputs : EffectInputs
            Reads ``die_c`` [°C].

        Returns
        -------
        dict of str to Contribution
            ``k1_mg_per_c``, ``k2_mg_per_c``: bias [g] per mg/°C.

        References
        ----------
        Maxwell element (standard viscoelastic model), docs/diagnosis.md §2c.
        """
        dt = inputs.dt_s
        delta = np.asarray(inputs.die_c, float) - self.values["reference_c"]
        out = {}
        for amp, tau in (("k1_mg_per_c", "tau_s"), ("k2_mg_per_c", "tau2_s")):
            t = self.values[tau]
            out[amp] = Contribution(bias_g=inputs.per_run(lambda x: maxwell_relaxation(x, dt, t), delta) * 1e-3)
        return out
