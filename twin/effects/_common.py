"""Parameters shared by several effects (not an effect module)."""

from twin.effects.base import Parameter

REFERENCE_C = Parameter("reference_c", "degC", 25.0, (-40.0, 105.0), "convention: temperature of zero drift",
                        role="fixed", free=False)
