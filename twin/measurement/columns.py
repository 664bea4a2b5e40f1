"""How to read a delimited log (:class:`ColumnMap`) and the unit conversions it names."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from twin.measurement.core import STANDARD_GRAVITY, MeasurementError
from twin.text import did_you_mean

TIME_FACTORS_S = {"s": 1.0, "ms": 1e-3, "us": 1e-6, "µs": 1e-6, "ns": 1e-9, "min": 60.0, "h": 3600.0}
OUTPUT_UNITS = ("g", "mg", "m/s^2", "m/s2", "digits")
TEMPERATURE_UNITS = ("C", "K", "F")
AXES = ("x", "y", "z")
GYRO_KEYS = ("gx", "gy", "gz")
GYRO_FACTORS_RAD_S = {"rad/s": 1.0, "deg/s": np.pi / 180.0}  # radians per second per unit
# delimiter spellings beyond one character: a tab typed on a command line, and runs of whitespace
DELIMITER_WORDS = {"tab": "\t", "\\t": "\t", "whitespace": r"\s+", r"\s+": r"\s+"}
COLUMN_KEYS = ("time", "temperature", "output", "applied", "run", "power_on", "x", "y", "z", *GYRO_KEYS)


@dataclass
class ColumnMap:
    """How to read a delimited log.

    Three output columns make the log an :class:`~twin.measurement.imu.ImuLog`. :meth:`validate`
    checks every field's type and range; the readers call it before reading.

    Attributes
    ----------
    time, temperature, output, applied, run, power_on : str or int or None
        Column names, or 0-based indices when the file has no header (``temperature`` and
        ``output`` required; ``time`` None: times from ``sample_rate_hz``).
    time_unit : str
        s, ms, us, µs, ns, min or h.
    temperature_unit : str
        C, K or F.
    output_unit : str
        g, mg, m/s^2 or digits (with ``digit_mg``).
    output_scale : float
        Multiplies after conversion [1] (e.g. 4 for a ±4 g part logged in units of full scale/4).
    digit_mg : float or None
        The part's sensitivity [mg/digit]: required with output_unit digits.
    skip_lines : int
        Lines skipped before the header.
    delimiter : str or None
        One character, ``tab`` or ``whitespace``; None: sniff ',', tab, ';', whitespace.
    header : bool
        The file has a header line.
    sample_rate_hz : float or None
        Sample rate of a log without a time column [Hz].
    invert_output : bool
        Negate the output.
    x, y, z : str or int or None
        The three output columns of a three-axis log.
    output_cols : list or None
        The same as a list of three.
    axis : str
        The axis (x, y or z) a single-axis comparison uses.
    gx, gy, gz : str or int or None
        Gyro columns (all three or none).
    gyro_unit : str
        rad/s (default) or deg/s.
    """

    time: str | int | None = "time_s"
    temperature: str | int = "temperature_c"
    output: str | int = "output_g"
    applied: str | int | None = "applied_g"
    run: str | int | None = "run"
    power_on: str | int | None = "power_on"
    time_unit: str = "s"
    temperature_unit: str = "C"  # C, K or F
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
    gx: str | int | None = None
    gy: str | int | None = None
    gz: str | int | None = None
    gyro_unit: str = "rad/s"

    @classmethod
    def from_yaml(cls, path: str | Path) -> ColumnMap:
        """The column map of a YAML file; a bad key or value names its line and what was expected.

        Parameters
        ----------
        path : str or Path
            YAML file of column-map keys.

        Returns
        -------
        ColumnMap
            The validated map.
        """
        from twin.errors import TwinError
        from twin.io import read_text
        from twin.text import line_map, load_yaml_mapping

        p = Path(path)
        text = read_text(p, "column map", MeasurementError)
        try:
            data, _ = load_yaml_mapping(text, str(p), "a column map") if text.strip() else ({}, {})
        except TwinError as exc:
            raise MeasurementError(str(exc)) from None
        lines = line_map(text)
        known = set(cls.__dataclass_fields__)
        for key in data:
            if key not in known:
                raise MeasurementError(f"{p}:{lines.get((key,), 1)}: unknown column-map key {key!r}"
                                       f"{did_you_mean(key, known, label='valid keys')}")
        cmap = cls(**data)
        cmap.validate(str(p), {key: lines.get((key,)) for key in data})
        return cmap

    def validate(self, where: str = "column map", lines: dict | None = None) -> ColumnMap:
        """Check every field's type and range (before any file is read); ``self`` for chaining.

        Parameters
        ----------
        where : str
            What to name in messages (the file).
        lines : dict, optional
            Line of each key in that file.

        Returns
        -------
        ColumnMap
            ``self``.

        Raises
        ------
        MeasurementError
            ``where[:line]: key: what was found, expected what`` for the first bad field.
        """
        lines = lines or {}

        def bad(key: str, expected: str) -> MeasurementError:
            line = lines.get(key)
            return MeasurementError(f"{where}{f':{line}' if line else ''}: {key}: got "
                                    f"{_shown(getattr(self, key))}, expected {expected}")

        for key in COLUMN_KEYS:
            value = getattr(self, key)
            if value is not None and not _is_column(value):
                raise bad(key, "a column name or a 0-based column index")
        for key in ("temperature", "output"):
            if getattr(self, key) is None:
                raise bad(key, "a column name or a 0-based column index")
        if self.output_cols is not None and not (isinstance(self.output_cols, (list, tuple))
                                                 and len(self.output_cols) == 3
                                                 and all(_is_column(c) for c in self.output_cols)):
            raise bad("output_cols", "a list of three column names or indices (x, y, z)")
        for key, allowed in (("time_unit", tuple(TIME_FACTORS_S)), ("output_unit", OUTPUT_UNITS),
                             ("temperature_unit", TEMPERATURE_UNITS), ("gyro_unit", tuple(GYRO_FACTORS_RAD_S))):
            value = getattr(self, key)
            if not isinstance(value, str) or (value.upper() if key == "temperature_unit" else value) not in allowed:
                raise bad(key, f"one of {', '.join(allowed)}")
        if self.axis not in AXES:
            raise bad("axis", "one of x, y, z")
        for key in ("header", "invert_output"):
            if not isinstance(getattr(self, key), bool):
                raise bad(key, "true or false")
        if not _is_int(self.skip_lines) or not 0 <= self.skip_lines <= 10**7:
            raise bad("skip_lines", "a whole number of lines >= 0")
        if not _is_number(self.output_scale) or self.output_scale == 0:
            raise bad("output_scale", "a finite non-zero number")
        for key in ("digit_mg", "sample_rate_hz"):
            value = getattr(self, key)
            if value is not None and not (_is_number(value) and 0 < value < 1e9):
                raise bad(key, "a finite number > 0" + (" [Hz]" if key == "sample_rate_hz" else " [mg/digit]"))
        if self.time is None and self.sample_rate_hz is None:
            raise bad("sample_rate_hz", "a sample rate [Hz] when the log has no time column (time: null)")
        if self.delimiter is not None and self.separator() is None:
            raise bad("delimiter", "one character, 'tab' or 'whitespace'")
        return self

    def separator(self) -> str | None:
        """The delimiter as the parser takes it (one character or ``\\s+``); ``None`` if unusable.

        Returns
        -------
        str or None
            The separator.
        """
        d = self.delimiter
        if not isinstance(d, str):
            return None
        if d in DELIMITER_WORDS:
            return DELIMITER_WORDS[d]
        # a quote, a digit, a sign, a point or a line break cannot separate numeric columns
        return d if len(d) == 1 and d not in "\"'\r\n0123456789.+-eE" else None

    def axis_columns(self) -> tuple[str | int, str | int, str | int] | None:
        """The x, y, z output columns, or ``None`` for a single-axis log.

        Returns
        -------
        tuple or None
            Three column names or indices.

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

    def gyro_columns(self) -> tuple[str | int, str | int, str | int] | None:
        """The gyro x, y, z columns (``gx``, ``gy``, ``gz``), or ``None`` when the map names none.

        Returns
        -------
        tuple or None
            Three column names or indices.

        Raises
        ------
        MeasurementError
            Only some of ``gx``, ``gy``, ``gz`` given.
        """
        given = {k: getattr(self, k) for k in GYRO_KEYS if getattr(self, k) is not None}
        if not given:
            return None
        if len(given) < 3:
            missing = ", ".join(k for k in GYRO_KEYS if k not in given)
            raise MeasurementError(f"column map sets {', '.join(given)} but not {missing}; "
                                   "a gyro needs gx, gy and gz")
        return self.gx, self.gy, self.gz


RUN_MAX = int(np.iinfo(np.int16).max)  # runs are stored as int16


def not_whole_in_range(values: np.ndarray, low: int, high: int) -> np.ndarray:
    """Where ``values`` (a run or power-on column read as floats) is not a whole number in [low, high].

    Parameters
    ----------
    values : ndarray
        Column read as floats [1].
    low, high : int
        Allowed range, inclusive.

    Returns
    -------
    ndarray of bool
        True where the value is not allowed.
    """
    return (values != np.round(values)) | (values < low) | (values > high)


def time_factor_s(unit: str) -> float:
    """Seconds per ``unit`` (``nan`` for an unknown unit, so the caller names the unit).

    Parameters
    ----------
    unit : str
        A key of :data:`TIME_FACTORS_S`.

    Returns
    -------
    float
        Factor [s per unit].
    """
    return TIME_FACTORS_S.get(unit, np.nan)


def convert_output(values: np.ndarray, cmap: ColumnMap) -> np.ndarray:
    """Output column(s) in g: the unit conversion, then ``output_scale``, then the sign.

    Parameters
    ----------
    values : ndarray
        Output as logged [``cmap.output_unit``].
    cmap : ColumnMap
        Unit, ``digit_mg``, ``output_scale``, ``invert_output``.

    Returns
    -------
    ndarray
        Output [g] (m/s² divided by standard gravity 9.80665 m/s², CGPM 1901).
    """
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
    if cmap.output_scale != 1.0:  # x·1 == x exactly: skip a copy of a long log
        out = out * cmap.output_scale
    return -out if cmap.invert_output else out


def convert_gyro_rad_s(values: np.ndarray, cmap: ColumnMap) -> np.ndarray:
    """Gyro column(s) in rad/s from ``cmap.gyro_unit`` (rad/s or deg/s).

    Parameters
    ----------
    values : ndarray
        Rate as logged [``cmap.gyro_unit``].
    cmap : ColumnMap
        Its ``gyro_unit``.

    Returns
    -------
    ndarray
        Rate [rad/s].
    """
    factor = GYRO_FACTORS_RAD_S.get(cmap.gyro_unit)
    if factor is None:
        raise MeasurementError(f"gyro_unit must be one of {', '.join(GYRO_FACTORS_RAD_S)}, got {cmap.gyro_unit!r}")
    return values if factor == 1.0 else values * factor


def convert_temperature_c(values: np.ndarray, cmap: ColumnMap) -> np.ndarray:
    """Temperature column in °C from C, K (−273.15) or F ((F − 32)·5/9, exact by definition).

    Parameters
    ----------
    values : ndarray
        Temperature as logged [``cmap.temperature_unit``].
    cmap : ColumnMap
        Its ``temperature_unit``.

    Returns
    -------
    ndarray
        Temperature [°C].
    """
    unit = cmap.temperature_unit.upper()
    if unit == "K":
        return values - 273.15
    if unit == "F":
        return (values - 32.0) * (5.0 / 9.0)
    return values


def _is_int(value) -> bool:
    return isinstance(value, (int, np.integer)) and not isinstance(value, bool)


def _is_number(value) -> bool:
    return isinstance(value, (int, float, np.integer, np.floating)) and not isinstance(value, bool) \
        and bool(np.isfinite(value))


def _is_column(value) -> bool:
    """A column name (non-empty text) or a 0-based index."""
    return (isinstance(value, str) and value.strip() != "") or (_is_int(value) and 0 <= value < 100_000)


def _shown(value) -> str:
    text = repr(value)
    return text if len(text) <= 60 else text[:57] + "..."
