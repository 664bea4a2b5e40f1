"""Registry of the benchmark's compensators: ``@register_compensator(name, label)`` on a factory.

A factory takes ``(quick, seed)`` — the benchmark's short budget flag and the test's seed — and
returns ``(features, estimator)``: a :class:`fitting.FeatureSet` (its ΔT reference is set from the
training data by the benchmark) and an unfitted scikit-learn-style regressor (``fit(X, y)``
returns the estimator, ``predict(X)`` gives one value per row) that predicts the drift
``output − applied`` [g] from the features. The benchmark builds and trains every registered
compensator in registration order; the built-in ones are the paper's models
(:mod:`twin.compensation.paper_models`). A user's module registers more with :func:`load_plugin`
(``twin benchmark --plugin PATH``); loading a plugin runs its code.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

from twin.errors import TwinError
from twin.plugins import Registry


class CompensatorError(TwinError):
    """A compensator that cannot be found, registered or built."""


@dataclass(frozen=True)
class Compensator:
    """A registered compensator: its name (the benchmark's key), a label for people, its factory.

    Attributes
    ----------
    name : str
        The benchmark's key (an identifier).
    label : str
        For people (tables, report).
    factory : callable
        ``factory(quick, seed) -> (FeatureSet, estimator)`` (module docstring).
    """

    name: str
    label: str
    factory: Callable[[bool, int], tuple]

    def build(self, quick: bool, seed: int) -> tuple:
        """``(features, estimator)`` for one test, checked.

        Parameters
        ----------
        quick : bool
            The benchmark's short budget.
        seed : int
            The test's seed.

        Returns
        -------
        tuple
            A :class:`fitting.FeatureSet` and an unfitted estimator with ``fit`` and ``predict``
            (the drift ``output − applied`` [g]).

        Raises
        ------
        CompensatorError
            The factory returned something else.
        """
        from fitting import FeatureSet

        made = self.factory(quick, seed)
        if not (isinstance(made, tuple) and len(made) == 2 and isinstance(made[0], FeatureSet)):
            raise CompensatorError(f"compensator {self.name!r}: its factory must return (FeatureSet, estimator), "
                                   f"got {type(made).__name__}")
        if not all(callable(getattr(made[1], m, None)) for m in ("fit", "predict")):
            raise CompensatorError(f"compensator {self.name!r}: {type(made[1]).__name__} has no fit/predict")
        return made

    def describe(self) -> dict:
        """The compensator as plain data.

        Returns
        -------
        dict
            ``name``, ``label`` and the ``module`` of its factory.
        """
        return {"name": self.name, "label": self.label, "module": self.factory.__module__}


#: name → compensator, in registration order (the benchmark's order)
COMPENSATORS = Registry("compensator", CompensatorError)


def register_compensator(name: str, label: str):
    """Decorator: register ``factory(quick, seed) -> (FeatureSet, estimator)`` under ``name``.

    Parameters
    ----------
    name : str
        An identifier, the benchmark's key; not ``physics_twin`` or ``noise_floor`` (reserved).
    label : str
        For people (tables, report).

    Returns
    -------
    callable
        The decorator; it returns the factory unchanged.

    Raises
    ------
    CompensatorError
        A name that is not an identifier or is reserved; when applied, a name another function
        registered.
    """
    if not (isinstance(name, str) and name.isidentifier()):
        raise CompensatorError(f"a compensator name must be an identifier, got {name!r}")
    if name in ("physics_twin", "noise_floor"):
        raise CompensatorError(f"{name!r} is a reserved benchmark key")

    def decorate(factory):
        COMPENSATORS.add(name, Compensator(name, label, factory), factory)
        return factory

    return decorate


get_compensator = COMPENSATORS.lookup
load_plugin = COMPENSATORS.load_plugin


def _register_builtins() -> None:
    from twin.compensation.paper_models import BUILTIN

    for name, label, factory in BUILTIN:
        register_compensator(name, label)(factory)


_register_builtins()  # the paper's compensators first: the benchmark's order
