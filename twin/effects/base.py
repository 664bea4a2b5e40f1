"""Effect abstraction and registry.

An effect is a named piece of drift physics with physical parameters (unit, default, bounds,
source). It reads named inputs (die temperature, time, applied acceleration …) and contributes
to the bias [g] and/or the relative scale factor [1]. The model sums contributions; every slot is
filled, "absent" being the explicit ``null`` effect (architecture principles 1–4).

Parameters have a role:

* ``amplitude`` — enters linearly. :meth:`Effect.basis` returns the contribution per unit of
  each amplitude at the current nonlinear parameters, so the diagnosis can screen an effect with
  linear tests, and the contribution is the amplitude-weighted sum of the basis;
* ``nonlinear`` — a time constant or width, searched on :meth:`Effect.grid` and then refined;
* ``fixed`` — a convention such as the reference temperature.

``free=False`` marks a parameter the calibrator leaves alone by default (the microstructure
effects take theirs from geometry and material).

An effect with ``slot = "temperature"`` (``thermal_lag``) does not add drift: in the twin it maps
the measured temperature to the die temperature the other effects read.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, ClassVar

import numpy as np

from twin.arrays import run_slices
from twin.errors import ModelError, TwinError
from twin.text import did_you_mean


@dataclass(frozen=True)
class Parameter:
    """A physical parameter: unit, default, bounds (the calibrator's box) and where it comes from."""

    name: str
    unit: str
    default: float
    bounds: tuple[float, float]
    source: str
    role: str = "amplitude"  # "amplitude" | "nonlinear" | "fixed"
    free: bool = True
    description: str = ""
    grid: tuple[float, ...] = ()  # screening grid of a nonlinear parameter
    screen: bool = True  # amplitude used when the effect is screened as a candidate


INPUT_NAMES = ("time_s", "die_c", "thermometer_c", "applied_g", "run_index", "time_since_power_on_s")


@dataclass(kw_only=True)
class EffectInputs:
    """Named, unit-bearing inputs an effect may read (all arrays on one time base).

    ``die_c`` is the true die temperature when simulating a device, and the twin's estimate of
    it (the measured temperature through the temperature slot) when modelling a measurement.
    An input a measurement lacks is ``None``; :meth:`require` names it for the effect that reads it.
    """

    time_s: np.ndarray
    die_c: np.ndarray | None = None
    thermometer_c: np.ndarray | None = None
    applied_g: np.ndarray | None = None
    run_index: np.ndarray | None = None
    time_since_power_on_s: np.ndarray | None = None
    _dt_cache: float | None = field(default=None, init=False, repr=False, compare=False)

    def replace(self, **changes: np.ndarray) -> EffectInputs:
        """A copy with some inputs changed (the sample interval is carried over with the time base)."""
        new = EffectInputs(**{**{k: getattr(self, k) for k in INPUT_NAMES}, **changes})
        if "time_s" not in changes:
            new._dt_cache = self._dt_cache
        return new

    def require(self, effect: type[Effect] | Effect) -> None:
        """Raise :class:`ModelError` naming the effect and each input it ``reads`` that is missing."""
        unknown = [r for r in effect.reads if r not in INPUT_NAMES]
        if unknown:
            raise ModelError(f"effect {effect.name!r} reads {', '.join(unknown)}, which is not an input; "
                             f"inputs are {', '.join(INPUT_NAMES)}")
        missing = [r for r in effect.reads if getattr(self, r) is None]
        if missing:
            raise ModelError(f"effect {effect.name!r} reads {', '.join(missing)}, which this measurement does not "
                             "provide")

    @property
    def dt_s(self) -> float:
        """Sample interval [s] (the median step: runs are uniformly sampled); computed once, a
        median of N differences costs ~0.1 s at 8.6 M samples and every stateful effect asks."""
        if self._dt_cache is None:
            self._dt_cache = float(np.median(np.diff(self.time_s))) if self.time_s.size > 1 else 1.0
        return self._dt_cache

    def run_slices(self) -> list[slice]:
        """Contiguous runs: stateful effects restart from equilibrium at each run's start."""
        return run_slices(self.run_index)

    def per_run(self, fn, x: np.ndarray) -> np.ndarray:
        """Apply a causal filter ``fn(x_run)`` separately to each run."""
        out = np.empty(np.shape(x), float)
        for s in self.run_slices():
            out[s] = fn(np.asarray(x)[s])
        return out


@dataclass
class Contribution:
    """Bias [g] and relative scale-factor change [1] of one effect."""

    bias_g: np.ndarray | float = 0.0
    scale_factor: np.ndarray | float = 0.0

    def output_g(self, applied_g: np.ndarray) -> np.ndarray:
        """Drift in the output [g]: bias + scale-factor change × applied acceleration."""
        return np.asarray(self.bias_g) + np.asarray(self.scale_factor) * np.asarray(applied_g)

    def __add__(self, other: Contribution) -> Contribution:
        return Contribution(np.asarray(self.bias_g) + other.bias_g, np.asarray(self.scale_factor) + other.scale_factor)

    def __mul__(self, k: float) -> Contribution:
        return Contribution(np.asarray(self.bias_g) * k, np.asarray(self.scale_factor) * k)

    __rmul__ = __mul__


class Effect:
    """Base class. Subclasses set ``name``, ``family``, ``parameters``, ``reads`` and implement
    :meth:`basis` (or, for the temperature slot, :meth:`die_temperature`)."""

    name: ClassVar[str]
    family: ClassVar[str]
    parameters: ClassVar[tuple[Parameter, ...]] = ()
    reads: ClassVar[tuple[str, ...]] = ()
    description: ClassVar[str] = ""
    slot: ClassVar[str] = "drift"  # "drift" | "temperature"
    identifiable: ClassVar[bool] = True  # False: structurally unidentifiable from residuals
    acts_on_thermometer: ClassVar[bool] = False  # in a simulated device: shifts the reading, not the output
    screened: ClassVar[bool] = True  # False: a forward model added by name (--with-effect), not screened blind

    def __init__(self, context: dict[str, Any] | None = None, **values: float) -> None:
        known = {p.name: p for p in self.parameters}
        for key in values:
            if key not in known:
                raise ModelError(f"effect {self.name!r} has no parameter {key!r}{did_you_mean(key, known)}")
        self.context = dict(context or {})
        self.values: dict[str, float] = {}
        for p in self.parameters:
            try:
                v = float(values.get(p.name, p.default))
            except (TypeError, ValueError):
                raise ModelError(f"effect {self.name!r}: {p.name} must be a number, got {values[p.name]!r}") from None
            lo, hi = p.bounds
            if not lo <= v <= hi:
                raise ModelError(f"effect {self.name!r}: {p.name} = {v:g} {p.unit} is outside its bounds [{lo:g}, {hi:g}]")
            self.values[p.name] = v

    # -- parameters by role
    @classmethod
    def amplitude_names(cls) -> list[str]:
        return [p.name for p in cls.parameters if p.role == "amplitude"]

    @classmethod
    def nonlinear_names(cls) -> list[str]:
        return [p.name for p in cls.parameters if p.role == "nonlinear"]

    @classmethod
    def grid(cls) -> list[dict[str, float]]:
        """Screening grid over the nonlinear parameters (their product); ``[{}]`` if none."""
        combos: list[dict[str, float]] = [{}]
        for p in cls.parameters:
            if p.role == "nonlinear":
                values = p.grid or (p.default,)
                combos = [{**c, p.name: v} for c in combos for v in values]
        return combos

    def with_values(self, **values: float) -> Effect:
        """A copy with some parameters changed (same context)."""
        return type(self)(self.context, **{**self.values, **values})

    # -- physics
    def basis(self, inputs: EffectInputs) -> dict[str, Contribution]:
        """Contribution per unit of each amplitude, at the current nonlinear parameters."""
        return {}

    def contribution(self, inputs: EffectInputs) -> Contribution:
        """The effect's bias and scale-factor change: Σ amplitude × basis."""
        inputs.require(self)
        total = Contribution()
        for name, unit_contribution in self.basis(inputs).items():
            total = total + self.values[name] * unit_contribution
        return total

    def die_temperature(self, inputs: EffectInputs) -> np.ndarray:  # pragma: no cover - temperature slot only
        raise NotImplementedError

    def thermometer_shift_c(self) -> float:
        """For ``acts_on_thermometer`` effects: what the reading gains in a simulated device [°C]."""
        return 0.0

    @classmethod
    def describe(cls) -> dict:
        """Registry entry as plain data (for ``twin effects`` and the docs)."""
        return {
            "name": cls.name,
            "family": cls.family,
            "slot": cls.slot,
            "description": cls.description,
            "reads": list(cls.reads),
            "identifiable": cls.identifiable,
            "module": cls.__module__,
            "parameters": [
                {"name": p.name, "unit": p.unit, "default": p.default, "bounds": list(p.bounds), "role": p.role,
                 "free": p.free, "source": p.source, **({"grid": list(p.grid)} if p.grid else {})}
                for p in cls.parameters
            ],
        }


REGISTRY: dict[str, type[Effect]] = {}


def register(cls: type[Effect]) -> type[Effect]:
    """Class decorator: add an effect to the registry under its ``name``."""
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
    """The registered effect class called ``name``; unknown names get "did you mean"."""
    try:
        return REGISTRY[name]
    except KeyError:
        raise ModelError(f"unknown effect {name!r}{did_you_mean(name, REGISTRY)}") from None


@dataclass
class Composition:
    """Effects composed into one model: a temperature slot (``null`` = die is the measured
    temperature) and drift effects summed; contributions kept per effect as ground truth."""

    effects: list[Effect] = field(default_factory=list)

    @property
    def temperature_effect(self) -> Effect | None:
        slots = [e for e in self.effects if e.slot == "temperature"]
        if len(slots) > 1:
            raise ModelError(f"only one temperature-slot effect allowed, got {[e.name for e in slots]}")
        return slots[0] if slots else None

    @property
    def drift_effects(self) -> list[Effect]:
        return [e for e in self.effects if e.slot == "drift"]

    def with_die_temperature(self, inputs: EffectInputs) -> EffectInputs:
        """Inputs with ``die_c`` from the temperature slot (unchanged when it is empty)."""
        slot = self.temperature_effect
        if slot is None:
            return inputs
        inputs.require(slot)
        return inputs.replace(die_c=slot.die_temperature(inputs))

    def evaluate(self, inputs: EffectInputs, device: bool = False) -> dict[str, Contribution]:
        """Per-effect contributions (drift effects only) after the temperature slot.

        ``device=True``: simulating a device, where effects acting on the thermometer change the
        reading (:meth:`thermometer_shift_c`) and contribute nothing to the output.
        """
        inputs = self.with_die_temperature(inputs)
        return {e.name: (Contribution() if device and e.acts_on_thermometer else e.contribution(inputs))
                for e in self.drift_effects}

    def thermometer_shift_c(self) -> float:
        return sum(e.thermometer_shift_c() for e in self.effects if e.acts_on_thermometer)

    def added(self, names: list[str], context: dict[str, Any]) -> Composition:
        """This model with the named effects added whole: every amplitude calibrated, those fixed
        by default too (an effect a user or the diagnosis adds is fitted as a whole)."""
        present = [e.name for e in self.effects]
        new = [get_effect(n)({**context, "fit_all": True}) for n in dict.fromkeys(names) if n not in present]
        return Composition(self.effects + new)
