"""Registry of drift effects.

Importing this package registers every module in it (one file per effect), the effects of
installed distributions that declare a ``tde_twin.effects`` entry point, and nothing else;
:func:`load_plugin` registers a user's module named in a scenario (``twin.plugins``).
Loading a plugin runs the user's code.
"""

from __future__ import annotations

import importlib
import pkgutil
import sys
from importlib.metadata import entry_points
from pathlib import Path

from twin.effects.base import Contribution, Effect, EffectInputs, Parameter
from twin.effects.registry import REGISTRY, Composition, get_effect, register
from twin.errors import ModelError
from twin.plugins import import_plugin
from twin.text import did_you_mean

ENTRY_POINT_GROUP = "tde_twin.effects"

for _info in pkgutil.iter_modules(__path__):
    if _info.name != "base":
        importlib.import_module(f"{__name__}.{_info.name}")


def _load_entry_points() -> None:
    for ep in entry_points(group=ENTRY_POINT_GROUP):
        try:
            ep.load()
        except Exception as exc:  # a broken third-party plugin must not break the tool
            print(f"twin: warning: effect entry point {ep.name!r} failed to load: {exc}", file=sys.stderr)


_load_entry_points()


def load_plugin(spec: str, base_dir: str | Path = ".") -> list[str]:
    """Import a plugin module and return the names of the effects it registered (runs the user's code).

    Parameters
    ----------
    spec : str
        A ``.py`` path relative to ``base_dir``, or a module name.
    base_dir : str or Path
        Directory a relative path is resolved against (the scenario's).

    Returns
    -------
    list of str
        Names of the newly registered effects, sorted.
    """
    before = set(REGISTRY)
    import_plugin(spec, base_dir, error=ModelError)
    return sorted(set(REGISTRY) - before)


__all__ = ["REGISTRY", "Composition", "Contribution", "Effect", "EffectInputs", "Parameter", "did_you_mean",
           "get_effect", "load_plugin", "register", "ENTRY_POINT_GROUP"]
