"""How to read a delimited log (:class:`ColumnMap`) and the unit conversions it names."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from twin.measurement.core import STANDARD_GRAVITY, MeasurementError
from twin.text import did_you_mean

TIME_FACTORS_S = {"s": 1.0, "ms": 1e-3, "us": 1e-6, "µs": 1e-6, "ns": 1e-9, "min": 60.0, "h": 3600.0}
OUTPUT_UNITS = ("g", "mg", "m/s^2", "m/s2", "digits")
AXES = ("x", "y", "z")


@dataclass
class ColumnMap:
    """How to read a delimited log.

    ``time``, ``temperature``, ``output``, ``applied``, ``run``, ``power_on``: column names, or
    0-based indices when the file has no header. Units: ``time_unit`` in s/ms/us; ``output_unit``
    in g/mg/m/s^2/digits (with ``digit_mg``); ``output_scale`` multiplies after conversion (e.g. 4
    for a ±4 g part logged in units of full scale/4); ``temperature_unit`` C or K.

    Three output columns make the log an :class:`~twin.measurement.imu.ImuLog`: ``x``, ``y``,
    ``z`` (or ``output_cols``, a list of three); ``axis`` is the one a single-axis comparison uses.
    """

    time: str | int | None = "time_s"
    temperature: str | int = "temperature_c"
    output: str | int = "output_g"
    applied: str | int | None = "applied_g"
    run: str | int | None = "run"
    power_on: str | int | None = "power_on"
    time_unit: str = "s"
    temperature_unit: str = "C"
    output_unit: str = "g"
    output_scale: float = 1.0
    digit_mg: float | None = None  # the part's sensitivity [mg/digit]: required with output_unit digits
    skip_lines: int = 0
    delimiter: str | None = None  # None: sniff ',', tab, ';', whitespace
    header: bool = True
    sample_rate_hz: float | None = None  # for logs without a time column
    invert_output: bool = False
    x: str | int | None = None
    y: str | int | None = None
    z: str | int | None = None
    output_cols: list[str | int] | None = None
    axis: str = "z"

    @classmethod
    def from_yaml(cls, path: str | Path) -> ColumnMap:
        import yaml

        p = Path(path)
        if not p.is_file():
            raise MeasurementError(f"{p}: column map not found")
        try:
            data = yaml.safe_load(p.read_text()) or {}
        except yaml.YAMLError as exc:
            raise MeasurementError(f"{p}: malformed YAML: {exc}") from None
        if not isinstance(data, dict):
            raise MeasurementError(f"{p}: a column map is a YAML mapping")
        known = set(cls.__dataclass_fields__)
        for key in data:
            if key not in known:
                raise MeasurementError(f"{p}: unknown column-map key {key!r}"
                                       f"{did_you_mean(key, known, label='valid keys')}")
        return cls(**data)

    def axis_columns(self) -> tuple[str | int, str | int, str | int] | None:
        """The x, y, z output columns, or ``None`` for a single-axis log.

        Raises
        ------
        MeasurementError
            ``output_cols`` not of length 3, or only some of ``x``, ``y``, ``z`` given.
        """
        if self.output_cols is not None:
            cols = list(self.output_cols)
            if len(cols) != 3:
                raise MeasurementError(f"column map: output_cols lists {len(cols)} column(s); expected 3 (x, y, z)")
            return tuple(cols)
        given = {a: getattr(self, a) for a in AXES if getattr(self, a) is not None}
        if not given:
            return None
        if len(given) < 3:
            missing = ", ".join(a for a in AXES if a not in given)
            raise MeasurementError(f"column map sets {', '.join(given)} but not {missing}; "
                                   "a 3-axis log needs x, y and z")
        return self.x, self.y, self.z


def time_factor_s(unit: str) -> float:
    """Seconds per ``unit`` (``nan`` for an unknown unit, so the caller names the unit)."""
    return TIME_FACTORS_S.get(unit, np.nan)


def convert_output(values: np.ndarray, cmap: ColumnMap) -> np.ndarray:
    """Output column(s) in g: the unit conversion, then ``output_scale``, then the sign."""
    unit = cmap.output_unit
    if unit == "g":
        out = values
    elif unit == "mg":
        out = values * 1e-3
    elif unit in ("m/s^2", "m/s2"):
        out = values / STANDARD_GRAVITY
    elif unit == "digits":
        if cmap.digit_mg is None:
            raise MeasurementError("output_unit digits needs digit_mg, the sensor's sensitivity [mg/digit] "
                                   "(twin parts lists it per full scale)")
        out = values * cmap.digit_mg * 1e-3
    else:
        raise MeasurementError(f"output_unit must be one of {', '.join(OUTPUT_UNITS)}, got {unit!r}")
    out = out * cmap.output_scale
    return -out if cmap.invert_output else out


def convert_temperature_c(values: np.ndarray, cmap: ColumnMap) -> np.ndarray:
    """Temperature column in °C."""
    return values - 273.15 if cmap.temperature_unit.upper() == "K" else values
