"""Multi-axis, multi-IMU logs (flight logs, 3-axis tables): :class:`ImuLog`, one per IMU instance.

The diagnosis works on one axis at a time; :meth:`ImuLog.axis` gives that axis as a
:class:`~twin.measurement.core.Measurement`.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from twin.measurement.core import Measurement, MeasurementError, check

AXES = ("x", "y", "z")
# ArduPilot's own temperature calibration refuses a learn run spanning under 10 °C (TEMP_RANGE_MIN)
MIN_TEMPERATURE_RANGE_C = 10.0
# a cubic per axis needs far more than 4 points once noise is in; 100 is a floor, not a target
MIN_SAMPLES = 100


@dataclass(frozen=True, eq=False)
class ImuLog:
    """One accelerometer instance of a log: three axes on one time base.

    Attributes
    ----------
    time_s : numpy.ndarray
        Sample times [s] (the log's own clock, e.g. time since boot).
    temperature_c : numpy.ndarray
        The IMU's temperature [°C].
    accel_g : numpy.ndarray
        Acceleration, shape (n, 3), columns x, y, z [g] in the log's frame (FRD for PX4 and
        ArduPilot: a level board reads about −1 g on z).
    instance : int
        The log's instance number (PX4 ``multi_id``, ArduPilot ``I``).
    device_id : int or None
        The driver's device id when the log has one.
    source : str
        The file read.
    notes : tuple of str
        What the reader noticed.
    records : dict
        Other per-instance records, by message name (e.g. ArduPilot ``TCLR``), each a dict of arrays.
    gyro_rad_s : numpy.ndarray or None
        Angular rate, shape (n, 3) [rad/s] on the same rows as ``accel_g``, when the log has a
        gyro of this IMU (ArduPilot ``GyrX..Z``, PX4 ``sensor_gyro``, gyro columns of a table).
    gyro_device_id : int or None
        The gyro driver's device id (PX4 ``TC_Gn_ID``, ArduPilot ``INS_GYRn_ID``), when logged.
    board_orientation : int or None
        ArduPilot's ``AHRS_ORIENTATION`` when the log records it: its ``IMU`` messages are rotated
        by it into the vehicle's axes, while ``INS_TCALn`` corrects in the sensor's own axes
        (``_rotate_and_correct_accel`` corrects before it rotates).
    """

    time_s: np.ndarray
    temperature_c: np.ndarray
    accel_g: np.ndarray
    instance: int = 0
    device_id: int | None = None
    source: str = ""
    notes: tuple[str, ...] = ()
    records: dict[str, dict[str, np.ndarray]] = field(default_factory=dict)
    gyro_rad_s: np.ndarray | None = None
    gyro_device_id: int | None = None
    board_orientation: int | None = None

    def __post_init__(self):
        n = self.time_s.shape[0]
        if self.accel_g.shape != (n, 3) or self.temperature_c.shape != (n,):
            raise MeasurementError(f"{self.source}: instance {self.instance}: time ({n}), temperature "
                                   f"{self.temperature_c.shape} and accel {self.accel_g.shape} disagree; "
                                   "expected n, (n,) and (n, 3)")
        if self.gyro_rad_s is not None and self.gyro_rad_s.shape != (n, 3):
            raise MeasurementError(f"{self.source}: instance {self.instance}: gyro {self.gyro_rad_s.shape} "
                                   f"does not match the {n} accelerometer rows; expected ({n}, 3)")

    @property
    def has_gyro(self) -> bool:
        """Whether the log carries this IMU's angular rate."""
        return self.gyro_rad_s is not None

    def __len__(self) -> int:
        return int(self.time_s.shape[0])

    @property
    def axes(self) -> tuple[str, ...]:
        """The axis names, in the column order of ``accel_g``."""
        return AXES

    @property
    def temperature_range_c(self) -> float:
        """Span of the temperature [°C] (0 for an empty log)."""
        return float(np.ptp(self.temperature_c)) if len(self) else 0.0

    def axis(self, name: str, applied_g: float | None = None) -> Measurement:
        """One axis as a single-axis :class:`Measurement` (one run, powered on throughout).

        Parameters
        ----------
        name : {"x", "y", "z"}
            The axis.
        applied_g : float, optional
            Acceleration applied along that axis [g]; ``None`` means unknown.

        Returns
        -------
        Measurement
            Time [s], temperature [°C], output along the axis [g].

        Raises
        ------
        MeasurementError
            Unknown axis, or the axis fails :func:`check`.
        """
        if name not in AXES:
            raise MeasurementError(f"{self.source}: no axis {name!r}; expected one of {', '.join(AXES)}")
        n = len(self)
        known = applied_g is not None
        applied = np.full(n, float(applied_g) if known else np.nan)
        m = Measurement(self.time_s.astype(float), self.temperature_c.astype(float),
                        self.accel_g[:, AXES.index(name)].astype(float), applied, np.zeros(n, np.int16),
                        np.zeros(n, bool), known, [self.source], 0, list(self.notes))
        check(m, f"{self.source} (instance {self.instance}, axis {name})")
        return m


def usable_for_calibration(log: ImuLog, *, min_samples: int = MIN_SAMPLES,
                           min_range_c: float = MIN_TEMPERATURE_RANGE_C, raise_error: bool = False) -> tuple[bool, str]:
    """Whether ``log`` can calibrate a temperature drift model: enough samples over enough °C.

    Parameters
    ----------
    log : ImuLog
        The log.
    min_samples : int
        Fewest samples.
    min_range_c : float
        Smallest temperature span [°C] (ArduPilot's TEMP_RANGE_MIN, 10 °C).
    raise_error : bool
        Raise instead of returning a negative verdict.

    Returns
    -------
    (bool, str)
        The verdict and its reason, e.g. ``"6 samples < 100, temperature range 0.3 °C < 10 °C"``.

    Raises
    ------
    MeasurementError
        With the reason, when ``raise_error`` and the log is not usable.
    """
    n, span = len(log), log.temperature_range_c
    problems = []
    if n < min_samples:
        problems.append(f"{n} samples < {min_samples}")
    if span < min_range_c:
        problems.append(f"temperature range {span:.2f} °C < {min_range_c:g} °C")
    where = f"{log.source} instance {log.instance}"
    if problems:
        reason = f"{where}: not usable for temperature calibration: {', '.join(problems)}"
        if raise_error:
            raise MeasurementError(reason)
        return False, reason
    return True, f"{where}: {n} samples over {span:.2f} °C"


def drop_unusable_rows(time_s: np.ndarray, temperature_c: np.ndarray, accel: np.ndarray, where: str):
    """Rows sorted by time, without duplicate times or non-finite values; and a note on what went.

    Flight logs interleave instances and may repeat a timestamp or log NaN temperature when a
    driver resets; the diagnosis needs strictly increasing time and finite values.

    Parameters
    ----------
    time_s : ndarray
        Sample times [s].
    temperature_c : ndarray
        Temperature [°C].
    accel : ndarray
        Acceleration, shape (n, 3) [g or the log's unit].
    where : str
        What to name in messages.

    Returns
    -------
    tuple
        Time [s], temperature [°C] and acceleration of the kept rows, and a tuple of notes.
    """
    order = np.argsort(time_s, kind="stable")
    t, temp, acc = time_s[order], temperature_c[order], accel[order]
    keep = np.isfinite(t) & np.isfinite(temp) & np.isfinite(acc).all(axis=1)
    keep[1:] &= np.diff(t) > 0
    dropped = int((~keep).sum())
    note = (f"{where}: {dropped} row(s) with a repeated time or non-finite values dropped",) if dropped else ()
    if not keep.any():
        raise MeasurementError(f"{where}: no row with finite time, temperature and acceleration")
    return t[keep], temp[keep], acc[keep], note
