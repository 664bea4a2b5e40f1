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

import math
import numbers
from dataclasses import dataclass
from importlib.metadata import PackageNotFoundError, version

import numpy as np

from twin.errors import TwinError

G0_M_S2 = 9.80665  # standard gravity: 1 g in m/s² (1 µg = 9.80665e-6 m/s²)
AXES = ("x", "y", "z")
FLOAT32_MAX = float(np.finfo(np.float32).max)  # 3.4028235e38: both firmwares hold parameters as float
FLOAT32_EPS = float(np.finfo(np.float32).eps)  # 2^-23
DEVICE_ID_MAX = 2**32 - 1  # PX4 device ids are uint32 (TemperatureCompensation::set_sensor_id)


class FirmwareCalError(TwinError):
    """Data that cannot be turned into a firmware calibration (shape, NaN, no temperature span)."""


class CalibrationRangeError(FirmwareCalError):
    """The temperature span is too small for the method (ArduPilot needs ≥ 10 °C)."""


class FirmwareValueError(FirmwareCalError):
    """A value the firmware cannot hold or would not apply: not finite, beyond float32, TMIN ≥ TMAX,
    a polynomial of a degree the firmware lacks, an instance it has no parameters for, device id 0."""


class FirmwareVerifyError(FirmwareCalError):
    """A generated firmware file that does not read back as the calibration it was written from."""


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
    def degree(self) -> int:
        """Highest power held (number of coefficients per axis − 1)."""
        return max(len(c) for c in self.coefficients) - 1

    @property
    def coefficient_array(self) -> np.ndarray:
        """(n_axes, order + 1) array of the coefficients, ascending powers."""
        return np.array(self.coefficients, dtype=float)

    def offset(self, temperature_c) -> np.ndarray:
        """Offset at each temperature: (n, n_axes) for an array, (n_axes,) for a scalar.

        Parameters
        ----------
        temperature_c : float or array_like
            Temperature [°C], clipped to [tmin_c, tmax_c].

        Returns
        -------
        ndarray
            Offset per axis [offset unit, e.g. m/s² or rad/s].

        References
        ----------
        The clamped polynomial of PX4 ``TemperatureCompensation::calc_thermal_offsets_3D`` and
        ArduPilot ``TCal::correct_sensor`` (module docstring), evaluated by Horner's rule in float64.
        """
        t = np.asarray(temperature_c, dtype=float)
        dt = np.clip(t, self.tmin_c, self.tmax_c) - self.tref_c
        c = self.coefficient_array
        out = np.zeros(dt.shape + (c.shape[0],))
        for k in range(c.shape[1] - 1, -1, -1):  # Horner, highest power first, in place (same operations)
            out *= dt[..., None]
            out += c[:, k]
        return out

    def mean_offset(self, temperature_c) -> np.ndarray:
        """The mean of :meth:`offset` over the samples, per axis: Σ_k c_k·mean((clip(T) − tref)^k),
        a pass per power of one column instead of the (n, n_axes) offsets (equal to rounding).

        Parameters
        ----------
        temperature_c : array_like
            Temperatures [°C], at least one.

        Returns
        -------
        ndarray
            Mean offset per axis [offset unit].
        """
        dt = np.clip(np.asarray(temperature_c, dtype=float), self.tmin_c, self.tmax_c) - self.tref_c
        c = self.coefficient_array
        moments, power = np.ones(c.shape[1]), np.ones_like(dt)
        for k in range(1, c.shape[1]):
            power *= dt
            moments[k] = power.mean()
        return c @ moments


def as_temperature(temperature_c, name: str = "temperature_c") -> np.ndarray:
    """1-D float64 temperatures, all finite, at least 4 of them (a cubic needs 4 points).

    Parameters
    ----------
    temperature_c : array_like
        Temperature per sample [°C].
    name : str
        Name in messages.

    Returns
    -------
    ndarray
        The temperatures [°C].
    """
    t = np.asarray(temperature_c, dtype=float)
    if t.ndim != 1:
        raise FirmwareCalError(f"{name} must be 1-D (one temperature per sample), got shape {t.shape}")
    if t.size < 4:
        raise FirmwareCalError(f"{name} has {t.size} samples; a cubic fit needs at least 4")
    if not np.all(np.isfinite(t)):
        raise FirmwareCalError(f"{name} has {int(np.sum(~np.isfinite(t)))} non-finite values; drop them first")
    return t


def as_samples(values, n: int, name: str, axes: int | None = 3) -> np.ndarray:
    """Float64 samples matching ``n`` temperatures: (n, axes), or (n,)/(n, k) when axes is None.

    Parameters
    ----------
    values : array_like
        Samples [their unit, e.g. m/s² or rad/s].
    n : int
        Number of temperatures.
    name : str
        Name in messages.
    axes : int or None
        Columns required.

    Returns
    -------
    ndarray
        The samples [unit of ``values``].
    """
    v = np.asarray(values, dtype=float)
    if axes is not None and v.shape != (n, axes):
        raise FirmwareCalError(f"{name} must have shape ({n}, {axes}) to match temperature_c, got {v.shape}")
    if axes is None and (v.ndim not in (1, 2) or v.shape[0] != n):
        raise FirmwareCalError(f"{name} must have {n} rows to match temperature_c, got shape {v.shape}")
    if not np.all(np.isfinite(v)):
        raise FirmwareCalError(f"{name} has {int(np.sum(~np.isfinite(v)))} non-finite values; drop them first")
    return v


def check_float32(value, name: str) -> float:
    """``value`` as a float, refused unless finite and held by a float32 without overflow.

    Why: both firmwares store parameters as 32-bit floats, so a value that is finite in float64 but
    beyond ±3.4028235e38 (e.g. 1e45) loads as ±inf. Refused, never clamped: a clamped coefficient
    would be a different calibration.

    Parameters
    ----------
    value : float
        The value [any unit].
    name : str
        The parameter it is written as.

    Returns
    -------
    float
        ``value`` as a Python float (float64) [unit of ``value``].

    Raises
    ------
    FirmwareValueError
        Naming the parameter ``name``, the value and what was expected.
    """
    if isinstance(value, bool) or not isinstance(value, numbers.Real):
        raise FirmwareValueError(f"{name} = {value!r} is not a number; expected a finite float32 value")
    v = float(value)
    if not math.isfinite(v):
        raise FirmwareValueError(f"{name} = {v!r} is not finite; expected a finite float32 value "
                                 "(refit from finite data)")
    with np.errstate(over="ignore"):
        held = np.float32(v)
    if not np.isfinite(held):
        raise FirmwareValueError(f"{name} = {v:g} is beyond float32 (|v| <= {FLOAT32_MAX:.8g}), the type the "
                                 "firmware stores it in; expected a float32 value, refused rather than clamped")
    return v


def check_temperature_range(tmin_c, tmax_c, tref_c, prefix: str) -> None:
    """TMIN, TMAX (and TREF unless None) finite float32, and TMIN < TMAX strictly as float32.

    Why float32: the firmware compares the stored floats, so two values distinct in float64 but
    equal in float32 are an empty range on the vehicle.

    Parameters
    ----------
    tmin_c, tmax_c, tref_c : float
        Calibrated range and reference (°C); ``tref_c`` None when the method has no TREF parameter.
    prefix : str
        Parameter prefix naming the instance, e.g. ``TC_A0_`` or ``INS_TCAL1_``.
    """
    tmin = check_float32(tmin_c, prefix + "TMIN")
    tmax = check_float32(tmax_c, prefix + "TMAX")
    if tref_c is not None:
        check_float32(tref_c, prefix + "TREF")
    if not np.float32(tmin) < np.float32(tmax):
        raise FirmwareValueError(f"{prefix}TMIN = {tmin:g} °C is not below {prefix}TMAX = {tmax:g} °C (as float32); "
                                 "expected TMIN < TMAX, the calibrated range; fit data that span a temperature range")


def check_instance(instance, first: int, last: int, label: str) -> int:
    """``instance`` as an int in ``first..last``; ``label`` is a template such as ``TC_A{}``.

    Parameters
    ----------
    instance : int
        Sensor instance.
    first, last : int
        Instances the firmware has parameters for.
    label : str
        Parameter prefix template, for messages.

    Returns
    -------
    int
        The instance.
    """
    if isinstance(instance, bool) or not isinstance(instance, numbers.Integral):
        raise FirmwareValueError(f"{label.format('n')} instance {instance!r} is not an integer; "
                                 f"expected {first}..{last}")
    n = int(instance)
    if not first <= n <= last:
        raise FirmwareValueError(f"instance {n} has no {label.format(n)}_* parameters: the firmware has "
                                 f"{label.format(first)}..{label.format(last)}; expected an instance {first}..{last}")
    return n


def check_device_id_px4(device_id, name: str) -> int:
    """A PX4 device id 1..2³²−1; 0 refused because PX4 would never apply the calibration.

    ``TemperatureCompensation::set_sensor_id`` (PX4/PX4-Autopilot,
    src/modules/temperature_compensation/TemperatureCompensation.cpp) maps a sensor to the slot
    whose ``TC_An_ID`` equals its ``device_id``; no sensor has device id 0.

    Parameters
    ----------
    device_id : int
        The sensor's device id.
    name : str
        The parameter it is written as.

    Returns
    -------
    int
        The device id.
    """
    if isinstance(device_id, bool) or not isinstance(device_id, numbers.Integral):
        raise FirmwareValueError(f"{name} = {device_id!r} is not an integer; expected the sensor's device id "
                                 f"1..{DEVICE_ID_MAX}")
    n = int(device_id)
    if n == 0:
        raise FirmwareValueError(f"{name} is 0: PX4 never applies a calibration whose TC_An_ID is 0 (it matches "
                                 f"sensors by device_id); expected the sensor's device id 1..{DEVICE_ID_MAX}; "
                                 "calibrate from a log that records device_id, or pass --device-id")
    if not 0 < n <= DEVICE_ID_MAX:
        raise FirmwareValueError(f"{name} = {n} is outside uint32; expected the sensor's device id 1..{DEVICE_ID_MAX}")
    return n


def check_coefficients(coefficients, n_terms: int, name, method: str, *, exact: bool = False) -> np.ndarray:
    """(3, n_terms) float64 coefficients, each a finite float32; shorter rows zero-padded unless ``exact``.

    A row with more than ``n_terms`` coefficients is refused, never cut: dropping the high powers
    would write a different polynomial than the one validated.

    Parameters
    ----------
    coefficients : sequence of 3 sequences
        Per axis, ascending powers as the method stores them.
    n_terms : int
        Terms the firmware has per axis (PX4 X0..X3: 4; ArduPilot ACC1..ACC3: 3).
    name : callable
        ``name(axis, k)`` → the parameter name of term k of ``axis`` (for messages).
    method : str
        What the firmware applies, for the message (e.g. ``PX4 applies X0..X3 (degree <= 3)``).
    exact : bool
        Refuse rows shorter than ``n_terms`` too (ArduPilot has exactly three terms).

    Returns
    -------
    ndarray
        Coefficients, shape (3, n_terms) [offset unit/°C^k].
    """
    rows = list(coefficients)
    if len(rows) != 3:
        raise FirmwareValueError(f"{name(0, 0)}: {len(rows)} axes of coefficients; expected 3 (x, y, z)")
    out = np.zeros((3, n_terms))
    for axis, row in enumerate(rows):
        row = list(row)
        if len(row) > n_terms or (exact and len(row) != n_terms) or not row:
            raise FirmwareValueError(f"{name(axis, 0)}: axis {AXES[axis]} holds {len(row)} coefficients; {method}; "
                                     f"expected {'exactly' if exact else 'at most'} {n_terms} (refit; never truncated)")
        for k, c in enumerate(row):
            out[axis, k] = check_float32(c, name(axis, k))
    return out


def check_polynomial(poly: ClampedPolynomial, where: str) -> None:
    """A clamped polynomial of any degree a float32 evaluator can hold: TMIN < TMAX, TREF and
    every coefficient finite float32 (the JSON and C-header writers, which have no degree limit).

    Parameters
    ----------
    poly : ClampedPolynomial
        The polynomial.
    where : str
        Prefix of messages.
    """
    check_temperature_range(poly.tmin_c, poly.tmax_c, poly.tref_c, where + " ")
    for axis, row in enumerate(poly.coefficients):
        for k, c in enumerate(row):
            check_float32(c, f"{where} coefficient {k} of axis {AXES[axis] if axis < len(AXES) else axis}")


def applied_vs_ideal(applied, ideal, mask=None) -> dict[str, dict[str, float]]:
    """Validation table: per axis max abs(applied − ideal) and RMS, e.g. what the vehicle applies with
    the written file loaded (``px4_vehicle_offsets``, ``ardupilot_vehicle_offsets``) against the
    float64 polynomial (``cal.offset``), in the offsets' unit.

    Parameters
    ----------
    applied, ideal : (n, 3) arrays
        Offsets applied and ideal [offset unit, e.g. m/s²].
    mask : (n,) bool array, optional
        Rows to include (e.g. after PX4's first publication).

    Returns
    -------
    dict
        Per axis ``{"max_abs": ..., "rms": ...}`` [offset unit].
    """
    diff = np.asarray(applied, dtype=float) - np.asarray(ideal, dtype=float)
    if mask is not None:
        diff = diff[np.asarray(mask, dtype=bool)]
    if diff.ndim != 2 or diff.shape[0] == 0:
        raise FirmwareCalError(f"applied and ideal must be (n, axes) with rows to compare, got {diff.shape}")
    return {AXES[a] if a < len(AXES) else str(a): {"max_abs": float(np.max(np.abs(diff[:, a]))),
                                                     "rms": float(np.sqrt(np.mean(diff[:, a] ** 2)))}
            for a in range(diff.shape[1])}


def float32_text(value: float) -> str:
    """The float32 nearest ``value``, written with 18 significant digits (QGC's full precision).

    Why: the digits are the exact float32 value, so text → double → float32 gives it back with
    no double rounding (QGroundControl ``Fact::rawValueStringFullPrecision`` also uses 18).

    Parameters
    ----------
    value : float
        The value [any unit].

    Returns
    -------
    str
        Its float32 value as text.
    """
    return "%.18g" % float(np.float32(value))


def c_float(value: float) -> str:
    """A C ``float`` literal of the float32 nearest ``value`` (9 significant digits round-trip).

    Parameters
    ----------
    value : float
        The value [any unit].

    Returns
    -------
    str
        E.g. ``"0.5f"``.
    """
    if not np.isfinite(np.float32(value)):
        raise FirmwareCalError(f"{value!r} has no finite float32 value to write into C")
    text = "%.9g" % float(np.float32(value))
    if not any(ch in text for ch in ".e"):
        text += ".0"
    return text + "f"


def generator_name() -> str:
    """``tde-twin X.Y.Z`` for the comment heading a generated file (no version in a source tree).

    Returns
    -------
    str
        Name and installed version.
    """
    try:
        return f"tde-twin {version('tde-twin')}"
    except PackageNotFoundError:
        return "tde-twin"
