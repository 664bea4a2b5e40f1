"""Which IMU instances and device ids the firmwares can hold a calibration for."""

from __future__ import annotations

import numpy as np

from twin.errors import TwinError
from twin.firmware.ardupilot import AP_INSTANCES
from twin.firmware.common import DEVICE_ID_MAX
from twin.firmware.px4 import PX4_INSTANCES as PX4_SLOTS

# the instances each firmware has: PX4 TC_A0..TC_A3 (TemperatureCompensation.h, ACCEL_COUNT_MAX 4),
# ArduPilot INS_TCAL1..INS_TCAL3 (INS_MAX_INSTANCES 3) for IMU instances 0..2
PX4_INSTANCES = range(PX4_SLOTS)
ARDUPILOT_INSTANCES = range(AP_INSTANCES[1])  # IMU instance n → INS_TCAL{n + 1}
MAX_DEVICE_ID = DEVICE_ID_MAX  # device ids are uint32 in both firmwares


class CalibrationInputError(TwinError):
    """A log cannot be calibrated: too short, too narrow in temperature, NaN or frozen temperature."""


def check_calibration_instance(instance: int, where: str) -> None:
    """An IMU instance some firmware has a calibration slot for (PX4 0..3, ArduPilot 0..2 → INS_TCAL1..3).

    Parameters
    ----------
    instance : int
    where : str
        The log and IMU, for the error.
    """
    if instance not in PX4_INSTANCES:
        raise CalibrationInputError(f"{where}: IMU instance {instance}; PX4 has TC_A0..TC_A3 and ArduPilot "
                                    "INS_TCAL1..INS_TCAL3, so expected an instance 0..3")


def check_device_id(device_id, where: str) -> int | None:
    """A device id as both firmwares hold it (uint32), or None when unknown.

    Parameters
    ----------
    device_id : int or None
    where : str
        The log and IMU, for the error.

    Returns
    -------
    int or None
        None for unknown or 0 (the firmware's "no device").
    """
    if device_id is None:
        return None
    if isinstance(device_id, bool) or not isinstance(device_id, (int, np.integer)) or not 0 <= device_id <= MAX_DEVICE_ID:
        raise CalibrationInputError(f"{where}: device id {device_id!r}; expected an integer 0..{MAX_DEVICE_ID} (uint32)")
    return int(device_id) or None  # 0 is the firmware's "no device"
