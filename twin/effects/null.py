"""The explicit absent effect."""

from twin.effects.base import Effect
from twin.effects.registry import register


@register
class NullEffect(Effect):
    """The explicit absent effect: contributes nothing."""

    name = "null"
    family = "null"
    description = "contributes nothing (the explicit 'absent' effect)"
