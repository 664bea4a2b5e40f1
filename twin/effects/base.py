"""The effect abstraction: parameters, inputs, contributions and the :class:`Effect` base class.

An effect is a named piece of drift physics with physical parameters (unit, default, bounds,
source). It reads named inputs (die temperature, time, applied acceleration …) and contributes
to the bias [g] and/or the relative scale factor [1]. The model sums contributions; every slot is
filled, "absent" being the explicit ``null`` effect (architecture principles 1–4). Effects are
registered and composed into one model in :mod:`twin.effects.registry`.

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
from twin.effects.records import EffectRecord, ParameterRecord
from twin.errors import ModelError
from twin.text import did_you_mean


@dataclass(frozen=True)
class Parameter:
    """A physical parameter: unit, default, bounds (the calibrator's box) and where it comes from.

    Attributes
    ----------
    name, unit, source : str
        Name, unit (e.g. ``"mg/degC"``) and where the default comes from.
    default : float
        Default value [unit].
    bounds : tuple of float
        (lower, upper): the calibrator's box [unit].
    role : str
        ``"amplitude"``, ``"nonlinear"`` or ``"fixed"``.
    free, screen : bool
        Calibrated by default; used when the effect is screened as a candidate.
    description : str
        Free text.
    grid : tuple of float
        Screening grid of a nonlinear parameter [unit].
    """

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

    Attributes
    ----------
    time_s, time_since_power_on_s : ndarray
        Sample times; time since the last power-on (or None) [s].
    die_c, thermometer_c : ndarray or None
        Die temperature; reference thermometer reading [°C].
    applied_g : ndarray or None
        Applied acceleration along the axis [g].
    run_index : ndarray or None
        Run number of each sample [1].
    """

    time_s: np.ndarray
    die_c: np.ndarray | None = None
    thermometer_c: np.ndarray | None = None
    applied_g: np.ndarray | None = None
    run_index: np.ndarray | None = None
    time_since_power_on_s: np.ndarray | None = None
    _dt_cache: float | None = field(default=None, init=False, repr=False, compare=False)

    def replace(self, **changes: np.ndarray) -> EffectInputs:
        """A copy with some inputs changed (the sample interval is carried over with the time base).

        Parameters
        ----------
        **changes : ndarray
            New values of inputs by name (:data:`INPUT_NAMES`) [each input's unit].

        Returns
        -------
        EffectInputs
            The copy; this one is unchanged.
        """
        new = EffectInputs(**{**{k: getattr(self, k) for k in INPUT_NAMES}, **changes})
        if "time_s" not in changes:
            new._dt_cache = self._dt_cache
        return new

    def require(self, effect: type[Effect] | Effect) -> None:
        """Raise :class:`ModelError` naming the effect and each input it ``reads`` that is missing.

        Parameters
        ----------
        effect : Effect or type of Effect
            The effect whose ``reads`` are checked.
        """
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
        """Contiguous runs: stateful effects restart from equilibrium at each run's start.

        Returns
        -------
        list of slice
            One slice of the samples per run, in order (one for all when ``run_index`` is None).
        """
        return run_slices(self.run_index)

    def per_run(self, fn, x: np.ndarray) -> np.ndarray:
        """Apply a causal filter ``fn(x_run)`` separately to each run.

        Parameters
        ----------
        fn : callable
            Filter taking one run's samples and returning as many [unit of ``x``].
        x : ndarray
            Samples on this time base [any unit].

        Returns
        -------
        ndarray
            ``fn`` applied run by run, as floats [unit of ``fn``'s output].
        """
        out = np.empty(np.shape(x), float)
        for s in self.run_slices():
            out[s] = fn(np.asarray(x)[s])
        return out


@dataclass
class Contribution:
    """Bias [g] and relative scale-factor change [1] of one effect.

    Attributes
    ----------
    bias_g : ndarray or float
        Bias [g].
    scale_factor : ndarray or float
        Relative scale-factor change [1].
    """

    bias_g: np.ndarray | float = 0.0
    scale_factor: np.ndarray | float = 0.0

    def output_g(self, applied_g: np.ndarray) -> np.ndarray:
        """Drift in the output: bias + scale-factor change × applied acceleration.

        Parameters
        ----------
        applied_g : ndarray
            Applied acceleration [g].

        Returns
        -------
        ndarray
            Output drift [g].
        """
        return np.asarray(self.bias_g) + np.asarray(self.scale_factor) * np.asarray(applied_g)

    def __add__(self, other: Contribution) -> Contribution:
        return Contribution(np.asarray(self.bias_g) + other.bias_g, np.asarray(self.scale_factor) + other.scale_factor)

    def __mul__(self, k: float) -> Contribution:
        return Contribution(np.asarray(self.bias_g) * k, np.asarray(self.scale_factor) * k)

    __rmul__ = __mul__


class Effect:
    """Base class. Subclasses set ``name``, ``family``, ``parameters``, ``reads`` and implement
    :meth:`basis` (or, for the temperature slot, :meth:`die_temperature`).

    Parameters
    ----------
    context : dict, optional
        Scenario context (e.g. ``geometry``, ``fit_all``).
    **values : float
        Parameter values by name [each parameter's unit]; the others take their defaults.
    """

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
        """Names of the amplitude parameters, in declaration order.

        Returns
        -------
        list of str
            Parameter names.
        """
        return [p.name for p in cls.parameters if p.role == "amplitude"]

    @classmethod
    def nonlinear_names(cls) -> list[str]:
        """Names of the nonlinear parameters, in declaration order.

        Returns
        -------
        list of str
            Parameter names.
        """
        return [p.name for p in cls.parameters if p.role == "nonlinear"]

    @classmethod
    def grid(cls) -> list[dict[str, float]]:
        """Screening grid over the nonlinear parameters (their product); ``[{}]`` if none.

        Returns
        -------
        list of dict of str to float
            One mapping of nonlinear parameter name to value [its unit] per grid point.
        """
        combos: list[dict[str, float]] = [{}]
        for p in cls.parameters:
            if p.role == "nonlinear":
                values = p.grid or (p.default,)
                combos = [{**c, p.name: v} for c in combos for v in values]
        return combos

    def with_values(self, **values: float) -> Effect:
        """A copy with some parameters changed (same context).

        Parameters
        ----------
        **values : float
            New parameter values by name [each parameter's unit]; the others are kept.

        Returns
        -------
        Effect
            The copy, checked against the bounds as at construction.
        """
        return type(self)(self.context, **{**self.values, **values})

    # -- physics
    def basis(self, inputs: EffectInputs) -> dict[str, Contribution]:
        """Contribution per unit of each amplitude, at the current nonlinear parameters.

        Parameters
        ----------
        inputs : EffectInputs
            The inputs the effect reads.

        Returns
        -------
        dict of str to Contribution
            Bias [g] and scale factor [1] per unit of each amplitude parameter.
        """
        return {}

    def contribution(self, inputs: EffectInputs) -> Contribution:
        """The effect's bias and scale-factor change: Σ amplitude × basis.

        Parameters
        ----------
        inputs : EffectInputs
            The inputs the effect reads.

        Returns
        -------
        Contribution
            Bias [g] and relative scale-factor change [1].
        """
        inputs.require(self)
        total = Contribution()
        for name, unit_contribution in self.basis(inputs).items():
            total = total + self.values[name] * unit_contribution
        return total

    def die_temperature(self, inputs: EffectInputs) -> np.ndarray:  # pragma: no cover - temperature slot only
        """Die temperature [°C] from the inputs (temperature-slot effects implement it).

        Parameters
        ----------
        inputs : EffectInputs
            The inputs the effect reads (the measured temperature among them).

        Returns
        -------
        ndarray
            Die temperature per sample [°C].
        """
        raise NotImplementedError

    def thermometer_shift_c(self) -> float:
        """For ``acts_on_thermometer`` effects: what the reading gains in a simulated device [°C].

        Returns
        -------
        float
            Shift of the thermometer reading [°C]; 0 for every other effect.
        """
        return 0.0

    @classmethod
    def describe(cls) -> EffectRecord:
        """Registry entry as a typed record (for ``twin effects`` and the docs).

        Returns
        -------
        EffectRecord
            Name, family, slot, description, inputs read, identifiability, module, and each
            parameter's name, unit, default, bounds [its unit], role, freedom and source.
        """
        return EffectRecord(
            name=cls.name,
            family=cls.family,
            slot=cls.slot,
            description=cls.description,
            reads=list(cls.reads),
            identifiable=cls.identifiable,
            module=cls.__module__,
            parameters=[
                ParameterRecord(name=p.name, unit=p.unit, default=p.default, bounds=list(p.bounds), role=p.role,
                                free=p.free, source=p.source, grid=list(p.grid) if p.grid else None)
                for p in cls.parameters
            ],
        )
