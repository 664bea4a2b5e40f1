"""Import a user's module by path or name: the one mechanism behind every registry's plugins
(effects, measurement readers, compensators, DOE responses). Loading a plugin runs its code."""

from __future__ import annotations

import importlib
import importlib.util
import sys
from pathlib import Path
from types import ModuleType

from twin.errors import TwinError


class PluginError(TwinError):
    """A plugin could not be found or failed while loading."""


def import_plugin(spec: str, base_dir: str | Path = ".", error: type[TwinError] = PluginError) -> ModuleType:
    """Import ``spec``: a ``.py`` path (relative to ``base_dir``) or a module name.

    A file is imported once per resolved path; a failure while it loads is reported as ``error``
    with the exception's type and message, in one line, and leaves nothing in ``sys.modules``.

    Parameters
    ----------
    spec : str
        A ``.py`` path or a module name.
    base_dir : str or Path
        Directory a relative path is resolved against.
    error : type of TwinError
        The exception raised on failure.

    Returns
    -------
    ModuleType
        The imported module.
    """
    path = Path(spec) if Path(spec).is_absolute() else Path(base_dir) / spec
    if not spec.endswith(".py") and ("/" in spec or path.exists()):  # a path, but not to a .py file
        what = "a folder" if path.is_dir() else "not a .py file" if path.exists() else "not found"
        raise error(f"plugin {spec}: {what}; expected a .py file or a module name")
    if not spec.endswith(".py"):
        try:
            return importlib.import_module(spec)
        except ImportError as exc:
            raise error(f"plugin module {spec!r} cannot be imported: {exc}") from None
        except TwinError:
            raise
        except (Exception, SystemExit) as exc:  # its own failure while loading, named in one line
            raise error(f"plugin module {spec!r} failed to load: {type(exc).__name__}: {exc}") from None
    if not path.is_file():
        raise error(f"plugin {path}: is a folder; expected a .py file" if path.is_dir() else f"plugin file not found: {path}")
    mod_name = f"twin_plugin_{path.stem}_{abs(hash(str(path.resolve()))) % 10**8}"
    if mod_name in sys.modules:
        return sys.modules[mod_name]
    module_spec = importlib.util.spec_from_file_location(mod_name, path)
    module = importlib.util.module_from_spec(module_spec)
    sys.modules[mod_name] = module
    try:
        module_spec.loader.exec_module(module)
    except TwinError:
        del sys.modules[mod_name]
        raise
    except (Exception, SystemExit) as exc:  # a plugin's own failure, named in one line
        del sys.modules[mod_name]
        raise error(f"plugin {path} failed to load: {type(exc).__name__}: {' '.join(str(exc).split())[:200]}") from None
    return module


class Registry(dict):
    """Name → entry, in registration order, for one kind of extension (compensator, response …).

    Registering a name twice is allowed only from the same function (a module imported again);
    an unknown name gets "did you mean"; :meth:`load_plugin` imports a user's module and returns
    what it registered.

    Parameters
    ----------
    kind : str
        What an entry is, for messages (e.g. ``"compensator"``).
    error : type of TwinError
        The exception raised.
    """

    def __init__(self, kind: str, error: type[TwinError]):
        super().__init__()
        self.kind, self.error = kind, error
        self._origins: dict[str, tuple[str, str]] = {}

    def add(self, name: str, entry, origin) -> None:
        """Register ``entry`` under ``name``; ``origin`` is the function that defines it.

        Parameters
        ----------
        name : str
            Registered name.
        entry : object
            What is registered.
        origin : callable
            The function (or class) defining it.
        """
        where = (origin.__module__, origin.__qualname__)
        if name in self and self._origins[name] != where:
            raise self.error(f"a {self.kind} named {name!r} is already registered (by {self._origins[name][0]})")
        self[name] = entry
        self._origins[name] = where

    def lookup(self, name: str):
        """The entry ``name``; unknown names get "did you mean".

        Parameters
        ----------
        name : str
            Registered name.

        Returns
        -------
        object
            The entry.
        """
        from twin.text import did_you_mean

        try:
            return self[name]
        except KeyError:
            raise self.error(f"unknown {self.kind} {name!r}{did_you_mean(name, self)}") from None

    def load_plugin(self, spec: str, base_dir: str | Path = ".") -> list[str]:
        """Import a module (a ``.py`` path relative to ``base_dir``, or a module name); the names it
        registered. Runs the user's code.

        Parameters
        ----------
        spec : str
            A ``.py`` path or a module name.
        base_dir : str or Path
            Directory a relative path is resolved against.

        Returns
        -------
        list of str
            Names registered by the module, in registration order.
        """
        before = set(self)
        import_plugin(spec, base_dir, error=self.error)
        return [n for n in self if n not in before]

    def pop(self, name, *default):
        """Remove ``name`` (and its origin) as :meth:`dict.pop` does.

        Parameters
        ----------
        name : str
            Registered name.
        *default : object
            Returned when ``name`` is absent (else KeyError).

        Returns
        -------
        object
            The entry removed, or the default.
        """
        self._origins.pop(name, None)
        return super().pop(name, *default)
