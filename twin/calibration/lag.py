"""Thermal-log plumbing shared by the calibration estimators: the ``X`` convention and causal lags.

Estimators take ``X`` of shape (n, 2) — ``time_s``, ``temperature_c`` — or (n, 3) with a run id
in the third column. Lags always run over the whole log given to ``fit``/``predict`` (temperature
is an input), and restart in equilibrium at the start of every run.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from sklearn.utils.validation import check_array, check_is_fitted, validate_data

from sim.drift import lowpass_at
from sim.recursion import first_order_filter
from twin.arrays import run_slices
from twin.errors import TwinError

MIN_ROWS = 4  # the fewest rows of X any calibration estimator takes, in fit or predict
MIN_TRAIN_ROWS = 10  # the fewest finite rows any calibration fit is attempted on


class ThermalLogError(TwinError, ValueError):
    """``X`` or ``y`` is no thermal log a calibration estimator can take.

    A ``TwinError`` (the command line reports it in one line) and a ``ValueError`` (what
    scikit-learn expects of an estimator refusing its input).
    """


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
        """Contiguous slices of equal run id, in order (found once per log: every lag asks).

        Returns
        -------
        list of slice
            One slice per run.
        """
        found = self.__dict__.get("_segments")
        if found is None:
            found = run_slices(self.run)
            object.__setattr__(self, "_segments", found)  # a cache, not a field: frozen all the same
        return list(found)


def make_X(time_s, temperature_c, run=None) -> np.ndarray:
    """Stack ``time_s``, ``temperature_c`` (and ``run``) into the estimators' ``X``.

    Parameters
    ----------
    time_s, temperature_c : (n,) array-like
        Sample times [s] and temperatures [°C].
    run : (n,) array-like of int, optional
        Run id per sample.

    Returns
    -------
    (n, 2) or (n, 3) ndarray
        The estimators' ``X``.
    """
    cols = [np.asarray(time_s, float), np.asarray(temperature_c, float)]
    if run is not None:
        cols.append(np.asarray(run, float))
    return np.column_stack(cols)


def as_log(X) -> ThermalLog:
    """Check ``X`` and return it as a :class:`ThermalLog`.

    Parameters
    ----------
    X : array-like, (n, 2) or (n, 3)
        ``[time_s, temperature_c]`` [s, °C], optionally with a run id.

    Returns
    -------
    ThermalLog
        The log split into runs.

    Raises
    ------
    ThermalLogError
        When ``X`` is not (n, 2) or (n, 3) with n ≥ :data:`MIN_ROWS`, holds NaN or inf, or its
        time does not increase strictly within a run.
    """
    X = np.asarray(X, float)
    if X.ndim != 2 or X.shape[1] not in (2, 3) or X.shape[0] < MIN_ROWS:
        # the counts spelled out as n_samples / n_features: scikit-learn's checks look for them
        shape = f"n_samples = {X.shape[0]}, n_features = {X.shape[1]}" if X.ndim == 2 else f"shape {X.shape}"
        raise ThermalLogError(f"X must be (n, 2) [time_s, temperature_c] or (n, 3) with a run id, "
                              f"n ≥ {MIN_ROWS}; got {shape}")
    if not np.all(np.isfinite(X)):
        raise ThermalLogError("X holds NaN or inf: time and temperature must be finite on every row")
    run = X[:, 2].astype(np.int64) if X.shape[1] == 3 else np.zeros(X.shape[0], np.int64)
    log = ThermalLog(X[:, 0], X[:, 1], run)
    if X.shape[1] == 2:  # one run: its slice without reading the (untouched, zero) run ids
        object.__setattr__(log, "_segments", [slice(0, X.shape[0])])
    for s in log.segments():
        t = log.time_s[s]
        if np.any(t[1:] <= t[:-1]):
            raise ThermalLogError(f"time_s must increase strictly within a run (run {int(run[s.start])})")
    return log


def validated_log(estimator, X, *, reset: bool) -> ThermalLog:
    """``X`` checked as scikit-learn checks an estimator's input, then as a thermal log.

    Parameters
    ----------
    estimator : BaseEstimator
        Records ``n_features_in_`` (2 or 3 columns) when ``reset``; otherwise ``X`` must match it
        and the estimator must be fitted.
    X : array-like, (n, 2) or (n, 3)
        ``[time_s, temperature_c]`` [s, °C], or with a run id in the third column.
    reset : bool
        True in ``fit``, False in every method that uses a fitted estimator.

    Returns
    -------
    ThermalLog
        The checked log.

    Raises
    ------
    ThermalLogError
        On bad input (its message is scikit-learn's or :func:`as_log`'s).
    sklearn.exceptions.NotFittedError
        When ``reset`` is False and the estimator is not fitted.
    """
    if not reset:
        check_is_fitted(estimator)
    try:
        # finiteness is left to as_log: one message for NaN and inf in time or temperature
        X = validate_data(estimator, X, reset=reset, dtype=np.float64, ensure_all_finite=False)
    except ValueError as exc:
        raise ThermalLogError(str(exc)) from None
    return as_log(X)


def fit_inputs(estimator, X, y, mask=None) -> tuple[ThermalLog, np.ndarray, np.ndarray]:
    """What every calibration ``fit`` starts with: the log, ``y`` as floats, the rows to fit on.

    Parameters
    ----------
    estimator : BaseEstimator
        Records ``n_features_in_``.
    X : array-like, (n, 2) or (n, 3)
        See :func:`validated_log`.
    y : array-like, (n, 3)
        Readings per axis (accelerometer [g] or gyro [rad/s]); rows with NaN are not fitted on.
    mask : array-like of bool or int, optional
        Rows to fit on (see :func:`train_mask`).

    Returns
    -------
    (log, y, keep) : ThermalLog, (n, 3) float array, (n,) bool array
    """
    if y is None:
        raise ThermalLogError(f"{type(estimator).__name__} requires y to be passed, but the target y is None; "
                              "expected the readings (n, 3)")
    log = validated_log(estimator, X, reset=True)
    try:
        y = check_array(y, dtype=np.float64, ensure_2d=False, ensure_all_finite=False, input_name="y")
    except ValueError as exc:
        raise ThermalLogError(str(exc)) from None
    return log, y, train_mask(y, log.time_s.size, mask)


def uniform_lag(u: np.ndarray, dt_s: float, tau_s: float) -> np.ndarray:
    """:func:`sim.drift.lowpass` (τ > 0), bit for bit, without its general network's overhead.

    ``lowpass`` runs :func:`sim.thermal.simulate_network` for one node (C = 1, G = g = 1/τ): the
    mode λ = 1/τ, its first-order-hold recursion, the input about ``u[0]``. The same coefficients
    from the same operations on one-element arrays, and one filter pass: 2–3× faster at any length
    (the τ search calls it thousands of times).

    Parameters
    ----------
    u : (n,) ndarray
        Input [°C], sampled every ``dt_s``.
    dt_s, tau_s : float
        Sample interval and time constant τ > 0 [s].

    Returns
    -------
    (n,) ndarray
        The lagged input [°C].
    """
    lam = np.ones(1) / tau_s  # the eigenvalue of the 1 × 1 network, exactly 1/τ
    lh = lam * dt_s
    p = np.exp(-lh)
    small = lh < 1e-6
    lam_safe = np.where(small, 1.0, lam)
    i0 = np.where(small, dt_s * (1 - lh / 2), -np.expm1(-lh) / lam_safe)
    i1 = np.where(small, dt_s * (0.5 - lh / 6), (1 - i0 / dt_s) / lam_safe)
    beta = lam[0]
    z = first_order_filter(u - u[0], beta * i1[0], beta * (i0 - i1)[0], p[0])
    z += u[0]
    return z


@dataclass(frozen=True, eq=False)
class RunClock:
    """The clock of one run, read once for every lag of it (:func:`clock_of`).

    Attributes
    ----------
    step_s : float
        The median step [s].
    irregular : ndarray of int or None
        Indices k of the steps t[k+1] − t[k] that are not ``step_s`` (gaps, a dropped sample),
        empty on a uniform clock; None when there are more than one in :data:`MAX_IRREGULAR_SHARE`
        of the steps (a jittered clock: every step its own coefficients).
    """

    step_s: float
    irregular: np.ndarray | None


MAX_IRREGULAR_SHARE = 1 / 100  # more irregular steps than this: the per-step recursion, not filter runs


def clock_of(time_s: np.ndarray) -> RunClock:
    """The step and the irregular steps of one run's increasing clock.

    Parameters
    ----------
    time_s : (n,) ndarray
        Sample times of one run [s].

    Returns
    -------
    RunClock
    """
    dt = np.diff(time_s)
    step = float(np.median(dt)) if dt.size else 0.0
    irregular = np.flatnonzero(np.abs(dt - step) > 1e-9 * step)
    return RunClock(step, irregular if irregular.size <= MAX_IRREGULAR_SHARE * max(dt.size, 1) else None)


def _exact_step(y: float, u0: float, u1: float, dt_s: float, tau_s: float) -> float:
    """One step of the first-order-hold lag over ``dt_s`` from state ``y`` (input u0 → u1), with
    :func:`uniform_lag`'s coefficients (the series below 10⁻⁶, where 1 − e^{−h} cancels)."""
    lh = dt_s / tau_s
    i0 = dt_s * (1 - lh / 2) if lh < 1e-6 else -np.expm1(-lh) * tau_s
    i1 = dt_s * (0.5 - lh / 6) if lh < 1e-6 else (1 - i0 / dt_s) * tau_s
    return float(np.exp(-lh) * y + (i1 * u1 + (i0 - i1) * u0) / tau_s)


def _uniform_from(u: np.ndarray, dt_s: float, tau_s: float, y0: float) -> np.ndarray:
    """:func:`uniform_lag` of ``u`` started from the state ``y0`` at ``u[0]`` (not from equilibrium)."""
    lam = 1.0 / tau_s
    lh = lam * dt_s
    p = np.exp(-lh)
    i0 = dt_s * (1 - lh / 2) if lh < 1e-6 else -np.expm1(-lh) / lam
    i1 = dt_s * (0.5 - lh / 6) if lh < 1e-6 else (1 - i0 / dt_s) / lam
    b = [lam * i1, lam * (i0 - i1)]
    out = np.empty_like(u)
    out[0] = y0
    if u.size > 1:  # the filter's state after sample 0, about u[0]: b1·v0 + p·(y0 − u0), v0 = 0
        out[1:] = first_order_filter(u[1:] - u[0], b[0], b[1], p, p * (y0 - u[0]))
        out[1:] += u[0]
    return out


def lag_on_clock(time_s: np.ndarray, u: np.ndarray, tau_s: float, clock: RunClock) -> np.ndarray:
    """``lag(u, τ)`` of one run from equilibrium at its start, on its clock (:func:`clock_of`).

    A uniform clock is one IIR filter (:func:`uniform_lag`); a clock uniform but for a few gaps
    (a log whose excluded rows left holes, a dropped sample) is one filter per uniform stretch and
    the exact step across each gap — no per-sample loop, so no compiled kernel to load; a jittered
    clock is :func:`sim.drift.lowpass_at`, every step with its own coefficients. All three are the
    same exact discretisation, so a firmware running the recursion on its measured time steps
    reproduces any of them.

    Parameters
    ----------
    time_s, u : (n,) ndarray
        Sample times [s] and input of one run.
    tau_s : float
        Time constant [s] (≤ 0: no lag).
    clock : RunClock

    Returns
    -------
    (n,) ndarray
    """
    if tau_s <= 0 or u.size < 2:
        return u.copy()
    if clock.irregular is None:
        return lowpass_at(time_s, u, tau_s)
    if not clock.irregular.size:
        return uniform_lag(u, clock.step_s, tau_s)
    out = np.empty_like(u)
    edges = [0, *(clock.irregular + 1).tolist(), u.size]
    out[: edges[1]] = uniform_lag(u[: edges[1]], clock.step_s, tau_s) if edges[1] > 1 else u[:1]
    for a, b in zip(edges[1:-1], edges[2:]):  # across the gap a−1 → a, then the stretch a:b
        y = _exact_step(out[a - 1], u[a - 1], u[a], float(time_s[a] - time_s[a - 1]), tau_s)
        out[a:b] = _uniform_from(u[a:b], clock.step_s, tau_s, y)
    return out


def _lag_segment(time_s: np.ndarray, temperature_c: np.ndarray, tau_s: float) -> np.ndarray:
    if tau_s <= 0 or time_s.size < 2:
        return temperature_c.copy()
    return lag_on_clock(time_s, temperature_c, tau_s, clock_of(time_s))


def lagged_c(log: ThermalLog, tau_s: float) -> np.ndarray:
    """Causal first-order lag ``lag(T, τ)`` [°C] of the log, from equilibrium at each run's start.

    Parameters
    ----------
    log : ThermalLog
        The temperature log.
    tau_s : float
        Time constant [s] (≤ 0: no lag).

    Returns
    -------
    (n,) ndarray
        Lagged temperature [°C].
    """
    out = np.empty_like(log.temperature_c)
    for s in log.segments():
        out[s] = _lag_segment(log.time_s[s], log.temperature_c[s], float(tau_s))
    return out


def train_mask(y: np.ndarray, n: int, mask=None) -> np.ndarray:
    """Rows to fit on: ``mask`` (boolean or indices) and finite ``y``; raise if too few.

    Parameters
    ----------
    y : (n, 3) ndarray
        Readings; rows with NaN are left out.
    n : int
        Rows of ``X``.
    mask : array-like of bool or int, optional
        Rows allowed.

    Returns
    -------
    (n,) ndarray of bool
        The rows to fit on.

    Raises
    ------
    ThermalLogError
        When ``y`` is not (n, 3) or fewer than :data:`MIN_TRAIN_ROWS` rows remain.
    """
    y = np.asarray(y, float)
    if y.shape != (n, 3):
        raise ThermalLogError(f"accel_g must be (n, 3) with n = {n} rows like X; got {y.shape}")
    keep = np.isfinite(y[:, 0])  # column by column: an all() along a short axis is 10× slower
    for k in range(1, y.shape[1]):
        keep &= np.isfinite(y[:, k])
    if mask is not None:
        m = np.asarray(mask)
        sel = np.zeros(n, bool)
        sel[m if m.dtype != bool else np.flatnonzero(m)] = True
        keep &= sel
    if keep.sum() < MIN_TRAIN_ROWS:
        raise ThermalLogError(f"only {int(keep.sum())} rows to fit on (need ≥ {MIN_TRAIN_ROWS} with finite accel_g)")
    return keep
