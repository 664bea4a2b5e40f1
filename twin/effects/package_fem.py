"""Package stress from the finite-element model: CTE mismatch of board / solder / leadframe / attach /
die / mould → anchor motion on the die → gap change → bias and scale factor (sim.fem).

Unlike ``package_stress`` (one fitted coupling), the bias here follows from geometry and
materials: mould CTE, attach modulus and thickness, die thickness, die placement and where the
comb cell sits on the die. A symmetric package with a centred cell gives exactly zero bias (the
datasheet's TCOff is a population spread driven by asymmetries: docs/fem.md).
"""

from __future__ import annotations

from functools import lru_cache

import numpy as np

from sim.microstructure import CombGeometry
from twin.effects._common import REFERENCE_C
from twin.effects.base import Contribution, Effect, Parameter
from twin.effects.registry import register
from twin.errors import ModelError

_GRID_C = np.arange(-60.0, 150.0 + 1e-9, 0.25)  # fixed grid: a sample never depends on the others (causal)
_MEMO = "docs/fem.md, design notes §D4"


def _fixed(name, unit, default, bounds, source):
    return Parameter(name, unit, default, bounds, source, role="fixed", free=False)


@lru_cache(maxsize=128)
def _tables(design, layout, geometry: CombGeometry, reading: str, reference_c: float):
    """Bias [g] and package scale factor [1] on the grid: one FE solve (cached per design), then
    interpolation for any number of samples."""
    from sim.fem.comb_on_substrate import package_drift
    from sim.fem.package_stack import solve_stack

    drift = package_drift(solve_stack(design), layout, geometry, _GRID_C, reading, reference_c)
    offset, sf = drift.offset_mg * 1e-3, drift.scale_factor_ppm * 1e-6
    return offset - np.interp(reference_c, _GRID_C, offset), sf - np.interp(reference_c, _GRID_C, sf)


@register
class PackageFem(Effect):
    """Package stress from the finite-element model: bias and scale factor from geometry and materials."""

    name = "package_fem"
    family = "bias_tc"
    description = ("package CTE mismatch solved by finite elements (generalised plane strain, Q2) and carried to "
                   "the comb's anchors: bias and scale factor from geometry and materials (docs/fem.md)")
    reads = ("die_c", "applied_g")
    # not screened blind: its bias is a bias tempco (aliased with static_bias_tc) and each first
    # use costs a finite-element solve; compare it by name with --with-effect package_fem
    screened = False
    parameters = (
        Parameter("bias_scale", "1", 1.0, (-20.0, 20.0), "1 = as computed; a fitted value scales the asymmetry "
                  "(population spread, docs/fem.md §D1)"),
        Parameter("scale_factor_scale", "1", 1.0, (0.0, 20.0), "1 = as computed", free=False),
        _fixed("mould_cte_ppm_per_k", "ppm/K", 11.0, (3.0, 60.0), f"EMC-G845 α1 ({_MEMO})"),
        _fixed("attach_modulus_gpa", "GPa", 3.9, (0.001, 20.0), f"84-1LMISR4 at 25 °C ({_MEMO})"),
        _fixed("attach_thickness_um", "um", 25.0, (5.0, 200.0), f"15-40 µm typical ({_MEMO})"),
        _fixed("die_thickness_um", "um", 400.0, (150.0, 1000.0),
               "die + cap, 0.3-0.7 mm (assumption, docs/fem.md §D2)"),
        _fixed("die_offset_um", "um", 0.0, (-500.0, 500.0), "die placement relative to the package centre"),
        _fixed("cell_offset_um", "um", 300.0, (-600.0, 600.0), "sense cell centre relative to the die centre "
               "(assumption: a 3-axis die cannot centre every cell)"),
        _fixed("spring_half_span_um", "um", 400.0, (10.0, 900.0), "spring anchors at ±400 µm (docs/fem.md §D1)"),
        _fixed("electrode_half_span_um", "um", 100.0, (0.0, 900.0),
               "electrode anchors at ±100 µm (docs/fem.md §D1)"),
        REFERENCE_C,
    )

    def design(self, **overrides):
        """The :class:`sim.fem.package_stack.PackageDesign` of the current parameters.

        Parameters
        ----------
        **overrides
            Further ``PackageDesign`` fields (thicknesses [µm], moduli [GPa], CTEs [ppm/K]).

        Returns
        -------
        PackageDesign
            The stack design.
        """
        from sim.fem.package_stack import PackageDesign

        v = self.values
        try:
            return PackageDesign(die_thickness_um=v["die_thickness_um"], die_offset_um=v["die_offset_um"],
                                 attach_thickness_um=v["attach_thickness_um"],
                                 attach_modulus_gpa=v["attach_modulus_gpa"],
                                 mould_cte_ppm_per_k=v["mould_cte_ppm_per_k"], **overrides)
        except ValueError as exc:
            raise ModelError(f"effect {self.name!r}: {exc}") from None

    def layout(self):
        """The :class:`sim.fem.comb_on_substrate.AnchorLayout` of the current parameters.

        Returns
        -------
        AnchorLayout
            Cell offset and anchor half-spans [µm].
        """
        from sim.fem.comb_on_substrate import AnchorLayout

        v = self.values
        return AnchorLayout(v["cell_offset_um"], v["spring_half_span_um"], v["electrode_half_span_um"])

    def geometry(self) -> CombGeometry:
        """The comb geometry of the context, or the default one.

        Returns
        -------
        CombGeometry
            Dimensions [µm] and resonance [Hz].
        """
        return self.context.get("geometry") or CombGeometry()

    def tables(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Bias and scale factor per unit amplitude on the fixed temperature grid (one FE solve, cached).

        Returns
        -------
        tuple of ndarray
            (temperature grid [°C], bias [g], scale factor [1]), zero at the reference temperature.

        References
        ----------
        docs/fem.md (design notes §D1, §D4).
        """
        try:
            offset, sf = _tables(self.design(), self.layout(), self.geometry(), "H", self.values["reference_c"])
        except ValueError as exc:
            raise ModelError(f"effect {self.name!r}: {exc}") from None
        return _GRID_C, offset, sf

    def basis(self, inputs):
        """Bias and scale factor per unit scale, interpolated from :meth:`tables` at the die temperature.

        Parameters
        ----------
        inputs : EffectInputs
            Reads ``die_c`` [°C], inside the tabulated −60..150 °C.

        Returns
        -------
        dict of str to Contribution
            ``bias_scale``: bias [g]; ``scale_factor_scale``: scale factor [1]; each per unit scale.

        References
        ----------
        docs/fem.md; gap changes to capacitances as Qi et al. (2022), Micromachines 13, 2156,
        eqs. (16)–(19).
        """
        die = np.asarray(inputs.die_c, float)
        if die.size and (die.min() < _GRID_C[0] or die.max() > _GRID_C[-1]):
            raise ModelError(f"effect {self.name!r}: die temperature {die.min():.1f}..{die.max():.1f} °C is outside "
                             f"the tabulated {_GRID_C[0]:g}..{_GRID_C[-1]:g} °C")
        grid, offset, sf = self.tables()
        # offset and sf are smooth in T (α(T) quadratic): linear interpolation on 0.25 °C loses < 1e-6 relative
        return {"bias_scale": Contribution(bias_g=np.interp(die, grid, offset)),
                "scale_factor_scale": Contribution(scale_factor=np.interp(die, grid, sf))}
