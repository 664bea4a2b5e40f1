"""PX4 ``.params`` files in QGroundControl's format: check, write, and verify the text against
the intended calibration before it is written (parsing a file back, and turning its parameters
back into a calibration, is :mod:`twin.firmware.px4_param_file`).

Format (QGroundControl ``ParameterManager::writeParametersToStream`` / ``readParametersFromStream``,
repo mavlink/qgroundcontrol): ``#`` comment lines — ``# Onboard parameters for Vehicle 1``, ``#``,
``# Stack: …``, ``# Vehicle: …``, ``# Version: …``, ``# Git Revision: …``, ``#``, then
``# Vehicle-Id Component-Id Name Value Type`` — and one row per parameter,
``vehicle<TAB>component<TAB>NAME<TAB>VALUE<TAB>TYPE``. QGC reads only rows of exactly 5 tab-separated
fields; TYPE is a MAV_PARAM_TYPE (6 = INT32, 9 = REAL32). process_sensor_caldata.py (repo
PX4/PX4-Autopilot) writes ``TC_An_ID`` as type 6 and every other ``TC_An_*`` as type 9, the accel
in the order ID, TMIN, TMAX, TREF, X0_0, X1_0, X2_0, X3_0, X0_1 … X3_2 and the gyro ``TC_Gn_*``
sorted by name (its ``key_list_gyro.sort()``). It does not write ``TC_A_ENABLE``/``TC_G_ENABLE``
(its step 1 sets them on the board); we add each (INT32) for the sensors we write, since the
firmware ignores every ``TC_A*``/``TC_G*`` parameter while it is 0 — and write no row at all for
a sensor we did not calibrate, so loading the file leaves that calibration on the board alone.

Every value is checked as the firmware will hold it before any text exists (:func:`check_px4_cal`),
and :func:`checked_px4_params_text` parses the text back as QGC does and re-applies the firmware
formula before it is returned for writing.
"""

from __future__ import annotations

from collections.abc import Iterable
from pathlib import Path

import numpy as np

from twin.firmware.common import (
    FLOAT32_EPS,
    CalibrationFileError,
    ClampedPolynomial,
    FirmwareValueError,
    FirmwareVerifyError,
    check_coefficients,
    check_device_id_px4,
    check_instance,
    check_temperature_range,
    float32_text,
)
from twin.firmware.px4 import (
    PX4_INSTANCES,
    PX4_TERMS,
    SENSOR_PREFIX,
    Px4AccelCal,
    Px4GyroCal,
    check_sensor,
)
from twin.firmware.px4_param_file import (
    MAV_PARAM_TYPE_INT32,
    MAV_PARAM_TYPE_REAL32,
    Px4ParamFile,
    parse_px4_params,
)
from twin.firmware.px4_vehicle import firmware_offset_px4
from twin.io import atomic_write_text

HEADER_LAST = "# Vehicle-Id Component-Id Name Value Type"
Px4Cal = Px4AccelCal | Px4GyroCal


def px4_cal_from_polynomial(poly: ClampedPolynomial, *, instance: int, device_id: int,
                            sensor: str = "accel") -> Px4AccelCal | Px4GyroCal:
    """A ``TC_A``/``TC_G`` calibration holding ``poly`` (e.g. a held-out polynomial fit's).

    Degrees below 3 are padded with zero terms; a higher degree is refused, never truncated
    (PX4 evaluates X0..X3 only, so dropping terms would load a different correction).

    Parameters
    ----------
    poly : ClampedPolynomial
        The polynomial [°C; m/s² or rad/s per °C^k], or a fit object holding one.
    instance, device_id : int
        n in ``TC_An``/``TC_Gn`` (0..3); the sensor's device id.
    sensor : {"accel", "gyro"}
        Which parameters.

    Returns
    -------
    Px4AccelCal or Px4GyroCal
        The calibration.

    Raises
    ------
    FirmwareValueError
        Degree > 3, or a value the firmware cannot hold.
    """
    kind = check_sensor(sensor)
    poly = getattr(poly, "polynomial", poly)  # a fit object (e.g. HeldoutPolynomialFit) gives its polynomial
    label = SENSOR_PREFIX[kind] + "{}"
    prefix = label.format(check_instance(instance, 0, PX4_INSTANCES - 1, label)) + "_"
    x = check_coefficients(poly.coefficients, PX4_TERMS, lambda a, k: f"{prefix}X{k}_{a}",
                           "PX4 applies X0..X3 (degree <= 3)")
    x = tuple(tuple(float(v) for v in row) for row in x)
    if kind == "gyro":
        return Px4GyroCal(int(instance), int(device_id), poly.tmin_c, poly.tmax_c, poly.tref_c, x)
    return Px4AccelCal(int(instance), int(device_id), poly.tmin_c, poly.tmax_c, poly.tref_c, x)


def check_px4_cal(cal, *, require_device_id: bool = True) -> None:
    """Refuse a calibration PX4 could not hold or would not apply, before any text is produced.

    Checks: a Px4AccelCal/Px4GyroCal; instance 0..3; device id 1..2³²−1 (unless
    ``require_device_id`` is False, e.g. for a JSON record); TMIN < TMAX, TREF finite; 3 axes of
    at most 4 coefficients (X0..X3), each a finite float32.

    Parameters
    ----------
    cal : Px4AccelCal or Px4GyroCal
        The calibration.
    require_device_id : bool
        Refuse device id 0 (PX4 would never apply the calibration).

    Raises
    ------
    FirmwareValueError
        One line naming the parameter, the value and what was expected.
    """
    if not isinstance(cal, (Px4AccelCal, Px4GyroCal)):
        raise FirmwareValueError(f"a PX4 .params file takes Px4AccelCal/Px4GyroCal, got {type(cal).__name__}; "
                                 "convert a polynomial with px4_cal_from_polynomial (degree <= 3)")
    label = SENSOR_PREFIX[cal.sensor] + "{}"
    check_instance(cal.instance, 0, PX4_INSTANCES - 1, label)
    p = cal.prefix
    if require_device_id:
        check_device_id_px4(cal.device_id, p + "ID")
    check_temperature_range(cal.tmin_c, cal.tmax_c, cal.tref_c, p)
    check_coefficients(cal.x, PX4_TERMS, lambda a, k: f"{p}X{k}_{a}", "PX4 applies X0..X3 (degree <= 3)")


def split_px4_cals(cals, gyro=None) -> tuple[list, list]:
    """(accel cals, gyro cals) from ``cals`` (one or an iterable, either kind) and ``gyro``.

    Parameters
    ----------
    cals : Px4AccelCal, Px4GyroCal, or an iterable of them
        Calibrations of either kind.
    gyro : Px4GyroCal or iterable of them, optional
        More gyro calibrations.

    Returns
    -------
    tuple of list
        The accel calibrations and the gyro calibrations, each in the order given.

    Raises
    ------
    CalibrationFileError
        Two calibrations for one ``TC_An``/``TC_Gn`` slot.
    FirmwareValueError
        Nothing to write, or an object that is not a PX4 calibration.
    """
    def items(x):
        return [] if x is None else list(x) if isinstance(x, Iterable) and not isinstance(x, str) else [x]

    every = items(cals) + items(gyro)
    for cal in every:
        if not isinstance(cal, (Px4AccelCal, Px4GyroCal)):
            raise FirmwareValueError(f"a PX4 .params file takes Px4AccelCal/Px4GyroCal, got {type(cal).__name__}; "
                                     "convert a polynomial with px4_cal_from_polynomial (degree <= 3)")
    if not every:
        raise FirmwareValueError("no accel or gyro calibration given; expected at least one to write")
    accel = [c for c in every if isinstance(c, Px4AccelCal)]
    gyros = [c for c in every if isinstance(c, Px4GyroCal)]
    for kind in (accel, gyros):
        instances = [c.instance for c in kind]
        if len(set(instances)) != len(instances):
            raise CalibrationFileError(f"two calibrations for the same {kind[0].prefix[:4]} instance: {instances}")
    return accel, gyros


def px4_param_values(cal: Px4Cal) -> dict[str, tuple[int | float, int]]:
    """NAME → (value as the firmware holds it, MAV_PARAM_TYPE) for one checked calibration.

    ``TC_xn_ID`` is the int32 with the device id's 32 bits (uint32 in the firmware, INT32 parameter);
    the others are the float32 nearest the calibration's value.

    Parameters
    ----------
    cal : Px4AccelCal or Px4GyroCal
        The calibration (checked by :func:`check_px4_cal`).

    Returns
    -------
    dict of str to tuple
        Parameter name → (value [°C, or m/s² or rad/s per °C^k], MAV_PARAM_TYPE).
    """
    check_px4_cal(cal)
    p = cal.prefix
    x = check_coefficients(cal.x, PX4_TERMS, lambda a, k: f"{p}X{k}_{a}", "PX4 applies X0..X3 (degree <= 3)")
    out = {p + "ID": (int(np.uint32(cal.device_id).view(np.int32)), MAV_PARAM_TYPE_INT32)}
    for key, value in (("TMIN", cal.tmin_c), ("TMAX", cal.tmax_c), ("TREF", cal.tref_c)):
        out[p + key] = (float(np.float32(value)), MAV_PARAM_TYPE_REAL32)
    for axis in range(3):
        for k in range(PX4_TERMS):
            out[f"{p}X{k}_{axis}"] = (float(np.float32(x[axis, k])), MAV_PARAM_TYPE_REAL32)
    return out


def px4_param_rows(cals, include_enable: bool = True, *, gyro=None) -> list[tuple[str, str, int]]:
    """(NAME, VALUE text, TYPE) rows: ``TC_A_ENABLE`` and the accel blocks in process_sensor_caldata.py's
    order, then ``TC_G_ENABLE`` and the gyro blocks sorted by name as the script writes them. A
    sensor kind without a calibration gets no row at all. Every value is checked first.

    Parameters
    ----------
    cals : Px4AccelCal, Px4GyroCal, or an iterable of them
        One calibration per instance and sensor kind.
    include_enable : bool
        Write ``TC_A_ENABLE``/``TC_G_ENABLE`` 1 for each kind written.
    gyro : Px4GyroCal or iterable of them, optional
        More gyro calibrations.

    Returns
    -------
    list of tuple
        (name, value text as the firmware holds it, MAV_PARAM_TYPE) per row.
    """
    accel, gyros = split_px4_cals(cals, gyro)
    rows: list[tuple[str, str, int]] = []
    for base, kind in (("TC_A", accel), ("TC_G", gyros)):
        if not kind:
            continue
        if include_enable:
            rows.append((base + "_ENABLE", "1", MAV_PARAM_TYPE_INT32))
        for cal in kind:
            block = [(name, str(v) if t == MAV_PARAM_TYPE_INT32 else float32_text(v), t)
                     for name, (v, t) in px4_param_values(cal).items()]
            rows += sorted(block) if base == "TC_G" else block
    return rows


def px4_params_text(cals, *, gyro=None, vehicle_id: int = 1, component_id: int = 1,
                    include_enable: bool = True, stack: str = "PX4 Pro", vehicle: str = "unknown",
                    version: str = "unknown", git_revision: str = "unknown",
                    comments: Iterable[str] = ("Sensor thermal compensation parameters",)) -> str:
    """The ``.params`` text QGroundControl loads (header as QGC writes it, tab-separated rows).

    Parameters
    ----------
    cals : Px4AccelCal, Px4GyroCal, or an iterable of them (may be empty when ``gyro`` is given)
        One calibration per instance and sensor kind.
    gyro : Px4GyroCal or iterable of them, optional
        Gyro calibrations (``TC_Gn_*``, with ``TC_G_ENABLE 1``); none means no gyro row at all.
    vehicle_id, component_id : int
        MAVLink system and component ids of the rows (QGC refuses a file whose system id differs
        from the connected vehicle's).
    stack, vehicle, version, git_revision : str
        The informational header lines QGC writes (QGC ignores ``#`` lines on load).
    comments : iterable of str
        Extra ``#`` lines placed before the final column-header line (e.g. provenance); the
        default is the first line process_sensor_caldata.py writes.

    Returns
    -------
    str
        The file's text.

    Raises
    ------
    FirmwareValueError
        A value PX4 cannot hold or would not apply (see :func:`check_px4_cal`); no text is made.
    """
    rows = px4_param_rows(cals, include_enable, gyro=gyro)
    lines = [f"# Onboard parameters for Vehicle {int(vehicle_id)}", "#", f"# Stack: {stack}",
             f"# Vehicle: {vehicle}", f"# Version: {version}", f"# Git Revision: {git_revision}", "#"]
    extra = [f"# {c}" for c in comments]
    lines += extra + (["#"] if extra else []) + [HEADER_LAST]
    lines += [f"{int(vehicle_id)}\t{int(component_id)}\t{name}\t{value}\t{ptype}" for name, value, ptype in rows]
    return "\n".join(lines) + "\n"


def _tolerance(cal: Px4Cal, grid: np.ndarray) -> np.ndarray:
    """Float32 evaluation error bound (n, 3) of the clamped cubic: 16 ulp of the sum of |terms|,
    plus the slope times the rounding of T, TMIN, TMAX and TREF to float32."""
    c = np.abs(np.array([list(r) + [0.0] * (PX4_TERMS - len(r)) for r in cal.x]))
    dt = np.abs(np.clip(grid, cal.tmin_c, cal.tmax_c) - cal.tref_c)[:, None]
    terms = sum(c[:, k] * dt ** k for k in range(PX4_TERMS))
    slope = sum(k * c[:, k] * dt ** (k - 1) for k in range(1, PX4_TERMS))
    scale = np.abs(grid)[:, None] + abs(cal.tmin_c) + abs(cal.tmax_c) + abs(cal.tref_c)
    return 16 * FLOAT32_EPS * terms + 4 * FLOAT32_EPS * scale * slope


def verify_px4_params(text: str, intended_cals, *, gyro=None, include_enable: bool = True,
                      source: str = "<params>") -> Px4ParamFile:
    """Parse ``text`` as QGC loads it and check it is exactly the intended calibrations.

    Checks: the parameter names are exactly those of the calibrations (and their ``_ENABLE``
    unless ``include_enable`` is False) — no extra gyro or accel row; each type is the script's;
    each value equals the float32 of the intended value; and ``calc_thermal_offsets_3D`` on the
    parsed values (:func:`~twin.firmware.px4_vehicle.firmware_offset_px4`) reproduces the intended float64
    offsets within float32 evaluation error (see ``_tolerance``), 10 °C beyond the range included.

    Parameters
    ----------
    text : str
        The ``.params`` text.
    intended_cals : Px4AccelCal, Px4GyroCal, or an iterable of them
        The calibrations the text should hold.
    gyro : Px4GyroCal or iterable of them, optional
        More intended gyro calibrations.
    include_enable : bool
        Whether the text should hold ``TC_A_ENABLE``/``TC_G_ENABLE``.
    source : str
        Name in messages.

    Returns
    -------
    Px4ParamFile
        The parsed file.

    Raises
    ------
    FirmwareVerifyError
        The first difference, as one line naming the parameter.
    """
    parsed = parse_px4_params(text, source)
    accel, gyros = split_px4_cals(intended_cals, gyro)
    expected: dict[str, tuple[int | float, int]] = {}
    for base, kind in (("TC_A", accel), ("TC_G", gyros)):
        if kind and include_enable:
            expected[base + "_ENABLE"] = (1, MAV_PARAM_TYPE_INT32)
        for cal in kind:
            expected.update(px4_param_values(cal))
    extra = sorted(set(parsed.values) - set(expected))
    missing = sorted(set(expected) - set(parsed.values))
    if extra or missing:
        state = "unexpected" if extra else "missing"
        raise FirmwareVerifyError(f"{source}: parameters {extra or missing} are {state}; "
                                  "expected exactly the calibrated sensors' rows; regenerate the file")
    for name, (value, ptype) in expected.items():
        if parsed.types[name] != ptype or parsed.values[name] != value:
            raise FirmwareVerifyError(f"{source}: {name} reads back as {parsed.values[name]!r} (type "
                                      f"{parsed.types[name]}), the calibration holds {value!r} (type {ptype}) as "
                                      "the firmware stores it; regenerate the file")
    values = dict(parsed.values, TC_A_ENABLE=1, TC_G_ENABLE=1)  # the formula, whatever the enables
    for cal in accel + gyros:
        grid = np.unique(np.concatenate([np.linspace(cal.tmin_c - 10, cal.tmax_c + 10, 401),
                                         [cal.tmin_c, cal.tmax_c, cal.tref_c]]).astype(np.float32)).astype(float)
        firmware = firmware_offset_px4(values, grid, cal.instance, sensor=cal.sensor).astype(float)
        err = np.abs(firmware - cal.offset(grid)) - _tolerance(cal, grid)
        if np.max(err) > 0:
            i, a = np.unravel_index(np.argmax(err), err.shape)
            raise FirmwareVerifyError(f"{source}: {cal.prefix[:-1]} axis {a} at {grid[i]:g} °C: the firmware "
                                      f"formula on the parsed values gives {firmware[i, a]:.9g}, the calibration "
                                      f"{cal.offset(grid)[i, a]:.9g}; regenerate the file")
    return parsed


def checked_px4_params_text(cals, *, gyro=None, **kwargs) -> str:
    """:func:`px4_params_text`, verified by :func:`verify_px4_params` before it is returned.

    The text to write atomically: every value was checked before the text existed, and the text
    was read back as QGC reads it.

    Parameters
    ----------
    cals : Px4AccelCal, Px4GyroCal, or an iterable of them
        One calibration per instance and sensor kind.
    gyro : Px4GyroCal or iterable of them, optional
        Gyro calibrations.
    **kwargs
        As :func:`px4_params_text`.

    Returns
    -------
    str
        The verified ``.params`` text.
    """
    text = px4_params_text(cals, gyro=gyro, **kwargs)
    verify_px4_params(text, cals, gyro=gyro, include_enable=kwargs.get("include_enable", True))
    return text


def write_px4_params(path, cals, **kwargs) -> Path:
    """Write :func:`checked_px4_params_text` atomically to ``path`` (a ``.params`` file); return the path.

    Nothing is written when a check refuses the calibration.

    Parameters
    ----------
    path : str or Path
        Output ``.params`` file.
    cals, **kwargs
        As :func:`px4_params_text`.

    Returns
    -------
    Path
        The file written.
    """
    return atomic_write_text(Path(path), checked_px4_params_text(cals, **kwargs))
