"""Transient after each power-on (board electronics warming the PCB, electronic settling)."""

from sim.drift import warmup_shape
from twin.effects.base import Contribution, Effect, Parameter
from twin.effects.registry import register


@register
class Warmup(Effect):
    """Transient after each power-on (board electronics warming the PCB, electronic settling)."""

    name = "warmup"
    family = "warmup"
    description = "bias = A·exp(−t_on/τ) after each power-on, same sign every time (docs/diagnosis.md §2g)"
    reads = ("time_since_power_on_s",)
    parameters = (
        Parameter("amplitude_mg", "mg", 1.0, (-50.0, 50.0), "0.1-1 °C of board warming × tempco (docs/diagnosis.md §2g)"),
        Parameter("tau_s", "s", 120.0, (1.0, 3600.0), "minutes (docs/diagnosis.md §2g)", role="nonlinear",
                  grid=(10.0, 30.0, 100.0, 300.0, 1000.0)),
    )

    def basis(self, inputs):
        """Bias per unit amplitude: exp(−t_on/τ) after each power-on.

        Parameters
        ----------
        inputs : EffectInputs
            Reads ``time_since_power_on_s`` [s].

        Returns
        -------
        dict of str to Contribution
            ``amplitude_mg``: bias [g] per mg.

        References
        ----------
        Exponential settling, docs/diagnosis.md §2g (a modelling choice, no further source).
        """
        return {"amplitude_mg": Contribution(bias_g=warmup_shape(inputs.time_since_power_on_s, self.values["tau_s"]) * 1e-3)}
