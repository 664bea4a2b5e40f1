"""Firmware-side accelerometer temperature calibration: PX4 and ArduPilot methods, a polynomial
with held-out order selection, and exporters the firmware or ground station reads (PX4 ``.params``
for QGroundControl, ArduPilot ``.parm``, versioned JSON, a C header), each with a parser.

Pure numpy/scipy; depends only on ``twin.errors`` and ``twin.io``. Units: m/s² and °C throughout
(1 g = :data:`G0_M_S2` = 9.80665 m/s²).
"""

from twin.firmware.ardupilot import (
                                     CALTEMP_UNSET_C,
                                     TEMP_RANGE_MIN_C,
                                     TEMP_REF_C,
                                     ArduPilotAccelCal,
                                     firmware_correct_ardupilot,
                                     fit_ardupilot,
)
from twin.firmware.ardupilot_parm import (
                                     ardupilot_cal_from_parm,
                                     ardupilot_parm_text,
                                     parse_ardupilot_parm,
                                     read_ardupilot_parm,
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
                                     G0_M_S2,
                                     CalibrationFileError,
                                     CalibrationRangeError,
                                     ClampedPolynomial,
                                     FirmwareCalError,
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
                                     interleaved_folds,
)
from twin.firmware.px4 import (
                                     Px4AccelCal,
                                     firmware_offset_px4,
                                     fit_px4,
                                     median_filter,
                                     resample_by_temperature,
)
from twin.firmware.px4_params import (
                                     Px4ParamFile,
                                     parse_px4_params,
                                     px4_cal_from_params,
                                     px4_params_text,
                                     read_px4_params,
                                     write_px4_params,
)

__all__ = [
    "AXES", "CALTEMP_UNSET_C", "G0_M_S2", "SCHEMA_VERSION", "TEMP_RANGE_MIN_C", "TEMP_REF_C",
    "ArduPilotAccelCal", "CalibrationFileError", "CalibrationRangeError", "ClampedPolynomial", "FirmwareCalError",
    "HeldoutPolynomialFit", "JsonCalibration", "Px4AccelCal", "Px4ParamFile",
    "ardupilot_cal_from_parm", "ardupilot_parm_text", "c_header", "cal_from_dict", "cal_to_dict",
    "die_temperature_lag", "firmware_correct_ardupilot", "firmware_offset_px4", "fit_ardupilot",
    "fit_polynomial_heldout", "fit_px4", "interleaved_folds", "lag_alpha", "lag_aware_c_header", "median_filter",
    "parse_ardupilot_parm", "parse_px4_params", "px4_cal_from_params", "px4_params_text",
    "read_ardupilot_parm", "read_json_cal", "read_px4_params", "resample_by_temperature",
    "write_ardupilot_parm", "write_c_header", "write_json_cal", "write_lag_aware_c_header", "write_px4_params",
]
