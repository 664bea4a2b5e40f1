"""The effect registry and the composition of registered effects into one model.

:func:`register` adds an :class:`~twin.effects.base.Effect` subclass under its ``name`` (a
plugin's ``basis`` is wrapped so that a failure or a malformed output names the effect);
:func:`get_effect` finds it again. :class:`Composition` holds the effects of one model: a
temperature slot and the drift effects whose contributions are summed.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from twin.effects.base import Contribution, Effect, EffectInputs
from twin.errors import ModelError, TwinError
from twin.text import did_you_mean

REGISTRY: dict[str, type[Effect]] = {}


def register(cls: type[Effect]) -> type[Effect]:
    """Class decorator: add an effect to the registry under its ``name``.

    Parameters
    ----------
    cls : type of Effect
        The effect class.

    Returns
    -------
    type of Effect
        ``cls`` itself (a plugin's ``basis`` wrapped with output checks).
    """
    for attr in ("name", "family"):
        if not isinstance(getattr(cls, attr, None), str) or not getattr(cls, attr).strip():
            raise ModelError(f"effect class {cls.__name__} needs a non-empty string {attr!r}")
    existing = REGISTRY.get(cls.name)
    if existing is not None and (existing.__module__, existing.__qualname__) != (cls.__module__, cls.__qualname__):
        raise ModelError(f"an effect named {cls.name!r} is already registered (by {existing.__module__})")
    if cls.__module__.split(".")[0] != "twin":
        _check_basis_of(cls)
    REGISTRY[cls.name] = cls
    return cls


BASIS_LIMIT = 1e6  # |bias [g]| or |scale factor| per unit amplitude: far beyond any real effect


def _check_basis_of(cls: type[Effect]) -> None:
    """Wrap a plugin's :meth:`Effect.basis`: whoever calls it (simulation, screening, fitting) gets
    one line naming the effect when it raises or returns anything but finite per-sample values."""
    raw = cls.__dict__.get("basis")
    if raw is None or getattr(raw, "checked_basis", False):
        return

    def basis(self, inputs):
        try:
            out = raw(self, inputs)
        except TwinError:
            raise
        except (Exception, SystemExit) as exc:  # noqa: BLE001 - user code: named, never a traceback
            raise ModelError(f"effect {self.name!r} ({type(self).__module__}): basis failed: {type(exc).__name__}: "
                             f"{' '.join(str(exc).split())[:200]}") from None
        amplitudes, n = set(self.amplitude_names()), np.shape(inputs.time_s)
        if not (isinstance(out, dict) and set(out) <= amplitudes
                and all(isinstance(c, Contribution) for c in out.values())):
            raise ModelError(f"effect {self.name!r}: basis returned {type(out).__name__}; expected a mapping of its "
                             f"amplitude parameters ({', '.join(sorted(amplitudes)) or 'none'}) to Contribution")
        for key, c in out.items():
            for part in ("bias_g", "scale_factor"):
                a = np.asarray(getattr(c, part))
                if a.dtype.kind not in "biuf" or a.shape not in ((), n) or not np.all(np.abs(a) <= BASIS_LIMIT):
                    raise ModelError(f"effect {self.name!r}: basis {key}.{part}: got {a.dtype} of shape {a.shape}, "
                                     f"expected {n[0] if n else 1} finite numbers within ±{BASIS_LIMIT:g}")
        return out

    basis.checked_basis = True
    basis.__doc__ = raw.__doc__
    cls.basis = basis


def get_effect(name: str) -> type[Effect]:
    """The registered effect class called ``name``; unknown names get "did you mean".

    Parameters
    ----------
    name : str
        Registered effect name.

    Returns
    -------
    type of Effect
        The effect class.
    """
    try:
        return REGISTRY[name]
    except KeyError:
        raise ModelError(f"unknown effect {name!r}{did_you_mean(name, REGISTRY)}") from None


@dataclass
class Composition:
    """Effects composed into one model: a temperature slot (``null`` = die is the measured
    temperature) and drift effects summed; contributions kept per effect as ground truth.

    Attributes
    ----------
    effects : list of Effect
        The composed effects (at most one in the temperature slot).
    """

    effects: list[Effect] = field(default_factory=list)

    @property
    def temperature_effect(self) -> Effect | None:
        """The temperature-slot effect, or ``None`` (die = measured temperature)."""
        slots = [e for e in self.effects if e.slot == "temperature"]
        if len(slots) > 1:
            raise ModelError(f"only one temperature-slot effect allowed, got {[e.name for e in slots]}")
        return slots[0] if slots else None

    @property
    def drift_effects(self) -> list[Effect]:
        """The drift-slot effects (their contributions [g] and [1] are summed)."""
        return [e for e in self.effects if e.slot == "drift"]

    def with_die_temperature(self, inputs: EffectInputs) -> EffectInputs:
        """Inputs with ``die_c`` from the temperature slot (unchanged when it is empty).

        Parameters
        ----------
        inputs : EffectInputs
            The inputs, ``die_c`` being the measured temperature [°C] or absent.

        Returns
        -------
        EffectInputs
            The inputs with ``die_c`` [°C] from the temperature-slot effect.
        """
        slot = self.temperature_effect
        if slot is None:
            return inputs
        inputs.require(slot)
        return inputs.replace(die_c=slot.die_temperature(inputs))

    def evaluate(self, inputs: EffectInputs, device: bool = False) -> dict[str, Contribution]:
        """Per-effect contributions (drift effects only) after the temperature slot.

        Parameters
        ----------
        inputs : EffectInputs
            The inputs the effects read.
        device : bool
            True when simulating a device, where effects acting on the thermometer change the
            reading (:meth:`thermometer_shift_c`) and contribute nothing to the output.

        Returns
        -------
        dict of str to Contribution
            Bias [g] and relative scale-factor change [1] of each drift effect, by name.
        """
        inputs = self.with_die_temperature(inputs)
        return {e.name: (Contribution() if device and e.acts_on_thermometer else e.contribution(inputs))
                for e in self.drift_effects}

    def thermometer_shift_c(self) -> float:
        """What the thermometer reading gains in a simulated device, summed over the effects [°C].

        Returns
        -------
        float
            Shift of the thermometer reading [°C].
        """
        return sum(e.thermometer_shift_c() for e in self.effects if e.acts_on_thermometer)

    def added(self, names: list[str], context: dict[str, Any]) -> Composition:
        """This model with the named effects added whole: every amplitude calibrated, those fixed
        by default too (an effect a user or the diagnosis adds is fitted as a whole).

        Parameters
        ----------
        names : list of str
            Registered effect names; those already in the model are skipped.
        context : dict
            Scenario context the new effects are built with (``fit_all`` is set).

        Returns
        -------
        Composition
            A new composition; this one is unchanged.
        """
        present = [e.name for e in self.effects]
        new = [get_effect(n)({**context, "fit_all": True}) for n in dict.fromkeys(names) if n not in present]
        return Composition(self.effects + new)
