"""ArduPilot ``.parm`` files: write what Tools/scripts/tempcal_IMU.py writes, parse what
``param load`` reads, and turn the values back into a calibration.

Written lines (``Coefficients.param_string`` in tempcal_IMU.py, repo ArduPilot/ardupilot), one
``NAME VALUE`` per line: ``INS_TCALn_ENABLE 1``; ``INS_TCALn_TMIN``/``TMAX`` with ``%.1f``;
``INS_TCALn_ACC{k}_{X,Y,Z}`` (k = 1..3, X/Y/Z innermost) with ``%.9f`` of coefficient × 1e6;
then ``INS_TCALn_GYR{k}_{X,Y,Z}`` the same way. We fit only the accelerometer, so the gyro terms
are written as 0 (leaving them out would keep whatever the board holds, applied over the new
range). The script does not write ``INS_ACCn_CALTEMP`` (the accel calibration sets it); we add it
only on request.

Reading follows MAVProxy/pymavlink ``MAVParmDict.load`` (repo ArduPilot/pymavlink, mavparm.py):
strip; skip blank and ``#`` lines; commas become spaces (Mission Planner's ``NAME,VALUE``); exactly
two fields; value by ``float()`` (``0x`` hex as int). ArduPilot stores parameters as float32.
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path

import numpy as np

from twin.firmware.ardupilot import CALTEMP_UNSET_C, SCALE_FACTOR, ArduPilotAccelCal
from twin.firmware.common import CalibrationFileError
from twin.io import atomic_write_text, read_text


def ardupilot_parm_text(cal: ArduPilotAccelCal, *, write_caltemp: bool = False, zero_gyro: bool = True) -> str:
    """The ``.parm`` text for one IMU, line for line as tempcal_IMU.py ``param_string`` writes it.

    Parameters
    ----------
    cal : ArduPilotAccelCal
    write_caltemp : bool
        Also write ``INS_ACC{n}_CALTEMP`` (the anchor of the correction); off by default because
        the board's own accel calibration owns that value.
    zero_gyro : bool
        Write ``INS_TCALn_GYR*`` as 0 (the script writes its gyro fit there).
    """
    n = cal.instance
    lines = [f"INS_TCAL{n}_ENABLE 1", "INS_TCAL%u_TMIN %.1f" % (n, cal.tmin_c),
             "INS_TCAL%u_TMAX %.1f" % (n, cal.tmax_c)]
    for k in range(3):
        for axis, name in enumerate("XYZ"):
            lines.append("INS_TCAL%u_ACC%u_%s %.9f" % (n, k + 1, name, cal.acc[axis][k] * SCALE_FACTOR))
    if zero_gyro:
        for k in range(3):
            for name in "XYZ":
                lines.append("INS_TCAL%u_GYR%u_%s %.9f" % (n, k + 1, name, 0.0))
    if write_caltemp:
        lines.append("INS_ACC%u_CALTEMP %.2f" % (n, cal.cal_temp_c))  # %.2f as get_persistent_params
    return "\n".join(lines) + "\n"


def write_ardupilot_parm(path, cal: ArduPilotAccelCal, **kwargs) -> Path:
    """Write :func:`ardupilot_parm_text` atomically to ``path`` (a ``.parm`` file); return the path."""
    return atomic_write_text(Path(path), ardupilot_parm_text(cal, **kwargs))


def parse_ardupilot_parm(text: str, source: str = "<parm>") -> dict[str, float]:
    """NAME → value (rounded to float32, as ArduPilot stores it), read as ``param load`` does.

    Lines MAVProxy would skip as invalid (not exactly two fields) raise here instead, naming the
    line, so a broken file is noticed.
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
    """Read and parse a ``.parm`` file (see :func:`parse_ardupilot_parm`)."""
    return parse_ardupilot_parm(read_text(path, "parameter file", CalibrationFileError), str(path))


def ardupilot_cal_from_parm(values: Mapping[str, float], instance: int = 1,
                            cal_temp_c: float | None = None) -> ArduPilotAccelCal:
    """``INS_TCAL{instance}_*`` back as an :class:`ArduPilotAccelCal` (coefficients ÷ 1e6).

    ``cal_temp_c`` overrides ``INS_ACCn_CALTEMP``; without either, the unset −300 is used.
    """
    p = f"INS_TCAL{int(instance)}_"
    names = [p + "TMIN", p + "TMAX"] + [f"{p}ACC{k}_{a}" for k in (1, 2, 3) for a in "XYZ"]
    missing = [n for n in names if n not in values]
    if missing:
        raise CalibrationFileError(f"parameters missing for IMU {instance}: {', '.join(missing)}")
    acc = tuple(tuple(values[f"{p}ACC{k}_{a}"] / SCALE_FACTOR for k in (1, 2, 3)) for a in "XYZ")
    if cal_temp_c is None:
        cal_temp_c = values.get(f"INS_ACC{int(instance)}_CALTEMP", CALTEMP_UNSET_C)
    return ArduPilotAccelCal(int(instance), float(values[p + "TMIN"]), float(values[p + "TMAX"]), acc,
                             float(cal_temp_c))
