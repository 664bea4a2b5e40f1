"""PX4 ``.params`` files in QGroundControl's format: write, parse, and turn back into a calibration.

Format (QGroundControl ``ParameterManager::writeParametersToStream`` / ``readParametersFromStream``,
repo mavlink/qgroundcontrol): ``#`` comment lines — ``# Onboard parameters for Vehicle 1``, ``#``,
``# Stack: …``, ``# Vehicle: …``, ``# Version: …``, ``# Git Revision: …``, ``#``, then
``# Vehicle-Id Component-Id Name Value Type`` — and one row per parameter,
``vehicle<TAB>component<TAB>NAME<TAB>VALUE<TAB>TYPE``. QGC reads only rows of exactly 5 tab-separated
fields; TYPE is a MAV_PARAM_TYPE (6 = INT32, 9 = REAL32). process_sensor_caldata.py (repo
PX4/PX4-Autopilot) writes ``TC_An_ID`` as type 6 and every other ``TC_An_*`` as type 9, in the
order ID, TMIN, TMAX, TREF, X0_0, X1_0, X2_0, X3_0, X0_1 … X3_2. It does not write
``TC_A_ENABLE`` (its step 1 sets it on the board); we add it (INT32) unless told not to, since the
firmware ignores every ``TC_A*`` parameter while it is 0.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from twin.firmware.common import CalibrationFileError, float32_text
from twin.firmware.px4 import Px4AccelCal
from twin.io import atomic_write_text, read_text

MAV_PARAM_TYPE_INT32 = 6
MAV_PARAM_TYPE_REAL32 = 9
MAV_PARAM_TYPE_REAL64 = 10
HEADER_LAST = "# Vehicle-Id Component-Id Name Value Type"


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


def px4_param_rows(cals: Iterable[Px4AccelCal], include_enable: bool = True) -> list[tuple[str, str, int]]:
    """(NAME, VALUE text, TYPE) rows in process_sensor_caldata.py's order, ``TC_A_ENABLE`` first."""
    rows: list[tuple[str, str, int]] = []
    if include_enable:
        rows.append(("TC_A_ENABLE", "1", MAV_PARAM_TYPE_INT32))
    for cal in cals:
        p = f"TC_A{cal.instance}_"
        # device ids are uint32 in the firmware and int32 parameters: store the same 32 bits
        rows.append((p + "ID", str(int(np.uint32(cal.device_id).view(np.int32))), MAV_PARAM_TYPE_INT32))
        for key, value in (("TMIN", cal.tmin_c), ("TMAX", cal.tmax_c), ("TREF", cal.tref_c)):
            rows.append((p + key, float32_text(value), MAV_PARAM_TYPE_REAL32))
        for axis in range(3):
            for k in range(4):
                rows.append((f"{p}X{k}_{axis}", float32_text(cal.x[axis][k]), MAV_PARAM_TYPE_REAL32))
    return rows


def px4_params_text(cals: Px4AccelCal | Iterable[Px4AccelCal], *, vehicle_id: int = 1, component_id: int = 1,
                    include_enable: bool = True, stack: str = "PX4 Pro", vehicle: str = "unknown",
                    version: str = "unknown", git_revision: str = "unknown",
                    comments: Iterable[str] = ("Sensor thermal compensation parameters",)) -> str:
    """The ``.params`` text QGroundControl loads (header as QGC writes it, tab-separated rows).

    Parameters
    ----------
    cals : Px4AccelCal or iterable of them
        One calibration per accel instance (instances must differ).
    vehicle_id, component_id : int
        MAVLink system and component ids of the rows (QGC refuses a file whose system id differs
        from the connected vehicle's).
    stack, vehicle, version, git_revision : str
        The informational header lines QGC writes (QGC ignores ``#`` lines on load).
    comments : iterable of str
        Extra ``#`` lines placed before the final column-header line (e.g. provenance); the
        default is the first line process_sensor_caldata.py writes.
    """
    cal_list = [cals] if isinstance(cals, Px4AccelCal) else list(cals)
    instances = [c.instance for c in cal_list]
    if len(set(instances)) != len(instances):
        raise CalibrationFileError(f"two calibrations for the same TC_A instance: {instances}")
    lines = [f"# Onboard parameters for Vehicle {int(vehicle_id)}", "#", f"# Stack: {stack}",
             f"# Vehicle: {vehicle}", f"# Version: {version}", f"# Git Revision: {git_revision}", "#"]
    extra = [f"# {c}" for c in comments]
    lines += extra + (["#"] if extra else []) + [HEADER_LAST]
    lines += [f"{int(vehicle_id)}\t{int(component_id)}\t{name}\t{value}\t{ptype}"
              for name, value, ptype in px4_param_rows(cal_list, include_enable)]
    return "\n".join(lines) + "\n"


def write_px4_params(path, cals: Px4AccelCal | Iterable[Px4AccelCal], **kwargs) -> Path:
    """Write :func:`px4_params_text` atomically to ``path`` (a ``.params`` file); return the path."""
    return atomic_write_text(Path(path), px4_params_text(cals, **kwargs))


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
    """Read and parse a QGC ``.params`` file (see :func:`parse_px4_params`)."""
    return parse_px4_params(read_text(path, "parameter file", CalibrationFileError), str(path))


def px4_cal_from_params(values: Mapping[str, float], instance: int = 0) -> Px4AccelCal:
    """The ``TC_A{instance}_*`` parameters back as a :class:`Px4AccelCal` (float32 values)."""
    p = f"TC_A{int(instance)}_"
    names = [p + k for k in ("ID", "TMIN", "TMAX", "TREF")] + [f"{p}X{k}_{i}" for i in range(3) for k in range(4)]
    missing = [n for n in names if n not in values]
    if missing:
        raise CalibrationFileError(f"parameters missing for accel instance {instance}: {', '.join(missing)}")
    x = tuple(tuple(float(values[f"{p}X{k}_{i}"]) for k in range(4)) for i in range(3))
    device_id = int(np.int32(values[p + "ID"]).view(np.uint32))
    return Px4AccelCal(int(instance), device_id, float(values[p + "TMIN"]), float(values[p + "TMAX"]),
                       float(values[p + "TREF"]), x)
