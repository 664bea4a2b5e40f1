"""The results of ``twin firmware`` and ``twin apply``: typed, and written to JSON field for field.

The JSON and its schema (``twin schema --result firmware`` / ``apply``) derive from these types
through :mod:`twin.results`.
"""

from __future__ import annotations

from dataclasses import dataclass

from twin.results import PerAxis, to_json


@dataclass(frozen=True)
class FirmwareResult:
    """What ``twin firmware --json`` writes.

    Attributes
    ----------
    output : str
        The firmware file written.
    format : str
        ``px4``, ``ardupilot``, ``json`` or ``c``.
    method : str or tuple of str
        The method written: one name, or one per IMU when they differ.
    imu : int or None
        The ``--imu`` instance asked for (None: every IMU of the calibration).
    lines : int
        Lines of the file written.
    notes : tuple of str
        What the user should know before loading it.
    """

    output: str
    format: str
    method: str | tuple[str, ...]
    imu: int | None
    lines: int
    notes: tuple[str, ...]

    def to_json(self) -> dict:
        """The JSON document (:func:`twin.results.to_json`).

        Returns
        -------
        dict
        """
        return to_json(self)


@dataclass(frozen=True)
class ApplyResult:
    """What ``twin apply --json`` writes.

    Attributes
    ----------
    output : str
        The compensated CSV written.
    method : str
        The method applied.
    instance : int
        The log's IMU instance compensated.
    rows : int
        Samples compensated.
    extrapolated_fraction : float
        Fraction of the samples outside the calibrated temperature span [1].
    residual_rms_mg : PerAxis of float, optional
        RMS of the compensated output about the ``--applied-g`` acceleration, its median offset
        removed [mg]; only with ``--applied-g``.
    raw_rms_mg : PerAxis of float, optional
        RMS of the raw output about its median [mg]; only with ``--applied-g``.
    """

    output: str
    method: str
    instance: int
    rows: int
    extrapolated_fraction: float
    residual_rms_mg: PerAxis[float] | None = None
    raw_rms_mg: PerAxis[float] | None = None

    def to_json(self) -> dict:
        """The JSON document (:func:`twin.results.to_json`).

        Returns
        -------
        dict
        """
        return to_json(self)
