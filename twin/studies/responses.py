"""Registry of DOE responses: ``@register_response(name, description=..., unit=...)`` on a function.

A response is a function of one run's :class:`RunContext` returning a number (stored as a float)
or a string. The context computes the simulated dataset, the blind measurement, the diagnosis
and the rest on first use and shares them between the responses of the run, so a response pays
only for what it reads. The built-in responses are in :mod:`twin.studies.standard_responses`; a
study's ``plugins:`` key (or :func:`load_plugin`) registers more. Loading a plugin runs its code.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from functools import cached_property

import numpy as np

from twin.errors import TwinError
from twin.plugins import Registry


class ResponseError(TwinError):
    """A response that cannot be found, registered or evaluated."""


class RunContext:
    """What a response may read about one run; each item is computed on first use, once.

    ``loaded`` (the resolved :class:`~twin.model.scenario.LoadedScenario`), ``scenario``,
    ``program``, ``job`` (index, replicate, point, seed), ``dataset`` (the simulated dataset, truth
    included), ``measurement`` (its logged columns only: what a lab would have), ``diagnosis``
    (``twin compare``'s result on the blind measurement), ``noise_g`` (the sensor noise, which no
    compensator removes), ``hidden_family`` (the family of the effect the twin lacks, or None),
    ``test_mask`` (the last cycle of every run: the split ``twin benchmark`` uses).

    Parameters
    ----------
    loaded : LoadedScenario
        The run's resolved scenario.
    job : dict, optional
        The run's job (:func:`twin.studies.design.resolve`); empty when not given.
    """

    def __init__(self, loaded, job: dict | None = None):
        self.loaded = loaded
        self.job = job or {}

    @property
    def scenario(self):
        """The run's validated scenario (a ``Scenario``)."""
        return self.loaded.scenario

    @property
    def program(self):
        """The run's compiled chamber program (set-point [°C] over time [s])."""
        return self.loaded.program

    @cached_property
    def dataset(self):
        """The simulated dataset, truth included (columns in their stated units: s, °C, g)."""
        from twin.model.simulate import simulate

        return simulate(self.loaded)

    @cached_property
    def measurement(self):
        """The blind measurement: the dataset's logged columns only (time [s], temperature [°C], output [g])."""
        from twin.measurement import from_dataset

        return from_dataset(self.dataset)  # blind: the logged columns only

    @cached_property
    def diagnosis(self):
        """The blind compare of the twin with this run's measurement (a ``CompareResult``)."""
        from twin.finding.build import compare_measurement

        return compare_measurement(self.loaded, self.measurement, [])[1]

    @cached_property
    def noise_g(self) -> np.ndarray:
        """The sensor noise per sample: white, bias instability and quantisation [g]."""
        ds = self.dataset
        return ds["truth/noise_white_g"] + ds["truth/noise_bias_instability_g"] + ds["truth/quantisation_g"]

    @cached_property
    def hidden_family(self) -> str | None:
        """The first of ``device.effects`` missing from ``twin.effects``, or the thermal lag when
        the thermometer is off the die and the twin has no ``thermal_lag``."""
        from twin.effects import REGISTRY

        scn = self.scenario
        hidden = [n for n in scn.device.effects if n not in scn.twin.effects]
        if hidden:
            return REGISTRY[hidden[0]].family
        th = scn.chamber.thermometer
        if (th.attached_to != "die" or th.tau_s > 0) and "thermal_lag" not in scn.twin.effects:
            return "thermal_lag"
        return None

    @cached_property
    def test_mask(self) -> np.ndarray:
        """Boolean mask of the test samples: the last cycle of every run [1]."""
        from twin.compensation.splits import last_cycle_test

        ds = self.dataset
        return last_cycle_test(self.program, ds["time_s"], ds["test/run_index"])


@dataclass(frozen=True)
class Response:
    """A registered response: name, what it measures, its unit, and its function.

    Attributes
    ----------
    name : str
        The response's name (an identifier; the table's column).
    description : str
        What it measures.
    unit : str
        The unit of its value (empty: dimensionless or a string).
    function : callable
        ``function(run: RunContext) -> float | str``.
    """

    name: str
    description: str
    unit: str
    function: Callable[[RunContext], float | str]

    def evaluate(self, run: RunContext) -> float | str:
        """The response of one run: a float, or a string as returned.

        Parameters
        ----------
        run : RunContext

        Returns
        -------
        float or str
            In :attr:`unit`.

        Raises
        ------
        ResponseError
            The function returned something else than a number or a string.
        """
        value = self.function(run)
        if isinstance(value, str):
            return value
        if isinstance(value, (bool, int, float, np.integer, np.floating)) or \
                (isinstance(value, np.ndarray) and value.shape == ()):
            return float(value)
        raise ResponseError(f"response {self.name!r} returned {type(value).__name__}; a response returns a number "
                            f"or a string")

    def describe(self) -> dict:
        """The response as plain data.

        Returns
        -------
        dict
            ``name``, ``description``, ``unit`` and the ``module`` of its function.
        """
        return {"name": self.name, "description": self.description, "unit": self.unit,
                "module": self.function.__module__}


#: name → response, in registration order
RESPONSES = Registry("response", ResponseError)


def register_response(name: str, *, description: str, unit: str = ""):
    """Decorator: register ``function(run: RunContext) -> float | str`` as the response ``name``.

    Parameters
    ----------
    name : str
        An identifier: the response's name in a study's ``responses``.
    description : str
        What it measures (not empty).
    unit : str
        The unit of its value (empty: dimensionless).

    Returns
    -------
    callable
        The decorator; it returns the function unchanged.

    Raises
    ------
    ResponseError
        A name that is not an identifier, or an empty description; when applied, a name another
        function registered.
    """
    if not (isinstance(name, str) and name.isidentifier()):
        raise ResponseError(f"a response name must be an identifier, got {name!r}")
    if not (isinstance(description, str) and description.strip()):
        raise ResponseError(f"response {name!r} needs a description")

    def decorate(function):
        RESPONSES.add(name, Response(name, description, unit, function), function)
        return function

    return decorate


get_response = RESPONSES.lookup
load_plugin = RESPONSES.load_plugin


def _register_builtins() -> None:
    from twin.studies.standard_responses import BUILTIN

    for name, description, unit, function in BUILTIN:
        register_response(name, description=description, unit=unit)(function)


_register_builtins()
