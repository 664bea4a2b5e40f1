"""The flight controllers' own fits as compensators, so they are validated like every other method.

:class:`Px4Method` wraps :func:`twin.firmware.fit_px4` (PX4 Tools/process_sensor_caldata.py) and
:class:`ArduPilotMethod` wraps :func:`twin.firmware.fit_ardupilot` (ArduPilot
Tools/scripts/tempcal_IMU.py). Both remove only the temperature dependence (the level is the
firmware's ordinary accelerometer calibration); for a fair held-out RMS each adds the mean level
of its training rows, like the constant term of the other compensators.
"""

from __future__ import annotations

import dataclasses

import numpy as np
from sklearn.base import clone
from sklearn.utils.validation import check_is_fitted

from twin.calibration.lag import fit_inputs, validated_log
from twin.calibration.models import AXES, CompensatorBase
from twin.firmware import (
    G0_M_S2,
    ardupilot_vehicle_offsets,
    checked_ardupilot_parm_text,
    checked_px4_params_text,
    fit_ardupilot,
    fit_ardupilot_gyro,
    fit_px4,
    fit_px4_gyro,
    median_filter,
    median_filter_rows,
    parse_ardupilot_parm,
    parse_px4_params,
    px4_vehicle_offsets,
)

# the firmwares work in SI units: the accelerometer methods take g and hand the fit m/s²
UNIT = {"accel": (G0_M_S2, "m/s²"), "gyro": (1.0, "rad/s")}


class _FirmwareMethod(CompensatorBase):
    """Fit on the training rows with the firmware tool's method; predict = level + its offset(T).

    ``y`` is the accelerometer in g (``sensor = "accel"``) or the gyro in rad/s (``"gyro"``).

    Attributes
    ----------
    n_features_in_ : int
        Columns of ``X`` seen in ``fit`` (2, or 3 with a run id).
    cal_ : Px4AccelCal, Px4GyroCal, ArduPilotAccelCal or ArduPilotGyroCal
        The firmware tool's fit, in SI units (m/s² or rad/s).
    level_g_ : (3,) array
        Mean of the training rows after the firmware's offset, in the unit of ``y``.
    """

    sensor = "accel"
    row_by_row = True

    def _fit_cal(self, time_s, temperature_c, samples_si):  # pragma: no cover - subclasses
        raise NotImplementedError

    def share_folds(self, X, y):
        """What every fold's fit on rows of the same ``X``, ``y`` can share (None: nothing), given
        back to :meth:`fit` as ``shared``; see :func:`twin.calibration.validate.validate`."""
        return None

    def _filtered(self, shared, y, keep):
        raise TypeError(f"{type(self).__name__} shares nothing between fits; shared must be None")

    def fit(self, X, y, mask=None, shared=None):
        """Fit on the rows of ``mask`` (a contiguous branch, as the tools expect). Returns self.

        ``shared`` is :meth:`share_folds` of the same ``X`` and ``y``: the same fit, sooner."""
        log, y, keep = fit_inputs(self, X, y, mask)
        scale = UNIT[self.sensor][0]
        rows = slice(None) if keep.all() else keep  # every row: the arrays themselves, no copies
        samples = y[rows] * scale
        temperature_c = log.temperature_c[rows]
        extra = {} if shared is None else {"filtered": self._filtered(shared, y, keep)}
        self.cal_ = self._fit_cal(log.time_s[rows], temperature_c, samples, **extra)
        # mean(reading − offset(T)) = mean(reading) − mean(offset(T)), in SI units then back: the
        # offset's mean from the powers of T (its polynomial), not from an offset per row
        self.level_g_ = (samples.mean(axis=0) - self.cal_.polynomial.mean_offset(temperature_c)) / scale
        return self

    def offset(self, X) -> np.ndarray:
        """The firmware's offset at each row's temperature, in the unit of ``y`` (n, 3)."""
        return self.cal_.offset(validated_log(self, X, reset=False).temperature_c) / UNIT[self.sensor][0]

    def predict(self, X) -> np.ndarray:
        """Modelled reading, (n, 3): the training level plus the firmware's offset at T."""
        check_is_fitted(self)
        return self.level_g_ + self.offset(X)

    def compensate(self, X, reading: np.ndarray) -> np.ndarray:
        """What the firmware outputs: ``reading`` minus its thermal offset."""
        return np.asarray(reading, float) - self.offset(X)

    def equation(self) -> str:
        """The fitted offset polynomial per axis, as the firmware evaluates it (SI units)."""
        check_is_fitted(self)
        p, unit = self.cal_.polynomial, UNIT[self.sensor][1]
        return "\n".join(f"{ax}: offset = " + " ".join(f"{c:+.6g}·(T − {p.tref_c:g} °C)^{k}" for k, c in
                                                       enumerate(p.coefficients[a])) + f" {unit}, T clipped to "
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

    def _fit_cal(self, time_s, temperature_c, accel_m_s2, filtered=None):
        return fit_px4(temperature_c, accel_m_s2, device_id=self.device_id, instance=self.instance,
                       filtered=filtered)

    def share_folds(self, X, y):
        """The median filter of every row of ``y`` in SI units: each fold's filter of its
        training rows is then read from it, and filtered again only around its gaps
        (:func:`twin.firmware.median_filter_rows`): the same values, for a gather per fold.

        Parameters
        ----------
        X : array-like, (n, 2) or (n, 3)
        y : (n, 3) array-like
            Readings [g].

        Returns
        -------
        (n, 3) ndarray or None
            None when ``y`` has rows with NaN (each fold then filters its own rows).
        """
        y = np.asarray(y, float)
        if y.ndim != 2 or y.shape[1] != 3 or not np.all(np.isfinite(y)):
            return None
        scale = UNIT[self.sensor][0]
        return np.column_stack([median_filter(y[:, k] * scale) for k in range(3)])

    def _filtered(self, shared, y, keep):
        return median_filter_rows(shared, y, np.flatnonzero(keep), scale=UNIT[self.sensor][0])


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


class Px4GyroMethod(Px4Method):
    """PX4's gyro thermal calibration (``TC_G{instance}_*``); ``y`` in rad/s."""

    sensor = "gyro"

    def _fit_cal(self, time_s, temperature_c, gyro_rad_s, filtered=None):
        return fit_px4_gyro(temperature_c, gyro_rad_s, device_id=self.device_id, instance=self.instance,
                            filtered=filtered)


class ArduPilotGyroMethod(ArduPilotMethod):
    """ArduPilot's gyro temperature calibration (``INS_TCAL{instance}_GYR*``); ``y`` in rad/s."""

    sensor = "gyro"

    def _fit_cal(self, time_s, temperature_c, gyro_rad_s):
        return fit_ardupilot_gyro(temperature_c, gyro_rad_s, time_s=time_s, instance=self.instance)


# PX4 needs a device id to apply a calibration at all; the validation below only runs the arithmetic
VALIDATION_DEVICE_ID = 1


class AsTheVehicleApplies(CompensatorBase):
    """A firmware method scored as the vehicle applies the file we write for it.

    ``fit`` fits the wrapped method, writes its parameter file exactly as ``twin firmware`` does
    (checked and read back) and parses it as the ground station loads it; ``predict`` applies the
    parsed values as the firmware does: float32, the clamp, and for PX4 the offset republished only
    when the temperature has moved more than 1 °C, checked once a second
    (``twin.firmware.px4_vehicle_offsets``); for ArduPilot the correction re-referenced at the
    calibration temperature (``twin.firmware.ardupilot_vehicle_offsets``).

    Parameters
    ----------
    method : Px4Method, ArduPilotMethod or their gyro variants
        Left unfitted: ``fit`` fits a clone of it.

    Attributes
    ----------
    n_features_in_ : int
        Columns of ``X`` seen in ``fit`` (2, or 3 with a run id).
    inner_ : Px4Method, ArduPilotMethod or their gyro variants
        The fitted clone of ``method``.
    values_ : dict
        The parameter file as the ground station parses it.
    device_id_ : int
        PX4 only: the device id written (``VALIDATION_DEVICE_ID`` when the method has none).
    level_g_ : (3,) array
        The inner method's training level, in the unit of ``y``.
    """

    @property
    def row_by_row(self) -> bool:
        """ArduPilot's correction is a function of each row's temperature; PX4's republish timer runs over the log."""
        return not isinstance(self.method, Px4Method)

    def __init__(self, method):
        self.method = method

    def fit(self, X, y, mask=None):
        """Fit the method on ``mask``'s rows and load its file as the vehicle would. Returns self.

        Parameters
        ----------
        X : array-like, (n, 2) or (n, 3)
            ``[time_s, temperature_c]`` [s, °C], optionally with a run id.
        y : (n, 3) array-like
            Readings [g] or [rad/s].
        mask : array-like of bool or int, optional
            Rows to fit on.

        Returns
        -------
        AsTheVehicleApplies
            ``self``, fitted.
        """
        fit_inputs(self, X, y, mask)  # records n_features_in_; the clone below checks the same input again
        return self._load(clone(self.method).fit(X, y, mask))

    def fit_from(self, inner, X, y, mask=None):
        """:meth:`fit` with the wrapped method already fitted on the same rows (a clone of
        ``method`` fitted on ``X``, ``y``, ``mask``, as :func:`~twin.calibration.validate.validate`
        fits it beside this one): the same result without fitting it twice. Returns self.

        Parameters
        ----------
        inner : Px4Method, ArduPilotMethod or their gyro variants
            Fitted on exactly these rows.
        X, y, mask
            As in :meth:`fit`.

        Returns
        -------
        AsTheVehicleApplies
            ``self``, fitted.
        """
        if type(inner) is not type(self.method) or inner.get_params() != self.method.get_params():
            raise TypeError(f"fit_from needs a fitted {type(self.method).__name__} with the parameters of method")
        check_is_fitted(inner)
        # inner checked these X, y and mask when it was fitted on them: not read again (a pass per fold)
        self.n_features_in_ = inner.n_features_in_
        return self._load(inner)

    def _load(self, inner):
        self.inner_ = inner
        cal = self.inner_.cal_
        if isinstance(self.method, Px4Method):
            if not cal.device_id:
                cal = dataclasses.replace(cal, device_id=VALIDATION_DEVICE_ID)
            self.device_id_ = cal.device_id
            self.values_ = parse_px4_params(checked_px4_params_text([cal])).values
        else:
            self.values_ = parse_ardupilot_parm(checked_ardupilot_parm_text([cal]))
        self.level_g_ = self.inner_.level_g_
        return self

    def offset(self, X) -> np.ndarray:
        """What the vehicle subtracts at each row, in the unit of ``y`` (n, 3).

        Parameters
        ----------
        X : array-like, (n, 2) or (n, 3)
            ``[time_s, temperature_c]`` [s, °C], optionally with a run id (each run a boot).

        Returns
        -------
        (n, 3) ndarray
            Offset in the unit of ``y`` [g or rad/s].
        """
        log = validated_log(self, X, reset=False)
        sensor, scale = self.method.sensor, UNIT[self.method.sensor][0]
        if isinstance(self.method, Px4Method):
            out = np.empty((log.time_s.size, 3))
            for s in log.segments():  # each run is a boot: the module starts unpublished
                out[s] = px4_vehicle_offsets(self.values_, log.time_s[s], log.temperature_c[s],
                                             self.method.instance, sensor, device_id=self.device_id_)
            return out / scale
        return ardupilot_vehicle_offsets(self.values_, log.temperature_c, self.method.instance,
                                         sensor=sensor).astype(float) / scale

    def predict(self, X) -> np.ndarray:
        """The training level plus the offset the vehicle applies.

        Parameters
        ----------
        X : array-like, (n, 2) or (n, 3)
            ``[time_s, temperature_c]`` [s, °C], optionally with a run id.

        Returns
        -------
        (n, 3) ndarray
            Modelled reading in the unit of ``y`` [g or rad/s].
        """
        check_is_fitted(self)
        return self.level_g_ + self.offset(X)
