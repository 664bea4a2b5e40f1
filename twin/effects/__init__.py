"""Registry of drift effects.

Importing this package registers every module in it (one file per effect), the effects of
installed distributions that declare a ``tde_twin.effects`` entry point, and nothing else;
:func:`load_plugin` registers a user's module named in a scenario (``twin.plugins``).
Loading a plugin runs the user's code.
"""

from __future__ import annotations

import importlib
import importlib.util
import pkgutil
import sys
from importlib.metadata import entry_points
from pathlib import Path

from twin.effects.base import (
    REGISTRY,
    Composition,
    Contribution,
    Effect,
    EffectInputs,
    Parameter,
    did_you_mean,
    get_effect,
    register,
)
from twin.errors import ModelError

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
    """Import a plugin module (a ``.py`` path relative to ``base_dir``, or a module name) and
    return the names of the effects it registered. Runs the user's code."""
    before = set(REGISTRY)
    path = Path(spec)
    if spec.endswith(".py"):
        path = path if path.is_absolute() else Path(base_dir) / path
        if not path.is_file():
            raise ModelError(f"plugin file not found: {path}")
        mod_name = f"twin_plugin_{path.stem}_{abs(hash(str(path.resolve()))) % 10**8}"
        if mod_name not in sys.modules:
            module_spec = importlib.util.spec_from_file_location(mod_name, path)
            module = importlib.util.module_from_spec(module_spec)
            sys.modules[mod_name] = module
            try:
                module_spec.loader.exec_module(module)
            except ModelError:
                raise
            except Exception as exc:
                del sys.modules[mod_name]
                raise ModelError(f"plugin {path} failed to load: {type(exc).__name__}: {exc}") from None
    else:
        try:
            importlib.import_module(spec)
        except ImportError as exc:
            raise ModelError(f"plugin module {spec!r} cannot be imported: {exc}") from None
    return sorted(set(REGISTRY) - before)


__all__ = ["REGISTRY", "Composition", "Contribution", "Effect", "EffectInputs", "Parameter", "did_you_mean",
           "get_effect", "load_plugin", "register", "ENTRY_POINT_GROUP"]
