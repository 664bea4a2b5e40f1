"""A self-contained C header for the lag-aware ("twin") temperature compensation.

Per axis a (the model :class:`twin.calibration.lagaware.LagAwareCompensator` fits, stored by
``twin.calibration.workflow.method_json``)::

    correction[a] = Σ_{k≥1} c[a][k]·(T_die[a] − T_ref)^k + b[a]·(T − T_g[a])
    T_die[a] = lag(T, τ_die[a]),  T_g[a] = lag(T, τ_rate[a])

The level c[a][0] is left out: the ordinary accelerometer calibration owns it. ``lag`` is the
exact response of τ dy/dt = u − y to a piecewise-linear input (first-order hold, the
discretisation of ``sim.thermal.first_order_lag``), starting in equilibrium at the first sample.
With h = dt/τ and e = exp(−h) it is the recursion

    y[n] = e·y[n−1] + b0·u[n] + b1·u[n−1],  b0 = 1 − (1 − e)/h,  b1 = (1 − e)/h − e,

which the header runs as y += b0·(u[n] − y) + b1·(u[n−1] − y): a DC gain of exactly 1 whatever the
rounding of b0 and b1. With e close to 1 a float state would stop moving once the increment is
below half an ulp (a dead band of ulp(T)/(2(1 − e)), 11 mK for τ = 600 s at 10 Hz), so the state
is a float pair, value and rounding residual (Kahan summation), as in :mod:`twin.firmware.c_header`.
"""

from __future__ import annotations

import math
import numbers
import re
from pathlib import Path

from twin.firmware.common import AXES, G0_M_S2, FirmwareCalError, c_float, generator_name
from twin.io import atomic_write_text

MG_TO_M_S2 = G0_M_S2 * 1e-3  # 1 mg in m/s²


def lag_coefficients(sample_rate_hz: float, tau_s: float) -> tuple[float, float, float]:
    """(e, b0, b1) of ``y[n] = e·y[n−1] + b0·u[n] + b1·u[n−1]``, the exact first-order-hold
    discretisation of τ dy/dt = u − y at dt = 1/sample_rate_hz; τ = 0 gives (0, 1, 0), y = u."""
    if not (math.isfinite(sample_rate_hz) and sample_rate_hz > 0):
        raise FirmwareCalError(f"sample_rate_hz must be positive and finite, got {sample_rate_hz}")
    if not (math.isfinite(tau_s) and tau_s >= 0):
        raise FirmwareCalError(f"tau_s must be >= 0 and finite, got {tau_s}")
    if tau_s == 0:
        return 0.0, 1.0, 0.0
    h = 1.0 / (sample_rate_hz * tau_s)
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


def _number(value, what: str) -> float:
    if isinstance(value, bool) or not isinstance(value, numbers.Real) or not math.isfinite(float(value)):
        raise FirmwareCalError(f"{what} must be a finite number, got {value!r}")
    return float(value)


def _per_axis(params: dict, key: str, *, optional_entries: bool = False) -> list:
    values = params.get(key)
    if isinstance(values, (str, bytes)) or not hasattr(values, "__len__") or len(values) != len(AXES):
        raise FirmwareCalError(f"params[{key!r}] must hold {len(AXES)} values (x, y, z), got {values!r}")
    return [None if (v is None and optional_entries) else _number(v, f"params[{key!r}][{i}]")
            for i, v in enumerate(values)]


def check_lag_aware_params(params: dict) -> dict:
    """The model of ``params`` (``method_json`` of a LagAwareCompensator) as plain floats.

    Missing or None ``tau_die_s`` means no die lag (T_die = T) and missing or None ``tau_rate_s``
    no rate term, as ``twin.calibration.deploy.correction_g`` reads them. Raises FirmwareCalError.
    """
    if not isinstance(params, dict):
        raise FirmwareCalError(f"params must be a dict (a lag-aware method), got {type(params).__name__}")
    for key in ("reference_c", "coef_mg"):
        if key not in params:
            raise FirmwareCalError(f"params lacks {key!r}; expected reference_c, coef_mg, tau_die_s, tau_rate_s, "
                                   "rate_mg_per_c")
    reference_c = _number(params["reference_c"], "params['reference_c']")
    rows = params["coef_mg"]
    if isinstance(rows, (str, bytes)) or not hasattr(rows, "__len__") or len(rows) != len(AXES):
        raise FirmwareCalError(f"params['coef_mg'] must hold {len(AXES)} coefficient lists (x, y, z)")
    coef = []
    for a, row in enumerate(rows):
        if isinstance(row, (str, bytes)) or not hasattr(row, "__len__") or len(row) < 1:
            raise FirmwareCalError(f"params['coef_mg'][{a}] must be a non-empty list of mg/degC^k, got {row!r}")
        coef.append([_number(v, f"params['coef_mg'][{a}][{k}]") for k, v in enumerate(row)])
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


def _literal(value: float, real: str) -> str:
    if real == "float":
        return c_float(value)
    text = repr(float(value))
    return text if any(ch in text for ch in ".e") else text + ".0"


def _table(rows, real: str, notes) -> str:
    rows = list(rows)
    return "\n".join("    {" + ", ".join(_literal(v, real) for v in row) + "}" + ("," if i < len(rows) - 1 else " ")
                     + f"  /* {note} */" for i, (row, note) in enumerate(zip(rows, notes)))


def _model_lines(m: dict) -> str:
    lines = []
    for a, ax in enumerate(AXES):
        poly = " ".join(f"{c:+.6g} mg/degC^{k} dT^{k}" for k, c in enumerate(m["coef_mg"][a]) if k >= 1) or "0"
        rate = (f"; {m['rate_mg_per_c'][a]:+.6g} mg/degC (T - T_g), tau_rate = {m['tau_rate_s'][a]:g} s"
                if m["tau_rate_s"][a] is not None else "")
        lines.append(f" *   {ax}: {poly}; tau_die = {m['tau_die_s'][a]:g} s{rate}"
                     f" (level {m['coef_mg'][a][0]:+.6g} mg left out)")
    return "\n".join(lines)


def lag_aware_c_header(params: dict, sample_rate_hz: float, *, prefix: str = "twin_lag", real: str = "float") -> str:
    """C99 header text applying the lag-aware compensation ``params`` sampled at ``sample_rate_hz``.

    Parameters
    ----------
    params : dict
        reference_c, coef_mg (3 lists, mg/°C^k ascending), tau_die_s (3), tau_rate_s (3, None where
        an axis has no rate term), rate_mg_per_c (3): ``twin.calibration.workflow.method_json`` of a
        LagAwareCompensator.
    sample_rate_hz : float
        Rate at which the firmware calls ``{prefix}_update`` [Hz]; the filter coefficients hold
        for it only.
    prefix : str
        C identifier prefix (lower case; macros use it upper-cased).
    real : {"float", "double"}
        Arithmetic type of constants, state and API.

    Returns
    -------
    str
        Defines ``{prefix}_state``, ``{prefix}_init(&s)``, ``{prefix}_update(&s, T)`` (once per sample),
        ``{prefix}_correction_m_s2(&s, T, out[3])`` and ``{prefix}_correct_m_s2(&s, T, accel[3])``
        (accel −= correction). No dynamic memory.
    """
    if not isinstance(prefix, str) or not re.fullmatch(r"[a-z_][a-z0-9_]*", prefix):
        raise FirmwareCalError(f"prefix {prefix!r} is not a lower-case C identifier")
    if real not in ("float", "double"):
        raise FirmwareCalError(f"real must be 'float' or 'double', got {real!r}")
    rate_hz = _number(sample_rate_hz, "sample_rate_hz")
    if rate_hz <= 0:
        raise FirmwareCalError(f"sample_rate_hz must be positive, got {sample_rate_hz}")
    m = check_lag_aware_params(params)
    n_axes, n_coeff = len(AXES), len(m["coef_mg"][0])
    up, r = prefix.upper(), f"{prefix}_real"
    die = [lag_coefficients(rate_hz, t) for t in m["tau_die_s"]]
    grad = [lag_coefficients(rate_hz, t or 0.0) for t in m["tau_rate_s"]]
    die_on = [int(t > 0) for t in m["tau_die_s"]]
    grad_on = [int(t is not None and t > 0) for t in m["tau_rate_s"]]
    poly = [[0.0] + [c * MG_TO_M_S2 for c in row[1:]] for row in m["coef_mg"]]
    rate = [b * MG_TO_M_S2 for b in m["rate_mg_per_c"]]
    die_notes = [f"{ax}: tau {t:g} s" for ax, t in zip(AXES, m["tau_die_s"])]
    grad_notes = [f"{ax}: tau {t:g} s" if t is not None else f"{ax}: no rate term"
                  for ax, t in zip(AXES, m["tau_rate_s"])]
    units = ", ".join(["0 (level left out)", "m/s^2/degC"] + [f"m/s^2/degC^{k}" for k in range(2, n_coeff)])
    ints = ", ".join
    text = f"""/* {prefix}.h: lag-aware accelerometer temperature compensation, generated by {generator_name()}.
 * Per axis a, with dT = T_die[a] - TREF:
 *   correction[a] = sum_k coeff[a][k] * dT^k + rate_coeff[a] * (T - T_g[a])   [m/s^2]
 *   T_die[a] = lag(T, tau_die[a]), T_g[a] = lag(T, tau_rate[a]): first-order lags of the measured
 *   temperature T, exact for T linear between samples, started in equilibrium at the first sample.
 * Fitted model (mg, reference {m['reference_c']:g} degC):
{_model_lines(m)}
 * Coefficient units by k: {units}.
 * Use: {prefix}_init(&s) once; per sample at {rate_hz:g} Hz, {prefix}_update(&s, T) then
 * {prefix}_correct_m_s2(&s, T, accel) (accel -= correction, sensor frame, in m/s^2).
 * The filters hold for {rate_hz:g} Hz only: regenerate the header for another rate.
 * Do not build with -ffast-math: it would optimise away the compensated (Kahan) filter state.
 */
#ifndef {up}_H
#define {up}_H

typedef {real} {r};

#define {up}_N_AXES {n_axes}
#define {up}_N_COEFF {n_coeff}
#define {up}_SAMPLE_RATE_HZ {_literal(rate_hz, real)}

static const {r} {prefix}_tref_c = {_literal(m['reference_c'], real)};
static const {r} {prefix}_coeff[{up}_N_AXES][{up}_N_COEFF] = {{
{_table(poly, real, AXES)}
}};
static const {r} {prefix}_rate_coeff[{up}_N_AXES] = {{{", ".join(_literal(v, real) for v in rate)}}};  /* m/s^2/degC */

/* Lag y[n] = e*y[n-1] + b0*u[n] + b1*u[n-1] per axis, rows {{e, b0, b1}}; *_lagged = 0: y = u. */
static const int {prefix}_die_lagged[{up}_N_AXES] = {{{ints(str(v) for v in die_on)}}};
static const {r} {prefix}_die_lag[{up}_N_AXES][3] = {{
{_table(die, real, die_notes)}
}};
static const int {prefix}_rate_lagged[{up}_N_AXES] = {{{ints(str(v) for v in grad_on)}}};
static const {r} {prefix}_rate_lag[{up}_N_AXES][3] = {{
{_table(grad, real, grad_notes)}
}};

typedef struct {{
    {r} die_c[{up}_N_AXES];     /* T_die, high part [degC]; true value = die_c - die_res */
    {r} die_res[{up}_N_AXES];   /* rounding residual of die_c */
    {r} grad_c[{up}_N_AXES];    /* T_g, high part [degC] */
    {r} grad_res[{up}_N_AXES];
    {r} t_prev_c;               /* previous measured temperature (first-order hold) */
    int started;
}} {prefix}_state;

static inline void {prefix}_init({prefix}_state *state)
{{
    for (int a = 0; a < {up}_N_AXES; a++) {{
        state->die_c[a] = state->die_res[a] = state->grad_c[a] = state->grad_res[a] = 0;
    }}
    state->t_prev_c = 0;
    state->started = 0;
}}

/* y += b0*(u - y) + b1*(u_prev - y) by Kahan summation on the pair (hi, res), y = hi - res. */
static inline void {prefix}_lag_step({r} *hi, {r} *res, const {r} coef[3], {r} u, {r} u_prev)
{{
    const {r} step = coef[1] * ((u - *hi) + *res) + coef[2] * ((u_prev - *hi) + *res);
    const {r} y = step - *res;
    const {r} t = *hi + y;
    *res = (t - *hi) - y;
    *hi = t;
}}

/* Advance the lags by one sample; call once per sample at {up}_SAMPLE_RATE_HZ. */
static inline void {prefix}_update({prefix}_state *state, {r} t_meas_c)
{{
    if (!state->started) {{
        for (int a = 0; a < {up}_N_AXES; a++) {{
            state->die_c[a] = state->grad_c[a] = t_meas_c;
            state->die_res[a] = state->grad_res[a] = 0;
        }}
        state->started = 1;
    }} else {{
        for (int a = 0; a < {up}_N_AXES; a++) {{
            if ({prefix}_die_lagged[a]) {{
                {prefix}_lag_step(&state->die_c[a], &state->die_res[a], {prefix}_die_lag[a], t_meas_c, state->t_prev_c);
            }}
            if ({prefix}_rate_lagged[a]) {{
                {prefix}_lag_step(&state->grad_c[a], &state->grad_res[a], {prefix}_rate_lag[a], t_meas_c,
                                  state->t_prev_c);
            }}
        }}
    }}
    state->t_prev_c = t_meas_c;
}}

/* The correction [m/s^2] at the state after {prefix}_update(state, t_meas_c) (same t_meas_c).
 * Before the first update the lags are taken in equilibrium at t_meas_c. */
static inline void {prefix}_correction_m_s2(const {prefix}_state *state, {r} t_meas_c, {r} out_m_s2[{up}_N_AXES])
{{
    for (int a = 0; a < {up}_N_AXES; a++) {{
        const int die = state->started && {prefix}_die_lagged[a];
        const int grad = state->started && {prefix}_rate_lagged[a];
        const {r} dt = die ? (state->die_c[a] - {prefix}_tref_c) - state->die_res[a] : t_meas_c - {prefix}_tref_c;
        const {r} gradient = grad ? (t_meas_c - state->grad_c[a]) + state->grad_res[a] : 0;
        {r} acc = {prefix}_coeff[a][{up}_N_COEFF - 1];
        for (int k = {up}_N_COEFF - 2; k >= 0; k--) {{
            acc = acc * dt + {prefix}_coeff[a][k];
        }}
        out_m_s2[a] = acc + {prefix}_rate_coeff[a] * gradient;
    }}
}}

static inline void {prefix}_correct_m_s2(const {prefix}_state *state, {r} t_meas_c, {r} accel_m_s2[{up}_N_AXES])
{{
    {r} correction[{up}_N_AXES];
    {prefix}_correction_m_s2(state, t_meas_c, correction);
    for (int a = 0; a < {up}_N_AXES; a++) {{
        accel_m_s2[a] -= correction[a];
    }}
}}

#endif /* {up}_H */
"""
    return text


def write_lag_aware_c_header(path, params: dict, sample_rate_hz: float, **kwargs) -> Path:
    """Write :func:`lag_aware_c_header` atomically to ``path`` (a ``.h`` file); return the path."""
    return atomic_write_text(Path(path), lag_aware_c_header(params, sample_rate_hz, **kwargs))
