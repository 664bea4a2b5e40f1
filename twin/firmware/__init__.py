"""Firmware-side temperature calibration: PX4 and ArduPilot methods for the accelerometer and the
gyro, a polynomial with held-out order selection, and exporters the firmware or ground station
reads (PX4 ``.params`` for QGroundControl, ArduPilot ``.parm``, versioned JSON, a C header), each
with a parser. Every writer checks each value as the firmware will hold it (float32, TMIN < TMAX,
degree, instance, PX4 device id) before any text exists; the ``.params``/``.parm`` writers read
their text back as the loader does before it is written. ``px4_vehicle_offsets`` and
``ardupilot_vehicle_offsets`` give what the vehicle applies along a log.

Pure numpy/scipy; depends only on ``twin.errors``, ``twin.io`` and ``twin.arrays``. Units: m/s², rad/s and °C
throughout (1 g = :data:`G0_M_S2` = 9.80665 m/s²).
"""

from twin.arrays import interleaved_folds  # the project's one fold builder, public here since firmware fits use it
from twin.firmware.ardupilot import (
                                     CALTEMP_UNSET_C,
                                     TEMP_RANGE_MIN_C,
                                     TEMP_REF_C,
                                     ArduPilotAccelCal,
                                     ArduPilotGyroCal,
                                     ardupilot_vehicle_correct,
                                     ardupilot_vehicle_offsets,
                                     firmware_correct_ardupilot,
                                     fit_ardupilot,
                                     fit_ardupilot_gyro,
)
from twin.firmware.ardupilot_parm import (
                                     ardupilot_cal_from_parm,
                                     ardupilot_parm_text,
                                     check_ardupilot_cal,
                                     checked_ardupilot_parm_text,
                                     parse_ardupilot_parm,
                                     read_ardupilot_parm,
                                     verify_ardupilot_parm,
                                     write_ardupilot_parm,
)
from twin.firmware.c_header import (
                                     c_header,
                                     die_temperature_lag,
                                     lag_alpha,
                                     write_c_header,
)
from twin.firmware.common import (
                                     AXES,
                                     FLOAT32_MAX,
                                     G0_M_S2,
                                     CalibrationFileError,
                                     CalibrationRangeError,
                                     ClampedPolynomial,
                                     FirmwareCalError,
                                     FirmwareValueError,
                                     FirmwareVerifyError,
                                     applied_vs_ideal,
                                     check_device_id_px4,
                                     check_float32,
)
from twin.firmware.json_cal import (
                                     SCHEMA_VERSION,
                                     JsonCalibration,
                                     cal_from_dict,
                                     cal_to_dict,
                                     read_json_cal,
                                     write_json_cal,
)
from twin.firmware.lag_header import lag_aware_c_header, write_lag_aware_c_header
from twin.firmware.polynomial import (
                                     HeldoutPolynomialFit,
                                     fit_polynomial_heldout,
)
from twin.firmware.px4 import (
                                     Px4AccelCal,
                                     Px4GyroCal,
                                     fit_px4,
                                     fit_px4_gyro,
                                     median_filter,
                                     median_filter_rows,
                                     resample_by_temperature,
)
from twin.firmware.px4_param_file import (
                                     Px4ParamFile,
                                     parse_px4_params,
                                     px4_cal_from_params,
                                     read_px4_params,
)
from twin.firmware.px4_params import (
                                     check_px4_cal,
                                     checked_px4_params_text,
                                     px4_cal_from_polynomial,
                                     px4_params_text,
                                     verify_px4_params,
                                     write_px4_params,
)
from twin.firmware.px4_vehicle import firmware_offset_px4, px4_republish_lag_c, px4_vehicle_offsets

__all__ = [
    "AXES", "CALTEMP_UNSET_C", "FLOAT32_MAX", "G0_M_S2", "SCHEMA_VERSION", "TEMP_RANGE_MIN_C", "TEMP_REF_C",
    "ArduPilotAccelCal", "ArduPilotGyroCal", "CalibrationFileError", "CalibrationRangeError", "ClampedPolynomial",
    "FirmwareCalError", "FirmwareValueError", "FirmwareVerifyError", "HeldoutPolynomialFit", "JsonCalibration",
    "Px4AccelCal", "Px4GyroCal", "Px4ParamFile",
    "applied_vs_ideal", "ardupilot_cal_from_parm", "ardupilot_parm_text", "ardupilot_vehicle_correct",
    "ardupilot_vehicle_offsets", "c_header", "cal_from_dict", "cal_to_dict", "check_ardupilot_cal",
    "check_device_id_px4", "check_float32", "check_px4_cal", "checked_ardupilot_parm_text",
    "checked_px4_params_text", "die_temperature_lag", "firmware_correct_ardupilot", "firmware_offset_px4",
    "fit_ardupilot", "fit_ardupilot_gyro", "fit_polynomial_heldout", "fit_px4", "fit_px4_gyro",
    "interleaved_folds", "lag_alpha", "lag_aware_c_header", "median_filter", "median_filter_rows",
    "parse_ardupilot_parm",
    "parse_px4_params", "px4_cal_from_params", "px4_cal_from_polynomial", "px4_params_text",
    "px4_republish_lag_c", "px4_vehicle_offsets", "read_ardupilot_parm", "read_json_cal", "read_px4_params",
    "resample_by_temperature", "verify_ardupilot_parm", "verify_px4_params", "write_ardupilot_parm",
    "write_c_header", "write_json_cal", "write_lag_aware_c_header", "write_px4_params",
]
