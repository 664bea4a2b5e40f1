"""Thermal-log plumbing shared by the calibration estimators: the ``X`` convention and causal lags.

Estimators take ``X`` of shape (n, 2) — ``time_s``, ``temperature_c`` — or (n, 3) with a run id
in the third column. Lags always run over the whole log given to ``fit``/``predict`` (temperature
is an input), and restart in equilibrium at the start of every run.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from sim.drift import lowpass, lowpass_at
from twin.arrays import run_slices
from twin.errors import TwinError


@dataclass(frozen=True, eq=False)
class ThermalLog:
    """A temperature log split into runs.

    Attributes
    ----------
    time_s, temperature_c : (n,) arrays
        Sample times [s] (increasing within a run) and reference temperatures [°C].
    run : (n,) int array
        Run id of each sample (0 when a single run).
    """

    time_s: np.ndarray
    temperature_c: np.ndarray
    run: np.ndarray

    def segments(self) -> list[slice]:
        """Contiguous slices of equal run id, in order."""
        return run_slices(self.run)


def make_X(time_s, temperature_c, run=None) -> np.ndarray:
    """Stack ``time_s``, ``temperature_c`` (and ``run``) into the estimators' ``X``."""
    cols = [np.asarray(time_s, float), np.asarray(temperature_c, float)]
    if run is not None:
        cols.append(np.asarray(run, float))
    return np.column_stack(cols)


def as_log(X) -> ThermalLog:
    """Check ``X`` and return it as a :class:`ThermalLog`; raise ``TwinError`` on bad input."""
    X = np.asarray(X, float)
    if X.ndim != 2 or X.shape[1] not in (2, 3) or X.shape[0] < 4:
        raise TwinError(f"X must be (n, 2) [time_s, temperature_c] or (n, 3) with a run id, n ≥ 4; got {X.shape}")
    if not np.all(np.isfinite(X)):
        raise TwinError("X holds NaN or inf: time and temperature must be finite on every row")
    run = X[:, 2].astype(np.int64) if X.shape[1] == 3 else np.zeros(X.shape[0], np.int64)
    log = ThermalLog(X[:, 0], X[:, 1], run)
    for s in log.segments():
        if np.any(np.diff(log.time_s[s]) <= 0):
            raise TwinError(f"time_s must increase strictly within a run (run {int(run[s.start])})")
    return log


def _lag_segment(time_s: np.ndarray, temperature_c: np.ndarray, tau_s: float) -> np.ndarray:
    if tau_s <= 0 or time_s.size < 2:
        return temperature_c.copy()
    dt = np.diff(time_s)
    step = float(np.median(dt))
    if np.all(np.abs(dt - step) <= 1e-9 * step):  # a uniform clock: one IIR filter
        return lowpass(temperature_c, step, tau_s)
    # a jittered or gappy clock: the same exact discretisation with each step's own coefficients,
    # so a firmware running the recursion on its measured time steps reproduces it
    return lowpass_at(time_s, temperature_c, tau_s)


def lagged_c(log: ThermalLog, tau_s: float) -> np.ndarray:
    """Causal first-order lag ``lag(T, τ)`` [°C] of the log, from equilibrium at each run's start."""
    out = np.empty_like(log.temperature_c)
    for s in log.segments():
        out[s] = _lag_segment(log.time_s[s], log.temperature_c[s], float(tau_s))
    return out


def train_mask(y: np.ndarray, n: int, mask=None) -> np.ndarray:
    """Rows to fit on: ``mask`` (boolean or indices) and finite ``y``; raise if too few."""
    y = np.asarray(y, float)
    if y.shape != (n, 3):
        raise TwinError(f"accel_g must be (n, 3) with n = {n} rows like X; got {y.shape}")
    keep = np.all(np.isfinite(y), axis=1)
    if mask is not None:
        m = np.asarray(mask)
        sel = np.zeros(n, bool)
        sel[m if m.dtype != bool else np.flatnonzero(m)] = True
        keep &= sel
    if keep.sum() < 10:
        raise TwinError(f"only {int(keep.sum())} rows to fit on (need ≥ 10 with finite accel_g)")
    return keep
