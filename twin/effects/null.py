"""The explicit absent effect."""

from twin.effects.base import Effect, register


@register
class NullEffect(Effect):
    name = "null"
    family = "null"
    description = "contributes nothing (the explicit 'absent' effect)"
