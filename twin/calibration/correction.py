"""What a stored calibration method subtracts from a reading: one implementation of the arithmetic
that ``twin apply``, the exporters' checks, the plausibility flags and the tests all use."""

from __future__ import annotations

import numpy as np

from twin.calibration.lag import as_log, lagged_c, make_X
from twin.errors import TwinError
from twin.firmware import G0_M_S2, cal_from_dict


class CalibrationDocumentError(TwinError):
    """A calibration document is unreadable, of another schema, or lacks what is asked of it."""


def firmware_cal(data: dict, name: str):
    """The firmware calibration object (PX4 or ArduPilot) a stored method holds.

    Parameters
    ----------
    data : dict
        The stored method (``kind`` must be ``"firmware"``).
    name : str
        Method name, for messages.

    Returns
    -------
    object
        The PX4 or ArduPilot calibration (:func:`twin.firmware.cal_from_dict`).

    Raises
    ------
    CalibrationDocumentError
        When the method is not a firmware polynomial.
    """
    if data.get("kind") != "firmware":
        raise CalibrationDocumentError(f"method {name!r} is not a firmware polynomial")
    return cal_from_dict(data["firmware"], name)


def correction_g(data: dict, time_s, temperature_c, run=None) -> np.ndarray:
    """What a method subtracts from the reading [g], (n, 3).

    Firmware polynomials give the firmware's own offset (the clamped polynomial of PX4
    ``TemperatureCompensation::calc_thermal_offsets_3D`` / ArduPilot ``TCal::correct_sensor``,
    :mod:`twin.firmware`); the lag-aware twin gives its modelled
    drift minus its level (the constant the ordinary accelerometer calibration owns). A polynomial
    without lags (``tau_die_s`` absent) is evaluated in the raw temperature.

    Parameters
    ----------
    data : dict
        The stored method.
    time_s, temperature_c : (n,) array-like
        Sample times [s] and temperatures [°C].
    run : (n,) array-like of int, optional
        Run id per sample (lags restart at each run).

    Returns
    -------
    (n, 3) ndarray
        Correction [g].
    """
    T = np.asarray(temperature_c, float)
    if data.get("kind") == "firmware":
        return firmware_cal(data, "firmware").offset_m_s2(T) / G0_M_S2
    if data.get("kind") == "ComposedCompensator":
        from twin.calibration.composed import composed_drift_g

        return composed_drift_g(data["axes"], data["reference_c"], time_s, T, run)
    coef = np.asarray(data["coef_mg"], float)
    out = np.empty((T.size, coef.shape[0]))
    log = as_log(make_X(np.asarray(time_s, float), T, run))
    tau_die = data.get("tau_die_s")
    for a in range(coef.shape[0]):
        arg = (lagged_c(log, tau_die[a]) if tau_die is not None else T) - data["reference_c"]
        out[:, a] = np.polyval(coef[a, ::-1], arg) - coef[a, 0]
        tau_rate = (data.get("tau_rate_s") or [None] * 3)[a]
        if tau_rate is not None:
            out[:, a] += data["rate_mg_per_c"][a] * (T - lagged_c(log, tau_rate))
    return out * 1e-3
