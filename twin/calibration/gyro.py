"""The gyro of one IMU calibrated by the PX4 and ArduPilot methods, validated like the accelerometer."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from sklearn.base import clone

from twin.calibration.document import AS_APPLIED
from twin.calibration.instances import ARDUPILOT_INSTANCES, check_device_id
from twin.calibration.methods import ArduPilotGyroMethod, ArduPilotMethod, AsTheVehicleApplies, Px4GyroMethod, Px4Method
from twin.calibration.models import AXES
from twin.calibration.validate import ValidationResult, validate
from twin.measurement import ImuLog

# a still MEMS gyro: zero-rate offset within a few °/s and a bias tempco of a few hundredths of
# °/s per °C (e.g. ±0.05 °/s/°C class parts); ten times those is not temperature drift
GYRO_MAX_BIAS_RAD_S = np.radians(10.0)
GYRO_MAX_SLOPE_RAD_S_PER_C = np.radians(0.5)


@dataclass(frozen=True, eq=False)
class GyroCalibration:
    """The gyro of one IMU: the firmware methods fitted on its still rows and validated held out.

    Attributes
    ----------
    device_id : int or None
        The gyro's device id (PX4 ``TC_Gn_ID``).
    validation : ValidationResult
        Held-out RMS in mrad/s (the ``_mg`` figures are thousandths of the unit: rad/s here).
    fitted : dict
        Method name → estimator fitted on every row.
    flags : dict
        Method name → why it is implausible.
    """

    device_id: int | None
    validation: ValidationResult
    fitted: dict
    flags: dict

    def recommended(self) -> dict[str, str | None]:
        """Per firmware, its own method unless flagged.

        Returns
        -------
        dict of str to str or None
        """
        return {t: (t if t in self.fitted and not self.flags.get(t) else None) for t in ("px4", "ardupilot")}


def as_applied(models: dict) -> dict:
    """The firmware methods again, scored as the vehicle applies the file written for them.

    Parameters
    ----------
    models : dict of str to estimator
        Method name → unfitted method; only PX4 and ArduPilot ones are wrapped.

    Returns
    -------
    dict of str to AsTheVehicleApplies
        ``<name>_as_applied`` → the wrapped method.
    """
    return {f"{name}{AS_APPLIED}": AsTheVehicleApplies(est) for name, est in models.items()
            if isinstance(est, (Px4Method, ArduPilotMethod))}


def calibrate_gyro(log: ImuLog, X: np.ndarray, gyro_rad_s: np.ndarray, protocol, run=None) -> GyroCalibration:
    """The gyro's temperature calibration by the PX4 and ArduPilot methods, validated like the accelerometer's.

    On the same rows and folds as the accelerometer (the gyro shares the IMU's die and thermometer).

    Parameters
    ----------
    log : ImuLog
        The log (its instance and gyro device id).
    X : ndarray
        The log's design ``[time_s, temperature_c(, run)]`` on the rows fitted.
    gyro_rad_s : ndarray
        Angular rate on those rows, (n, 3) [rad/s].
    protocol : Protocol
        The held-out folds.
    run : ndarray, optional
        Run index of each row.

    Returns
    -------
    GyroCalibration
    """
    device = check_device_id(log.gyro_device_id, f"{log.source} instance {log.instance} gyro")
    models = {"px4": Px4GyroMethod(instance=log.instance, device_id=int(device or 0))}
    if log.instance in ARDUPILOT_INSTANCES:
        models["ardupilot"] = ArduPilotGyroMethod(instance=log.instance + 1)
    validation = validate({**models, **as_applied(models)}, X[:, 0], X[:, 1], gyro_rad_s, protocol, run=run)
    fitted = {name: clone(est).fit(X, gyro_rad_s) for name, est in models.items()}
    span = (float(X[:, 1].min()), float(X[:, 1].max()))
    flags = {name: gyro_flags(name, est, span) for name, est in fitted.items()}
    return GyroCalibration(device, validation, fitted, flags)


def gyro_flags(name: str, est, span_c: tuple[float, float]) -> list[str]:
    """Why a gyro fit is implausible: a bias slope or a level a still MEMS gyro does not have.

    Parameters
    ----------
    name : str
        The method.
    est : Px4GyroMethod or ArduPilotGyroMethod
        Fitted.
    span_c : tuple of float
        The temperatures fitted [°C].

    Returns
    -------
    list of str
        One line per reason (empty when plausible).
    """
    temperature_c = np.linspace(*span_c, 64)
    curve = est.cal_.offset(temperature_c)
    flags = []
    if not np.all(np.isfinite(curve)):
        return [f"gyro {name}: correction not finite over {span_c[0]:.1f}..{span_c[1]:.1f} °C"]
    slope = np.max(np.abs(np.gradient(curve, temperature_c, axis=0)), axis=0)
    level = np.abs(np.asarray(est.level_g_) + curve.mean(axis=0))
    for axis, s, g in zip(AXES, slope, level):
        if s > GYRO_MAX_SLOPE_RAD_S_PER_C:
            flags.append(f"gyro {name} {axis}: bias slope up to {np.degrees(s):.2f} °/s/°C, beyond "
                         f"{np.degrees(GYRO_MAX_SLOPE_RAD_S_PER_C):.2f} °/s/°C")
        if g > GYRO_MAX_BIAS_RAD_S:
            flags.append(f"gyro {name} {axis}: bias {np.degrees(g):.1f} °/s; a still MEMS gyro's zero-rate "
                         f"offset is within about ±{np.degrees(GYRO_MAX_BIAS_RAD_S):.0f} °/s")
    return flags
