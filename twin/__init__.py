"""tde-twin: digital twin of the temperature drift error of MEMS accelerometers.

Kept light on purpose: ``import twin`` loads neither torch, pyvista nor matplotlib, nor
``importlib.metadata`` (≈ 40 ms) until ``twin.__version__`` is read.
"""

__all__ = ["__version__"]


def __getattr__(name: str) -> str:
    """``__version__``, read from the installed package's metadata the first time it is asked for."""
    if name != "__version__":
        raise AttributeError(f"module 'twin' has no attribute {name!r}")
    from importlib.metadata import PackageNotFoundError, version

    try:
        value = version("tde-twin")
    except PackageNotFoundError:  # pragma: no cover - running from a source tree without install
        value = "0.0.0+unknown"
    globals()["__version__"] = value
    return value
