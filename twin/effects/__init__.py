"""Registry of drift effects. Importing this package registers the built-in effects."""

from twin.effects import builtin  # noqa: F401  (registers)
from twin.effects.base import (
    REGISTRY,
    Composition,
    Contribution,
    Effect,
    EffectInputs,
    Parameter,
    get_effect,
    register,
)

__all__ = ["REGISTRY", "Composition", "Contribution", "Effect", "EffectInputs", "Parameter", "get_effect", "register"]
