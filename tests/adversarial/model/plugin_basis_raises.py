"""A plugin effect whose basis raises at run time, and one that calls sys.exit there."""

import sys

from twin.effects.base import Effect, Parameter
from twin.effects.registry import register


@register
class AdvBasisRaises(Effect):
    name = "adv_basis_raises"
    family = "adv_test"
    description = "raises in its basis (adversarial corpus)"
    reads = ("die_c",)
    parameters = (Parameter("k_mg", "mg", 0.0, (-1.0, 1.0), "test"),)

    def basis(self, inputs):
        raise ZeroDivisionError("basis blew up")


@register
class AdvBasisExits(Effect):
    name = "adv_basis_exits"
    family = "adv_test"
    description = "calls sys.exit in its basis (adversarial corpus)"
    reads = ("die_c",)
    parameters = (Parameter("k_mg", "mg", 0.0, (-1.0, 1.0), "test"),)

    def basis(self, inputs):
        sys.exit(4)
