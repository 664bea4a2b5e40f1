"""Numerical core of ``twin calibrate``: three-axis temperature compensation and its validation.

- :mod:`~twin.calibration.branches` — heating / cooling / dwell branches; protocols ("fit on
  heating, test on cooling" and the reverse, leave one run out, interleaved blocks as fallback).
- :mod:`~twin.calibration.models` — ``CubicCompensator`` (PX4), ``TemperaturePolynomial`` (per-axis
  polynomial in the thermometer reading, degree on held-out blocks; not ``fitting.PolynomialCompensator``).
- :mod:`~twin.calibration.lagaware` — ``LagAwareCompensator``: polynomial in a lagged die
  temperature plus a thermal-gradient (rate) term, time constants fitted on training rows only.
- :mod:`~twin.calibration.validate` — held-out RMS per branch and axis, noise floor, best method.
- :mod:`~twin.calibration.orientation` — static segments, six-position/tumble orientations,
  offset(T) and scale factor(T) with 95 % intervals.

Estimators are scikit-learn regressors (``sklearn.base.clone`` copies them unfitted); they take
``X = make_X(time_s, temperature_c[, run])`` and ``accel_g`` (n, 3).
"""

from twin.calibration.branches import Branch, Fold, Protocol, TestSet, protocol_heating_vs_cooling, split_branches
from twin.calibration.lag import make_X
from twin.calibration.lagaware import LagAwareCompensator
from twin.calibration.models import CubicCompensator, TemperaturePolynomial
from twin.calibration.orientation import (OffsetScaleFit, Orientation, OrientationReport, StaticSegment,
                                          cluster_orientations, detect_static_segments, fit_offset_scale,
                                          six_position)
from twin.calibration.validate import Score, ValidationResult, validate

__all__ = [
    "Branch", "Fold", "Protocol", "TestSet", "protocol_heating_vs_cooling", "split_branches", "make_X",
    "LagAwareCompensator", "CubicCompensator", "TemperaturePolynomial", "OffsetScaleFit", "Orientation",
    "OrientationReport", "StaticSegment", "cluster_orientations", "detect_static_segments", "fit_offset_scale",
    "six_position", "Score", "ValidationResult", "validate",
]
