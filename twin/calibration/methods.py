"""The flight controllers' own fits as compensators, so they are validated like every other method.

:class:`Px4Method` wraps :func:`twin.firmware.fit_px4` (PX4 Tools/process_sensor_caldata.py) and
:class:`ArduPilotMethod` wraps :func:`twin.firmware.fit_ardupilot` (ArduPilot
Tools/scripts/tempcal_IMU.py). Both remove only the temperature dependence (the level is the
firmware's ordinary accelerometer calibration); for a fair held-out RMS each adds the mean level
of its training rows, like the constant term of the other compensators.
"""

from __future__ import annotations

import numpy as np

from twin.calibration.lag import as_log, train_mask
from twin.calibration.models import AXES, CompensatorBase
from twin.firmware import G0_M_S2, fit_ardupilot, fit_px4


class _FirmwareMethod(CompensatorBase):
    """Fit on the training rows with the firmware tool's method; predict = level + its offset(T)."""

    def _fit_cal(self, time_s, temperature_c, accel_m_s2):  # pragma: no cover - subclasses
        raise NotImplementedError

    def fit(self, X, y, mask=None):
        """Fit on the rows of ``mask`` (a contiguous branch, as the tools expect). Returns self."""
        log = as_log(X)
        keep = train_mask(y, log.time_s.size, mask)
        y = np.asarray(y, float)
        self.cal_ = self._fit_cal(log.time_s[keep], log.temperature_c[keep], y[keep] * G0_M_S2)
        self.level_g_ = np.mean(y[keep] - self.cal_.offset_m_s2(log.temperature_c[keep]) / G0_M_S2, axis=0)
        return self

    def predict(self, X) -> np.ndarray:
        """Modelled reading [g], (n, 3): the training level plus the firmware's offset at T."""
        return self.level_g_ + self.cal_.offset_m_s2(as_log(X).temperature_c) / G0_M_S2

    def compensate(self, X, accel_g: np.ndarray) -> np.ndarray:
        """What the firmware outputs: ``accel_g`` minus its thermal offset [g]."""
        return np.asarray(accel_g, float) - self.cal_.offset_m_s2(as_log(X).temperature_c) / G0_M_S2

    def equation(self) -> str:
        """The fitted offset polynomial per axis, as the firmware evaluates it [m/s²]."""
        p = self.cal_.polynomial
        return "\n".join(f"{ax}: offset = " + " ".join(f"{c:+.6g}·(T − {p.tref_c:g} °C)^{k}" for k, c in
                                                       enumerate(p.coefficients[a])) + " m/s², T clipped to "
                         f"[{p.tmin_c:.1f}, {p.tmax_c:.1f}] °C" for a, ax in enumerate(AXES))


class Px4Method(_FirmwareMethod):
    """PX4's accelerometer thermal calibration (``TC_A{instance}_*``).

    Parameters
    ----------
    instance : int
        n in ``TC_An`` (0..3).
    device_id : int
        ``TC_An_ID``.
    """

    def __init__(self, instance: int = 0, device_id: int = 0):
        self.instance = instance
        self.device_id = device_id

    def _fit_cal(self, time_s, temperature_c, accel_m_s2):
        return fit_px4(temperature_c, accel_m_s2, device_id=self.device_id, instance=self.instance)


class ArduPilotMethod(_FirmwareMethod):
    """ArduPilot's IMU temperature calibration (``INS_TCAL{instance}_*``).

    Parameters
    ----------
    instance : int
        n in ``INS_TCALn`` (1..3).
    """

    def __init__(self, instance: int = 1):
        self.instance = instance

    def _fit_cal(self, time_s, temperature_c, accel_m_s2):
        return fit_ardupilot(temperature_c, accel_m_s2, time_s=time_s, instance=self.instance)
