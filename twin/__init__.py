"""tde-twin: digital twin of the temperature drift error of MEMS accelerometers.

Kept light on purpose: ``import twin`` loads neither torch, pyvista nor matplotlib.
"""

from importlib.metadata import PackageNotFoundError, version

try:
    __version__ = version("tde-twin")
except PackageNotFoundError:  # pragma: no cover - running from a source tree without install
    __version__ = "0.0.0+unknown"

__all__ = ["__version__"]
