"""The fitted methods of a calibration document, one record per kind, told apart by ``kind``.

The firmware methods hold their firmware calibration (:mod:`twin.firmware.json_record`); the
twin's methods hold their coefficients [mg/°C^k] and, for the lag-aware and composed twins, their
time constants and effects, so that ``twin apply`` and the exporters need nothing else.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Annotated, Literal, Union

from pydantic import Field

from twin.firmware.json_record import FirmwareCalibration


@dataclass(frozen=True, kw_only=True)
class FirmwareMethod:
    """A PX4 or ArduPilot method: its firmware calibration and the level it leaves.

    Attributes
    ----------
    kind : "firmware"
    level_g : (float, float, float), optional
        Mean reading left after the correction [g] (the accelerometer).
    level_rad_s : (float, float, float), optional
        The same for the gyro [rad/s].
    firmware : FirmwareCalibration
    equation : str
    """

    kind: Literal["firmware"]
    level_g: tuple[float, float, float] | None = None
    level_rad_s: tuple[float, float, float] | None = None
    firmware: FirmwareCalibration
    equation: str


@dataclass(frozen=True)
class PolynomialMethod:
    """A polynomial in the raw temperature per axis.

    Attributes
    ----------
    kind : str
        The estimator's class name.
    reference_c : float
        Expansion point [°C].
    coef_mg : tuple of tuple of float
        a_k per axis [mg/°C^k], ascending powers of ``T − reference_c``.
    equation : str
    """

    kind: Literal["TemperaturePolynomial", "CubicCompensator"]
    reference_c: float
    coef_mg: tuple[tuple[float, ...], ...]
    equation: str


@dataclass(frozen=True)
class LagAwareMethod:
    """The lag-aware twin: a polynomial in the lagged die temperature plus a rate term per axis.

    Attributes
    ----------
    kind : "LagAwareCompensator"
    reference_c : float
        Expansion point [°C].
    coef_mg : tuple of tuple of float
        a_k per axis [mg/°C^k] in ``T_die − reference_c``.
    equation : str
    tau_die_s : tuple of float
        τ_die per axis [s].
    tau_rate_s : tuple of float or None
        τ_rate per axis [s] (None: the axis has no rate term).
    rate_mg_per_c : tuple of float
        Rate amplitude b per axis [mg/°C] (0 where unused).
    tau_die_ci95_s : tuple of (float, float)
        95 % interval of τ_die per axis [s].
    shared : bool
        One (τ_die, τ_rate) for all axes.
    """

    kind: Literal["LagAwareCompensator"]
    reference_c: float
    coef_mg: tuple[tuple[float, ...], ...]
    equation: str
    tau_die_s: tuple[float, ...]
    tau_rate_s: tuple[float | None, ...]
    rate_mg_per_c: tuple[float, ...]
    tau_die_ci95_s: tuple[tuple[float, float], ...]
    shared: bool


@dataclass(frozen=True)
class EffectValues:
    """One library effect of a composed twin with its fitted values.

    Attributes
    ----------
    name : str
        The registered effect.
    values : dict of str to float
        Parameter → value, in each parameter's unit (the effect's names carry them: ``tau_s``,
        ``k1_mg_per_c`` …).
    """

    name: str
    values: dict[str, float]


@dataclass(frozen=True)
class ComposedAxis:
    """One axis of a composed twin.

    Attributes
    ----------
    axis : str
    coef_mg : tuple of float
        Static curve a_k [mg/°C^k] in ``T_die − reference_c``.
    applied_g : float
        Median reading of the fitted rows [g].
    train_rms_mg : float
        RMS left on the training rows [mg].
    effects : tuple of EffectValues
    """

    axis: str
    coef_mg: tuple[float, ...]
    applied_g: float
    train_rms_mg: float
    effects: tuple[EffectValues, ...]


@dataclass(frozen=True)
class ComposedMethod:
    """The composed twin: a static cubic in the die temperature plus library effects per axis.

    Attributes
    ----------
    kind : "ComposedCompensator"
    reference_c : float
        Expansion point [°C].
    coef_mg : tuple of tuple of float
        Static a_k per axis [mg/°C^k].
    equation : str
    axes : tuple of ComposedAxis
    """

    kind: Literal["ComposedCompensator"]
    reference_c: float
    coef_mg: tuple[tuple[float, ...], ...]
    equation: str
    axes: tuple[ComposedAxis, ...]


MethodRecord = Annotated[Union[FirmwareMethod, PolynomialMethod, LagAwareMethod, ComposedMethod],
                         Field(discriminator="kind")]
