"""The lag-aware model's parameters for the C header: the per-step coefficients of the exact
first-order-hold lag, and the model of a stored method checked and reduced to plain floats.

The lag τ dy/dt = u − y with u linear over a step of dt integrates exactly to
y[n] = e·y[n−1] + b0·u[n] + b1·u[n−1] with h = dt/τ, e = exp(−h), b0 = 1 − (1 − e)/h,
b1 = (1 − e)/h − e (the discretisation of ``sim.thermal.first_order_lag``).
"""

from __future__ import annotations

import math
import numbers

from twin.firmware.common import AXES, FirmwareCalError


def lag_coefficients_dt(dt_s: float, tau_s: float) -> tuple[float, float, float]:
    """(e, b0, b1) of ``y[n] = e·y[n−1] + b0·u[n] + b1·u[n−1]`` over one step of ``dt_s``.

    Parameters
    ----------
    dt_s : float
        Time step [s], ≥ 0 and finite (0 gives (1, 0, 0): the lag does not move).
    tau_s : float
        Time constant [s], ≥ 0 and finite; 0 gives (0, 1, 0), y = u.

    Returns
    -------
    tuple of float
        The exact first-order-hold discretisation of τ dy/dt = u − y: with h = dt/τ,
        e = exp(−h), b0 = 1 − (1 − e)/h, b1 = (1 − e)/h − e, in float64; for h < 0.5 b0 comes
        from its series Σ_{k≥2} (−1)^k h^{k−1}/k!, which has no cancellation.
    """
    if not (math.isfinite(dt_s) and dt_s >= 0):
        raise FirmwareCalError(f"dt_s must be >= 0 and finite, got {dt_s}")
    if not (math.isfinite(tau_s) and tau_s >= 0):
        raise FirmwareCalError(f"tau_s must be >= 0 and finite, got {tau_s}")
    if tau_s == 0:
        return 0.0, 1.0, 0.0
    h = dt_s / tau_s
    if h == 0:
        return 1.0, 0.0, 0.0
    e = math.exp(-h)
    one_minus_e = -math.expm1(-h)
    if h < 0.5:  # b0 = (h − 1 + e^{−h})/h = Σ_{k≥2} (−1)^k h^{k−1}/k!, without the cancellation
        b0, term, k = 0.0, h / 2.0, 2
        while abs(term) > 1e-18 * abs(b0) or k == 2:
            b0 += term
            k += 1
            term *= -h / k
    else:
        b0 = 1.0 - one_minus_e / h
    return e, b0, one_minus_e - b0


def lag_coefficients(sample_rate_hz: float, tau_s: float) -> tuple[float, float, float]:
    """(e, b0, b1) of :func:`lag_coefficients_dt` at dt = 1/sample_rate_hz; τ = 0 gives (0, 1, 0).

    Parameters
    ----------
    sample_rate_hz : float
        Update rate [Hz].
    tau_s : float
        Time constant [s], ≥ 0.

    Returns
    -------
    tuple of float
        (e, b0, b1) [1].

    References
    ----------
    Exact first-order-hold discretisation of τ dy/dt = u − y (module docstring), a standard result.
    """
    if not (math.isfinite(sample_rate_hz) and sample_rate_hz > 0):
        raise FirmwareCalError(f"sample_rate_hz must be positive and finite, got {sample_rate_hz}")
    if not (math.isfinite(tau_s) and tau_s >= 0):
        raise FirmwareCalError(f"tau_s must be >= 0 and finite, got {tau_s}")
    return lag_coefficients_dt(1.0 / sample_rate_hz, tau_s)


def finite_number(value, what: str) -> float:
    """``value`` as a float, refused (:class:`FirmwareCalError`) unless a finite real number.

    Parameters
    ----------
    value : float
        The value [any unit].
    what : str
        Name in messages.

    Returns
    -------
    float
        The value [unit of ``value``].
    """
    if isinstance(value, bool) or not isinstance(value, numbers.Real) or not math.isfinite(float(value)):
        raise FirmwareCalError(f"{what} must be a finite number, got {value!r}")
    return float(value)


def _per_axis(params: dict, key: str, *, optional_entries: bool = False) -> list:
    values = params.get(key)
    if isinstance(values, (str, bytes)) or not hasattr(values, "__len__") or len(values) != len(AXES):
        raise FirmwareCalError(f"params[{key!r}] must hold {len(AXES)} values (x, y, z), got {values!r}")
    return [None if (v is None and optional_entries) else finite_number(v, f"params[{key!r}][{i}]")
            for i, v in enumerate(values)]


def check_lag_aware_params(params: dict) -> dict:
    """The model of ``params`` (``method_json`` of a LagAwareCompensator) as plain floats.

    Missing or None ``tau_die_s`` means no die lag (T_die = T) and missing or None ``tau_rate_s``
    no rate term, as ``twin.calibration.deploy.correction_g`` reads them. Raises FirmwareCalError.

    Parameters
    ----------
    params : dict
        The stored method.

    Returns
    -------
    dict
        ``reference_c`` [°C], ``coef_mg`` [mg/°C^k] per axis, ``tau_die_s`` and ``tau_rate_s`` [s]
        per axis, ``rate_mg_per_c`` [mg/°C] per axis.
    """
    if not isinstance(params, dict):
        raise FirmwareCalError(f"params must be a dict (a lag-aware method), got {type(params).__name__}")
    for key in ("reference_c", "coef_mg"):
        if key not in params:
            raise FirmwareCalError(f"params lacks {key!r}; expected reference_c, coef_mg, tau_die_s, tau_rate_s, "
                                   "rate_mg_per_c")
    reference_c = finite_number(params["reference_c"], "params['reference_c']")
    rows = params["coef_mg"]
    if isinstance(rows, (str, bytes)) or not hasattr(rows, "__len__") or len(rows) != len(AXES):
        raise FirmwareCalError(f"params['coef_mg'] must hold {len(AXES)} coefficient lists (x, y, z)")
    coef = []
    for a, row in enumerate(rows):
        if isinstance(row, (str, bytes)) or not hasattr(row, "__len__") or len(row) < 1:
            raise FirmwareCalError(f"params['coef_mg'][{a}] must be a non-empty list of mg/degC^k, got {row!r}")
        coef.append([finite_number(v, f"params['coef_mg'][{a}][{k}]") for k, v in enumerate(row)])
    if len({len(r) for r in coef}) != 1:
        raise FirmwareCalError(f"params['coef_mg'] rows differ in length: {[len(r) for r in coef]}")
    tau_die = [0.0] * len(AXES) if params.get("tau_die_s") is None else _per_axis(params, "tau_die_s")
    tau_rate = ([None] * len(AXES) if params.get("tau_rate_s") is None
                else _per_axis(params, "tau_rate_s", optional_entries=True))
    for key, taus in (("tau_die_s", tau_die), ("tau_rate_s", tau_rate)):
        bad = [t for t in taus if t is not None and t < 0]
        if bad:
            raise FirmwareCalError(f"params[{key!r}] must be >= 0 s, got {bad[0]}")
    rate = [0.0] * len(AXES)
    if any(t is not None for t in tau_rate):
        rate = _per_axis(params, "rate_mg_per_c")
    rate = [r if t is not None else 0.0 for r, t in zip(rate, tau_rate)]
    return {"reference_c": reference_c, "coef_mg": coef, "tau_die_s": tau_die, "tau_rate_s": tau_rate,
            "rate_mg_per_c": rate}
