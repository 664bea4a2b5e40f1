"""Stress from the transient gradient across package and board, ∝ rate of change."""

from sim.drift import smoothed_rate_c_per_s
from twin.effects.base import Contribution, Effect, Parameter
from twin.effects.registry import register


@register
class ThermalGradient(Effect):
    """Stress from the transient gradient across package and board, ∝ rate of change."""

    name = "thermal_gradient"
    family = "thermal_lag"
    description = ("bias ∝ dT/dt seen through a node of time constant τ (docs/diagnosis.md §2i); "
                   "aliased with thermal_lag unless a second probe or ramp-rate dependence separates them")
    reads = ("die_c",)
    parameters = (
        Parameter("coef_mg_per_c_per_min", "mg/(degC/min)", 0.5, (-50.0, 50.0), "similar to lag during ramps (docs/diagnosis.md §2i)"),
        Parameter("tau_s", "s", 300.0, (5.0, 1500.0),
                  "conduction through package/board: seconds to ~20 min (docs/physics.md §1.6); longer is creep",
                  role="nonlinear", grid=(30.0, 100.0, 300.0, 1000.0)),
    )

    def basis(self, inputs):
        """Bias per unit coefficient: the die temperature's rate through a lag τ, per run.

        Parameters
        ----------
        inputs : EffectInputs
            Reads ``die_c`` [°C].

        Returns
        -------
        dict of str to Contribution
            ``coef_mg_per_c_per_min``: bias [g] per mg/(°C/min).

        References
        ----------
        Rate of a first-order lag τ dy/dt = T − y (standard result); docs/diagnosis.md §2i.
        """
        dt, tau = inputs.dt_s, self.values["tau_s"]
        rate = inputs.per_run(lambda x: smoothed_rate_c_per_s(x, dt, tau), inputs.die_c)
        return {"coef_mg_per_c_per_min": Contribution(bias_g=rate * 60.0 * 1e-3)}
