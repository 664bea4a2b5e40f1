"""What every firmware format shares: errors, input checks, the clamped polynomial all methods
reduce to, and number formatting that survives a float32 round trip.

Both firmwares apply a temperature offset of the same shape: the temperature is clipped to the
calibrated range, then a polynomial in (T − T_ref) gives the offset subtracted from the raw
reading (PX4 ``TemperatureCompensation::calc_thermal_offsets_3D`` in
src/modules/temperature_compensation/TemperatureCompensation.cpp, repo PX4/PX4-Autopilot;
ArduPilot ``TCal::correct_sensor`` in libraries/AP_InertialSensor/AP_InertialSensor_tempcal.cpp,
repo ArduPilot/ardupilot). :class:`ClampedPolynomial` is that shape, in float64.
"""

from __future__ import annotations

from dataclasses import dataclass
from importlib.metadata import PackageNotFoundError, version

import numpy as np

from twin.errors import TwinError

G0_M_S2 = 9.80665  # standard gravity: 1 g in m/s² (1 µg = 9.80665e-6 m/s²)
AXES = ("x", "y", "z")


class FirmwareCalError(TwinError):
    """Data that cannot be turned into a firmware calibration (shape, NaN, no temperature span)."""


class CalibrationRangeError(FirmwareCalError):
    """The temperature span is too small for the method (ArduPilot needs ≥ 10 °C)."""


class CalibrationFileError(TwinError):
    """A calibration file (.params, .parm, JSON) that cannot be read or lacks a parameter."""


@dataclass(frozen=True)
class ClampedPolynomial:
    """offset(T) = Σ_k c[axis][k] · (clip(T, tmin_c, tmax_c) − tref_c)^k, per axis.

    Attributes
    ----------
    tmin_c, tmax_c : float
        Calibrated range (°C); temperatures outside are clipped to it, as both firmwares do.
    tref_c : float
        Reference temperature of the polynomial (°C).
    coefficients : tuple of tuple of float
        ``coefficients[axis][k]`` in (offset unit)/°C^k, ascending powers.
    """

    tmin_c: float
    tmax_c: float
    tref_c: float
    coefficients: tuple[tuple[float, ...], ...]

    @property
    def coefficient_array(self) -> np.ndarray:
        """(n_axes, order + 1) array of the coefficients, ascending powers."""
        return np.array(self.coefficients, dtype=float)

    def offset(self, temperature_c) -> np.ndarray:
        """Offset at each temperature: (n, n_axes) for an array, (n_axes,) for a scalar."""
        t = np.asarray(temperature_c, dtype=float)
        dt = np.clip(t, self.tmin_c, self.tmax_c) - self.tref_c
        c = self.coefficient_array
        out = np.zeros(dt.shape + (c.shape[0],))
        for k in range(c.shape[1] - 1, -1, -1):  # Horner, highest power first
            out = out * dt[..., None] + c[:, k]
        return out


def as_temperature(temperature_c, name: str = "temperature_c") -> np.ndarray:
    """1-D float64 temperatures, all finite, at least 4 of them (a cubic needs 4 points)."""
    t = np.asarray(temperature_c, dtype=float)
    if t.ndim != 1:
        raise FirmwareCalError(f"{name} must be 1-D (one temperature per sample), got shape {t.shape}")
    if t.size < 4:
        raise FirmwareCalError(f"{name} has {t.size} samples; a cubic fit needs at least 4")
    if not np.all(np.isfinite(t)):
        raise FirmwareCalError(f"{name} has {int(np.sum(~np.isfinite(t)))} non-finite values; drop them first")
    return t


def as_samples(values, n: int, name: str, axes: int | None = 3) -> np.ndarray:
    """Float64 samples matching ``n`` temperatures: (n, axes), or (n,)/(n, k) when axes is None."""
    v = np.asarray(values, dtype=float)
    if axes is not None and v.shape != (n, axes):
        raise FirmwareCalError(f"{name} must have shape ({n}, {axes}) to match temperature_c, got {v.shape}")
    if axes is None and (v.ndim not in (1, 2) or v.shape[0] != n):
        raise FirmwareCalError(f"{name} must have {n} rows to match temperature_c, got shape {v.shape}")
    if not np.all(np.isfinite(v)):
        raise FirmwareCalError(f"{name} has {int(np.sum(~np.isfinite(v)))} non-finite values; drop them first")
    return v


def float32_text(value: float) -> str:
    """The float32 nearest ``value``, written with 18 significant digits (QGC's full precision).

    Why: the digits are the exact float32 value, so text → double → float32 gives it back with
    no double rounding (QGroundControl ``Fact::rawValueStringFullPrecision`` also uses 18).
    """
    return "%.18g" % float(np.float32(value))


def c_float(value: float) -> str:
    """A C ``float`` literal of the float32 nearest ``value`` (9 significant digits round-trip)."""
    if not np.isfinite(np.float32(value)):
        raise FirmwareCalError(f"{value!r} has no finite float32 value to write into C")
    text = "%.9g" % float(np.float32(value))
    if not any(ch in text for ch in ".e"):
        text += ".0"
    return text + "f"


def generator_name() -> str:
    """``tde-twin X.Y.Z`` for the comment heading a generated file (no version in a source tree)."""
    try:
        return f"tde-twin {version('tde-twin')}"
    except PackageNotFoundError:
        return "tde-twin"
