"""ArduPilot ``.parm`` files: check, write what Tools/scripts/tempcal_IMU.py writes, verify, parse
what ``param load`` reads, and turn the values back into a calibration.

Written lines (``Coefficients.param_string`` in tempcal_IMU.py, repo ArduPilot/ardupilot), one
``NAME VALUE`` per line: ``INS_TCALn_ENABLE 1``; ``INS_TCALn_TMIN``/``TMAX`` with ``%.1f``;
``INS_TCALn_ACC{k}_{X,Y,Z}`` (k = 1..3, X/Y/Z innermost) with ``%.9f`` of coefficient × 1e6;
then ``INS_TCALn_GYR{k}_{X,Y,Z}`` the same way. We write the gyro lines only for a gyro
calibration we fitted: without one there is no ``GYR`` line, so loading the file leaves the
board's gyro temperature calibration as it was (writing zeros would erase it; ``zero_gyro``
does that only on request). The board's gyro terms then apply over the new TMIN/TMAX, which the
IMU's accel and gyro share. A number whose ``%.9f``/``%.1f`` text would not load as the float32
of the value (a tiny coefficient, a TMIN such as 20.04) gets more decimals, still fixed-point.
The script does not write ``INS_ACCn_CALTEMP``/``INS_GYRn_CALTEMP`` (the ordinary calibrations
set them); we add them only on request.

Reading follows MAVProxy/pymavlink ``MAVParmDict.load`` (repo ArduPilot/pymavlink, mavparm.py):
strip; skip blank and ``#`` lines; commas become spaces (Mission Planner's ``NAME,VALUE``); exactly
two fields; value by ``float()`` (``0x`` hex as int). ArduPilot stores parameters as float32.
"""

from __future__ import annotations

import numbers
from collections.abc import Iterable, Mapping
from pathlib import Path

import numpy as np

from twin.firmware.ardupilot import (
    AP_INSTANCES,
    CALTEMP_UNSET_C,
    SCALE_FACTOR,
    SENSOR_TERM,
    TEMP_REF_C,
    ArduPilotAccelCal,
    ArduPilotGyroCal,
    ardupilot_vehicle_offsets,
)
from twin.firmware.common import (
    FLOAT32_EPS,
    CalibrationFileError,
    FirmwareValueError,
    FirmwareVerifyError,
    check_coefficients,
    check_float32,
    check_instance,
    check_temperature_range,
)
from twin.io import atomic_write_text, read_text

ApCal = ArduPilotAccelCal | ArduPilotGyroCal


def check_ardupilot_cal(cal) -> None:
    """Refuse a calibration ArduPilot could not hold, before any text is produced.

    Checks: an ArduPilotAccelCal/ArduPilotGyroCal; instance 1..3 (INS_TCAL1..3); TMIN < TMAX as
    float32; exactly 3 axes × 3 terms (ACC1..ACC3 or GYR1..GYR3, no constant), each × 1e6 a finite
    float32 (the stored value); the CALTEMP anchor a finite float32.

    Parameters
    ----------
    cal : ArduPilotAccelCal or ArduPilotGyroCal
        The calibration.

    Raises
    ------
    FirmwareValueError
        One line naming the parameter, the value and what was expected.
    """
    if not isinstance(cal, (ArduPilotAccelCal, ArduPilotGyroCal)):
        raise FirmwareValueError(f"an ArduPilot .parm takes ArduPilotAccelCal/ArduPilotGyroCal, got "
                                 f"{type(cal).__name__}; expected a fit_ardupilot or fit_ardupilot_gyro result")
    n = check_instance(cal.instance, *AP_INSTANCES, "INS_TCAL{}")
    check_temperature_range(cal.tmin_c, cal.tmax_c, None, f"INS_TCAL{n}_")
    term = SENSOR_TERM[cal.sensor]
    scaled = [[c * SCALE_FACTOR if isinstance(c, numbers.Real) else c for c in row] for row in cal.terms]
    check_coefficients(scaled, 3, lambda a, k: f"INS_TCAL{n}_{term}{k + 1}_{'XYZ'[a]}",
                       f"ArduPilot applies exactly {term}1..{term}3 (orders 1-3, no constant)", exact=True)
    check_float32(cal.cal_temp_c, cal.caltemp_name)


def parm_number(value: float, decimals: int) -> str:
    """Fixed-point text of ``value`` with ``decimals`` digits (the script's format) when that text
    loads as the float32 of ``value``; otherwise the fewest more decimals of that float32 that do.

    Parameters
    ----------
    value : float
        The value [any unit].
    decimals : int
        Digits after the point tempcal_IMU.py writes.

    Returns
    -------
    str
        The text.
    """
    held = np.float32(value)
    text = "%.*f" % (decimals, value)
    for d in range(decimals + 1, 80):
        if np.float32(float(text)) == held:
            return text
        text = "%.*f" % (d, float(held))
    return "%.9g" % float(held)  # subnormal float32: only exponent notation is short enough


def _pair(cals, gyro=None) -> list[tuple[ArduPilotAccelCal | None, ArduPilotGyroCal | None]]:
    """(accel, gyro) per IMU instance, in the order given; each checked."""
    def items(x):
        return [] if x is None else list(x) if isinstance(x, Iterable) and not isinstance(x, str) else [x]

    pairs: dict[int, list] = {}
    for cal in items(cals) + items(gyro):
        check_ardupilot_cal(cal)
        slot = pairs.setdefault(cal.instance, [None, None])
        i = 0 if cal.sensor == "accel" else 1
        if slot[i] is not None:
            raise CalibrationFileError(f"two {cal.sensor} calibrations for INS_TCAL{cal.instance}")
        slot[i] = cal
    if not pairs:
        raise FirmwareValueError("no accel or gyro calibration given; expected at least one to write")
    for n, (acc, gyr) in pairs.items():
        if acc is not None and gyr is not None and (np.float32(acc.tmin_c), np.float32(acc.tmax_c)) != (
                np.float32(gyr.tmin_c), np.float32(gyr.tmax_c)):
            raise FirmwareValueError(f"INS_TCAL{n}_TMIN/TMAX: accel {acc.tmin_c:g}..{acc.tmax_c:g} °C, gyro "
                                     f"{gyr.tmin_c:g}..{gyr.tmax_c:g} °C; the IMU holds one range for both, "
                                     "expected equal ones; fit both from the same log")
    return [tuple(v) for v in pairs.values()]


def ardupilot_parm_lines(cals, *, gyro=None, write_caltemp: bool = False,
                         zero_gyro: bool = False) -> list[tuple[str, float, str]]:
    """(NAME, value as ArduPilot holds it, text) per line, in tempcal_IMU.py's order, IMU by IMU.

    Parameters
    ----------
    cals : ArduPilotAccelCal or ArduPilotGyroCal, or an iterable of them
        Calibrations, several IMUs allowed.
    gyro : ArduPilotGyroCal or iterable of them, optional
        The IMUs' gyro calibrations.
    write_caltemp : bool
        Also write the CALTEMP anchors [°C].
    zero_gyro : bool
        Write ``INS_TCALn_GYR*`` as 0 for an IMU with no gyro calibration given (it erases the
        board's gyro temperature calibration: only on request).

    Returns
    -------
    list of tuple
        (name, float32 value [°C, or coefficient × 1e6 in m/s²/°C^k or rad/s/°C^k], text).
    """
    lines: list[tuple[str, float, str]] = []

    def add(name, value, decimals):
        lines.append((name, float(np.float32(value)), parm_number(value, decimals)))

    for acc, gyr in _pair(cals, gyro):
        first = acc if acc is not None else gyr
        n = first.instance
        lines.append((f"INS_TCAL{n}_ENABLE", 1.0, "1"))
        add(f"INS_TCAL{n}_TMIN", first.tmin_c, 1)
        add(f"INS_TCAL{n}_TMAX", first.tmax_c, 1)
        zeros = ((0.0,) * 3,) * 3
        for term, terms in (("ACC", acc.terms if acc else None),
                            ("GYR", gyr.terms if gyr else zeros if zero_gyro else None)):
            if terms is None:
                continue
            for k in range(3):
                for axis, name in enumerate("XYZ"):
                    add(f"INS_TCAL{n}_{term}{k + 1}_{name}", terms[axis][k] * SCALE_FACTOR, 9)
        if write_caltemp:
            for cal in (acc, gyr):
                if cal is not None:
                    add(cal.caltemp_name, cal.cal_temp_c, 2)  # %.2f as TCal::get_persistent_params
    return lines


def ardupilot_parm_text(cal, *, gyro=None, write_caltemp: bool = False, zero_gyro: bool = False) -> str:
    """The ``.parm`` text, line for line as tempcal_IMU.py ``param_string`` writes it.

    Parameters
    ----------
    cal : ArduPilotAccelCal or ArduPilotGyroCal, or an iterable of them
        Calibrations, several IMUs allowed.
    gyro : ArduPilotGyroCal or iterable of them, optional
        The IMU's fitted gyro terms (``INS_TCALn_GYR*``); without one, no ``GYR`` line at all.
    write_caltemp : bool
        Also write ``INS_ACC{n}_CALTEMP`` (and ``INS_GYR{n}_CALTEMP`` with a gyro), the anchors of
        the correction; off by default because the board's own calibrations own those values.
    zero_gyro : bool
        Write ``INS_TCALn_GYR*`` as 0 where no gyro calibration is given (erases the board's).

    Returns
    -------
    str
        ``NAME VALUE`` lines.

    Raises
    ------
    FirmwareValueError
        A value ArduPilot cannot hold (see :func:`check_ardupilot_cal`); no text is made.
    """
    lines = ardupilot_parm_lines(cal, gyro=gyro, write_caltemp=write_caltemp, zero_gyro=zero_gyro)
    return "".join(f"{name} {text}\n" for name, _, text in lines)


def _tolerance(cal: ApCal, grid: np.ndarray) -> np.ndarray:
    """Float32 error bound (n, 3) of P(clip T − 35) − P(clip T_cal − 35): 32 ulp of the sum of
    |terms| at both temperatures plus the slopes times the rounding of T, TMIN and TMAX."""
    c = np.abs(np.array(cal.terms, dtype=float))  # (3, 3): axis, power − 1
    total = np.zeros((grid.size, 3))
    for temp in (grid, np.full(grid.size, float(cal.cal_temp_c))):
        d = np.abs(np.clip(temp, cal.tmin_c, cal.tmax_c) - TEMP_REF_C)[:, None]
        terms = sum(c[:, k - 1] * d ** k for k in (1, 2, 3))
        slope = sum(k * c[:, k - 1] * d ** (k - 1) for k in (1, 2, 3))
        scale = np.abs(temp)[:, None] + abs(cal.tmin_c) + abs(cal.tmax_c) + TEMP_REF_C
        total += 32 * FLOAT32_EPS * terms + 4 * FLOAT32_EPS * scale * slope
    return total


def verify_ardupilot_parm(text: str, intended_cals, *, gyro=None, write_caltemp: bool = False,
                          zero_gyro: bool = False, source: str = "<parm>") -> dict[str, float]:
    """Parse ``text`` as ``param load`` does and check it is exactly the intended calibrations.

    Checks: the names are exactly the intended lines (no ``GYR`` line without a gyro
    calibration); each value equals the float32 of the intended value; ``TCal::correct_sensor``
    on the parsed values (:func:`~twin.firmware.ardupilot.ardupilot_vehicle_offsets`, anchored at
    each calibration's CALTEMP) reproduces the intended float64 offsets within float32
    evaluation error, 10 °C beyond the range included.

    Parameters
    ----------
    text : str
        The ``.parm`` text.
    intended_cals, gyro, write_caltemp, zero_gyro
        What the text was written from, as :func:`ardupilot_parm_lines`.
    source : str
        Name in messages.

    Returns
    -------
    dict
        The parsed values.

    Raises
    ------
    FirmwareVerifyError
        The first difference, as one line naming the parameter.
    """
    parsed = parse_ardupilot_parm(text, source)
    lines = ardupilot_parm_lines(intended_cals, gyro=gyro, write_caltemp=write_caltemp, zero_gyro=zero_gyro)
    expected = {name: value for name, value, _ in lines}
    extra = sorted(set(parsed) - set(expected))
    missing = sorted(set(expected) - set(parsed))
    if extra or missing:
        state = "unexpected" if extra else "missing"
        raise FirmwareVerifyError(f"{source}: parameters {extra or missing} are {state}; "
                                  "expected exactly the calibrated sensors' lines; regenerate the file")
    for name, value in expected.items():
        if parsed[name] != value:
            raise FirmwareVerifyError(f"{source}: {name} reads back as {parsed[name]!r}, the calibration holds "
                                      f"{value!r} as the firmware stores it; regenerate the file")
    for pair in _pair(intended_cals, gyro):
        for cal in (c for c in pair if c is not None):
            grid = np.unique(np.linspace(cal.tmin_c - 10, cal.tmax_c + 10, 401).astype(np.float32)).astype(float)
            firmware = ardupilot_vehicle_offsets(parsed, grid, cal.instance, cal.cal_temp_c, cal.sensor).astype(float)
            err = np.abs(firmware - cal.offset(grid)) - _tolerance(cal, grid)
            if np.max(err) > 0:
                i, a = np.unravel_index(np.argmax(err), err.shape)
                raise FirmwareVerifyError(f"{source}: INS_TCAL{cal.instance} {cal.sensor} axis {a} at {grid[i]:g} °C: "
                                          f"the firmware formula on the parsed values gives {firmware[i, a]:.9g}, "
                                          f"the calibration {cal.offset(grid)[i, a]:.9g}; regenerate the file")
    return parsed


def checked_ardupilot_parm_text(cals, *, gyro=None, write_caltemp: bool = False, zero_gyro: bool = False) -> str:
    """:func:`ardupilot_parm_text` for one or several IMUs, verified by :func:`verify_ardupilot_parm`
    before it is returned (the text to write atomically).

    Parameters
    ----------
    cals, gyro, write_caltemp, zero_gyro
        As :func:`ardupilot_parm_text`.

    Returns
    -------
    str
        The verified text.
    """
    text = ardupilot_parm_text(cals, gyro=gyro, write_caltemp=write_caltemp, zero_gyro=zero_gyro)
    verify_ardupilot_parm(text, cals, gyro=gyro, write_caltemp=write_caltemp, zero_gyro=zero_gyro)
    return text


def write_ardupilot_parm(path, cal, **kwargs) -> Path:
    """Write :func:`checked_ardupilot_parm_text` atomically to ``path`` (a ``.parm`` file); return the path.

    Nothing is written when a check refuses the calibration.

    Parameters
    ----------
    path : str or Path
        Output ``.parm`` file.
    cal : ArduPilotAccelCal or ArduPilotGyroCal, or an iterable of them
        Calibrations.
    **kwargs
        ``gyro``, ``write_caltemp``, ``zero_gyro`` of :func:`ardupilot_parm_text`.

    Returns
    -------
    Path
        The file written.
    """
    return atomic_write_text(Path(path), checked_ardupilot_parm_text(cal, **kwargs))


def parse_ardupilot_parm(text: str, source: str = "<parm>") -> dict[str, float]:
    """NAME → value (rounded to float32, as ArduPilot stores it), read as ``param load`` does.

    Lines MAVProxy would skip as invalid (not exactly two fields) raise here instead, naming the
    line, so a broken file is noticed.

    Parameters
    ----------
    text : str
        ``.parm`` text (``NAME VALUE`` or ``NAME,VALUE``; ``#`` comments).
    source : str
        Name in messages.

    Returns
    -------
    dict of str to float
        Values as float32 [each parameter's unit].
    """
    values: dict[str, float] = {}
    for number, raw in enumerate(text.splitlines(), 1):
        line = raw.strip()
        if not line or line[0] == "#":
            continue
        fields = line.replace(",", " ").split()
        if len(fields) != 2:
            raise CalibrationFileError(f"{source}:{number}: expected 'NAME VALUE', got {raw!r}")
        name, value = fields
        try:
            number_value = int(value[2:], 16) if value.lower().startswith("0x") else float(value)
        except ValueError:
            raise CalibrationFileError(f"{source}:{number}: value {value!r} of {name} is not a number") from None
        values[name] = float(np.float32(number_value))
    return values


def read_ardupilot_parm(path) -> dict[str, float]:
    """Read and parse a ``.parm`` file (see :func:`parse_ardupilot_parm`).

    Parameters
    ----------
    path : str or Path
        The file.

    Returns
    -------
    dict of str to float
        Values as float32 [each parameter's unit].
    """
    return parse_ardupilot_parm(read_text(path, "parameter file", CalibrationFileError), str(path))


def ardupilot_cal_from_parm(values: Mapping[str, float], instance: int = 1,
                            cal_temp_c: float | None = None, *, sensor: str = "accel") -> ApCal:
    """``INS_TCAL{instance}_*`` back as an :class:`ArduPilotAccelCal` (``ArduPilotGyroCal`` for
    ``sensor="gyro"``), coefficients ÷ 1e6.

    Parameters
    ----------
    values : mapping
        Parameter name → value.
    instance : int
        n in ``INS_TCALn``.
    cal_temp_c : float, optional
        Overrides ``INS_ACCn_CALTEMP`` / ``INS_GYRn_CALTEMP`` [°C]; without either, the unset
        −300 is used.
    sensor : {"accel", "gyro"}
        Which calibration.

    Returns
    -------
    ArduPilotAccelCal or ArduPilotGyroCal
        TMIN/TMAX [°C], coefficients [m/s²/°C^k or rad/s/°C^k], CALTEMP [°C].
    """
    if sensor not in SENSOR_TERM:
        raise FirmwareValueError(f"sensor {sensor!r} is not one ArduPilot compensates; expected 'accel' or 'gyro'")
    term = SENSOR_TERM[sensor]
    p = f"INS_TCAL{int(instance)}_"
    names = [p + "TMIN", p + "TMAX"] + [f"{p}{term}{k}_{a}" for k in (1, 2, 3) for a in "XYZ"]
    missing = [n for n in names if n not in values]
    if missing:
        raise CalibrationFileError(f"parameters missing for IMU {instance}: {', '.join(missing)}")
    terms = tuple(tuple(values[f"{p}{term}{k}_{a}"] / SCALE_FACTOR for k in (1, 2, 3)) for a in "XYZ")
    if cal_temp_c is None:
        cal_temp_c = values.get(f"INS_{term}{int(instance)}_CALTEMP", CALTEMP_UNSET_C)
    cls = ArduPilotGyroCal if sensor == "gyro" else ArduPilotAccelCal
    return cls(int(instance), float(values[p + "TMIN"]), float(values[p + "TMAX"]), terms, float(cal_temp_c))
