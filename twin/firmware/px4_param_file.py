"""PX4 ``.params`` files read back: the text parsed as QGroundControl loads it, and the
``TC_A``/``TC_G`` parameters turned back into a calibration.

Format (QGroundControl ``ParameterManager::readParametersFromStream``, repo mavlink/qgroundcontrol):
``#`` lines are comments; every other row is ``vehicle<TAB>component<TAB>NAME<TAB>VALUE<TAB>TYPE``
with TYPE a MAV_PARAM_TYPE (6 = INT32, 9 = REAL32). Writing, and verifying a written text against
the intended calibration, is :mod:`twin.firmware.px4_params`.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np

from twin.firmware.common import CalibrationFileError
from twin.firmware.px4 import SENSOR_PREFIX, Px4AccelCal, Px4GyroCal, check_sensor
from twin.io import read_text

MAV_PARAM_TYPE_INT32 = 6
MAV_PARAM_TYPE_REAL32 = 9
MAV_PARAM_TYPE_REAL64 = 10


@dataclass(frozen=True)
class Px4ParamFile:
    """A parsed ``.params`` file: values as the firmware holds them, with their MAVLink types.

    Attributes
    ----------
    values : dict
        NAME → int (integer types) or float (REAL32 values are rounded to float32, as stored).
    types : dict
        NAME → MAV_PARAM_TYPE.
    vehicle_id, component_id : int
        From the rows (all rows must agree).
    comments : tuple of str
        The ``#`` lines, in order.
    """

    values: dict
    types: dict
    vehicle_id: int
    component_id: int
    comments: tuple[str, ...]


def _value(text: str, ptype: int, where: str) -> int | float:
    try:
        if ptype == MAV_PARAM_TYPE_REAL32:
            return float(np.float32(float(text)))  # the firmware stores REAL32 parameters as float
        if ptype == MAV_PARAM_TYPE_REAL64:
            return float(text)
        if 1 <= ptype <= 8:
            return int(text)
    except ValueError:
        raise CalibrationFileError(f"{where}: value {text!r} is not a number of MAV_PARAM_TYPE {ptype}") from None
    raise CalibrationFileError(f"{where}: unknown MAV_PARAM_TYPE {ptype} (QGC reads 1..10)")


def parse_px4_params(text: str, source: str = "<params>") -> Px4ParamFile:
    """Parse QGC ``.params`` text the way ``ParameterManager::readParametersFromStream`` reads it.

    ``#`` lines are comments; every other non-blank line must have exactly 5 tab-separated fields
    (QGC silently skips other lines; we raise, naming the line, so a broken export is noticed).

    Parameters
    ----------
    text : str
        The ``.params`` text.
    source : str
        Name in messages.

    Returns
    -------
    Px4ParamFile
        Values [each parameter's unit], types, ids and comments.
    """
    values, types, comments, ids = {}, {}, [], set()
    for number, line in enumerate(text.splitlines(), 1):
        where = f"{source}:{number}"
        if line.startswith("#"):
            comments.append(line)
            continue
        if not line.strip():
            continue
        fields = line.split("\t")
        if len(fields) != 5:
            raise CalibrationFileError(f"{where}: {len(fields)} tab-separated fields, QGC needs 5 "
                                       "(Vehicle-Id Component-Id Name Value Type)")
        try:
            vid, cid, ptype = int(fields[0]), int(fields[1]), int(fields[4])
        except ValueError:
            raise CalibrationFileError(f"{where}: Vehicle-Id, Component-Id and Type must be integers") from None
        name = fields[2]
        if name in values:
            raise CalibrationFileError(f"{where}: parameter {name} appears twice")
        values[name] = _value(fields[3], ptype, where)
        types[name] = ptype
        ids.add((vid, cid))
    if len(ids) > 1:
        raise CalibrationFileError(f"{source}: rows for several vehicle/component ids {sorted(ids)}")
    vid, cid = next(iter(ids)) if ids else (1, 1)
    return Px4ParamFile(values, types, vid, cid, tuple(comments))


def read_px4_params(path) -> Px4ParamFile:
    """Read and parse a QGC ``.params`` file (see :func:`parse_px4_params`).

    Parameters
    ----------
    path : str or Path
        The file.

    Returns
    -------
    Px4ParamFile
        As :func:`parse_px4_params`.
    """
    return parse_px4_params(read_text(path, "parameter file", CalibrationFileError), str(path))


def px4_cal_from_params(values: Mapping[str, float], instance: int = 0, *, sensor: str = "accel") -> Px4AccelCal | Px4GyroCal:
    """The ``TC_A{instance}_*`` (or ``TC_G{instance}_*``) parameters back as a calibration (float32 values).

    Parameters
    ----------
    values : mapping
        Parameter name → value.
    instance : int
        n in ``TC_An``/``TC_Gn``.
    sensor : {"accel", "gyro"}
        Which parameters.

    Returns
    -------
    Px4AccelCal or Px4GyroCal
        TMIN/TMAX/TREF [°C] and X0..X3 [m/s² or rad/s per °C^k].
    """
    kind = check_sensor(sensor)
    p = f"{SENSOR_PREFIX[kind]}{int(instance)}_"
    names = [p + k for k in ("ID", "TMIN", "TMAX", "TREF")] + [f"{p}X{k}_{i}" for i in range(3) for k in range(4)]
    missing = [n for n in names if n not in values]
    if missing:
        raise CalibrationFileError(f"parameters missing for {kind} instance {instance}: {', '.join(missing)}")
    x = tuple(tuple(float(values[f"{p}X{k}_{i}"]) for k in range(4)) for i in range(3))
    device_id = int(np.int32(values[p + "ID"]).view(np.uint32))
    cls = Px4GyroCal if kind == "gyro" else Px4AccelCal
    return cls(int(instance), device_id, float(values[p + "TMIN"]), float(values[p + "TMAX"]),
               float(values[p + "TREF"]), x)
