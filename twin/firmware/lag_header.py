"""A self-contained C header for the lag-aware ("twin") temperature compensation.

Per axis a (the model :class:`twin.calibration.lagaware.LagAwareCompensator` fits, stored by
``twin.calibration.document.method_json``)::

    correction[a] = Σ_{k≥1} c[a][k]·(T_die[a] − T_ref)^k + b[a]·(T − T_g[a])
    T_die[a] = lag(T, τ_die[a]),  T_g[a] = lag(T, τ_rate[a])

The level c[a][0] is left out: the ordinary accelerometer calibration owns it. ``lag`` is the
exact response of τ dy/dt = u − y to a piecewise-linear input (first-order hold, the
discretisation of ``sim.thermal.first_order_lag``), starting in equilibrium at the first sample.
Over a step of dt with h = dt/τ and e = exp(−h) it is the recursion

    y[n] = e·y[n−1] + b0·u[n] + b1·u[n−1],  b0 = 1 − (1 − e)/h,  b1 = (1 − e)/h − e

(integrate τ dy/dt = u − y with u linear over the step; :mod:`twin.firmware.hold_coefficients`
writes its C). Logged clocks jitter (0.502–0.511 s
on a nominal 0.505 s step in the TofuPilot log), so the header computes (e, b0, b1) from the
measured step on every call instead of baking in one sample rate.

The header runs it as y += b0·(u[n] − y) + b1·(u[n−1] − y): a DC gain of exactly 1 whatever the
rounding of b0 and b1. With e close to 1 a float state would stop moving once the increment is
below half an ulp (a dead band of ulp(T)/(2(1 − e)), 11 mK for τ = 600 s at 10 Hz), so the state
is a float pair, value and rounding residual (Kahan summation), as in :mod:`twin.firmware.c_header`.
The polynomial is evaluated by the compensated Horner scheme (Graillat, Langlois & Louvet,
"Compensated Horner scheme", 2005) with the coefficients and the lagged temperature as float
pairs, so that a float32 build stays within a few float32 ulps of the float64 correction.
"""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np

from twin.firmware.common import AXES, G0_M_S2, FirmwareCalError, generator_name
from twin.firmware.hold_coefficients import c_literal, hold_coefficients_c
from twin.firmware.lag_params import check_lag_aware_params, finite_number
from twin.io import atomic_write_text

MG_TO_M_S2 = G0_M_S2 * 1e-3  # 1 mg in m/s²


def _table(rows, real: str, notes) -> str:
    rows = list(rows)
    return "\n".join("    {" + ", ".join(c_literal(v, real) for v in row) + "}" + ("," if i < len(rows) - 1 else " ")
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


def _split(value: float, real: str) -> tuple[float, float]:
    """(hi, lo) with hi the ``real`` nearest ``value`` and lo the float rounding of the rest: the
    pair carries ~48 bits in float32, so a float32 coefficient's rounding (3e-6 mg on a 45 mg
    term) does not eat the 0.01 µg budget."""
    if real == "double":
        return float(value), 0.0
    hi = float(np.float32(value))
    return hi, float(np.float32(value - hi))


def lag_aware_c_header(params: dict, sample_rate_hz: float | None = None, *, prefix: str = "twin_lag",
                       real: str = "float") -> str:
    """C99 header text applying the lag-aware compensation ``params`` at the measured time steps.

    Parameters
    ----------
    params : dict
        reference_c, coef_mg (3 lists, mg/°C^k ascending), tau_die_s (3), tau_rate_s (3, None where
        an axis has no rate term), rate_mg_per_c (3): ``twin.calibration.document.method_json`` of a
        LagAwareCompensator.
    sample_rate_hz : float, optional
        Nominal rate [Hz]. Only for the fixed-rate convenience ``{prefix}_update_fixed`` (and the
        ``{PREFIX}_NOMINAL_DT_S`` macro); the filters themselves hold for any step. None: neither
        is written.
    prefix : str
        C identifier prefix (lower case; macros use it upper-cased).
    real : {"float", "double"}
        Arithmetic type of constants, state and API.

    Returns
    -------
    str
        A header without dynamic memory that defines ``{prefix}_state``, ``{prefix}_init(&s)`` and, per
        sample (the correction [m/s²] is written to ``out``; the firmware subtracts it),

        - ``int {prefix}_update(&s, T, uint64_t timestamp_us, out[3])``, the recommended call:
          firmware stamps samples with a 64-bit microsecond clock (PX4 ``timestamp_sample``,
          ArduPilot ``AP_HAL::micros64()``), and the header differences it in integers, exact at any
          uptime. A caller forming dt from a float32 time in seconds would lose it: at one day of
          uptime float32 resolves 7.8 ms, 1.5 % of a 0.5 s step. The clock going backwards (a
          reboot, a new log) restarts the lags here, so every caller does it the same way.
        - ``int {prefix}_update_dt(&s, T, dt_s, out[3])``, the same with the step [s], for firmware
          whose clock is a sample counter.
        - ``int {prefix}_update_fixed(&s, T, out[3])``, the step fixed at 1/sample_rate_hz (only
          when ``sample_rate_hz`` is given).

        The first call after init starts the lags in equilibrium at T, as
        ``twin.calibration.lag.lagged_c`` does at the start of every run; call init again to start
        a new run. A step that is negative, NaN or +inf (or a timestamp earlier than the last one)
        restarts them the same way (status ``{PREFIX}_RESTARTED``): the exact lag over an infinite
        step is equilibrium, and a clock that went backwards marks a new run. A zero step holds the
        lags (the h → 0 limit of the recursion). Long finite gaps need nothing special: the
        recursion is exact for T linear across the gap, as ``lagged_c`` interpolates it. A
        non-finite T leaves the state untouched and repeats the previous correction (status
        ``{PREFIX}_REJECTED``).

    Notes
    -----
    Per call and per distinct time constant the header evaluates the first-order-hold
    coefficients for the step (:func:`lag_coefficients_dt`; at most one ``expf`` and one
    ``expm1f``): for h = dt/τ < 0.25 the form b0 = 1 − (1 − e)/h would cancel (b0 ≈ h/2 while
    (1 − e)/h ≈ 1), so b0 and b1 come from their Taylor series, b0 = Σ_{k≥1} (−1)^{k+1} h^k/(k+1)!
    and b1 = Σ_{k≥1} (−1)^{k+1} k h^k/(k+1)!, which keep full relative precision down to h = 0.

    Precision of a float build against the same model in float64: the lags are float pairs
    (Kahan), the polynomial and the rate term are compensated (constants as float pairs too), so
    what remains is the final rounding of the correction, half a float32 ulp: 0.003 µg at 80 mg.
    From 2 m/s² (204 mg) up, where half an ulp is 0.012 µg, no float can hold a correction to 0.01 µg.

    ``twin apply`` (``twin.calibration.lag.lagged_c``) lags a log whose clock drifts more than 5 %
    of a step from uniform on a uniform grid at the median step and interpolates back; on such a
    log it differs from the exact lag this header runs (by up to 36 µg on the TofuPilot log).
    """
    if not isinstance(prefix, str) or not re.fullmatch(r"[a-z_][a-z0-9_]*", prefix):
        raise FirmwareCalError(f"prefix {prefix!r} is not a lower-case C identifier")
    if real not in ("float", "double"):
        raise FirmwareCalError(f"real must be 'float' or 'double', got {real!r}")
    rate_hz = None
    if sample_rate_hz is not None:
        rate_hz = finite_number(sample_rate_hz, "sample_rate_hz")
        if rate_hz <= 0:
            raise FirmwareCalError(f"sample_rate_hz must be positive, got {sample_rate_hz}")
    m = check_lag_aware_params(params)
    n_axes, n_coeff = len(AXES), len(m["coef_mg"][0])
    up, r = prefix.upper(), f"{prefix}_real"
    exp_fn, expm1_fn, fma_fn = ("expf", "expm1f", "fmaf") if real == "float" else ("exp", "expm1", "fma")
    # one filter per distinct τ: a shared τ (one die for three axes) costs one exp, not three
    taus: list[float] = []
    for t in m["tau_die_s"] + m["tau_rate_s"]:
        if t is not None and t > 0 and t not in taus:
            taus.append(t)
    die_index = [taus.index(t) if t > 0 else -1 for t in m["tau_die_s"]]
    rate_index = [taus.index(t) if t is not None and t > 0 else -1 for t in m["tau_rate_s"]]
    coeff = [[_split(c * MG_TO_M_S2 if k else 0.0, real) for k, c in enumerate(row)] for row in m["coef_mg"]]
    tref_hi, tref_lo = _split(m["reference_c"], real)
    rate = [_split(b * MG_TO_M_S2 if i >= 0 else 0.0, real) for b, i in zip(m["rate_mg_per_c"], rate_index)]
    units = ", ".join(["0 (level left out)", "m/s^2/degC"] + [f"m/s^2/degC^{k}" for k in range(2, n_coeff)])
    lag_notes = ", ".join(f"{t:g} s" for t in taus) or "none"
    ints = ", ".join

    def row(values):
        return ", ".join(c_literal(v, real) for v in values)

    slots = f"{up}_LAG_SLOTS"
    nominal, fixed = "", ""
    if rate_hz is not None:
        nominal = f"""
#define {up}_SAMPLE_RATE_HZ {c_literal(rate_hz, real)}
#define {up}_NOMINAL_DT_S {c_literal(1.0 / rate_hz, real)}"""
        fixed = f"""
/* Fixed-rate convenience: the step taken as {up}_NOMINAL_DT_S. Prefer {prefix}_update with the
 * sample's timestamp: a clock {rate_hz:g} Hz only on average makes the lags drift by the jitter. */
static inline int {prefix}_update_fixed({prefix}_state *state, {r} temperature_c, {r} out_correction_m_s2[{up}_N_AXES])
{{
    return {prefix}_update_dt(state, temperature_c, {up}_NOMINAL_DT_S, out_correction_m_s2);
}}
"""
    text = f"""/* {prefix}.h: lag-aware accelerometer temperature compensation, generated by {generator_name()}.
 * Per axis a, with dT = T_die[a] - TREF:
 *   correction[a] = sum_k coeff[a][k] * dT^k + rate_coeff[a] * (T - T_g[a])   [m/s^2]
 *   T_die[a] = lag(T, tau_die[a]), T_g[a] = lag(T, tau_rate[a]): first-order lags of the measured
 *   temperature T, exact for T linear between samples, started in equilibrium at the first sample.
 * Fitted model (mg, reference {m['reference_c']:g} degC):
{_model_lines(m)}
 * Coefficient units by k: {units}.
 * Use: {prefix}_init(&s) once (and again to start a new run); per sample
 *   {prefix}_update(&s, T, timestamp_us, corr); accel[a] -= corr[a];   (sensor frame, m/s^2)
 * with the sample's own timestamp [us]. The lags use the measured step, so clock jitter, dropped
 * samples and gaps are handled exactly; {prefix}_update_dt takes the step in seconds instead.
 * Needs <math.h> (link with -lm on hosted systems). Do not build with -ffast-math: it would
 * optimise away the compensated (Kahan) state and polynomial, and the checks for NaN.
 */
#ifndef {up}_H
#define {up}_H

#include <math.h>
#include <stdint.h>

typedef {real} {r};

#define {up}_N_AXES {n_axes}
#define {up}_N_COEFF {n_coeff}
#define {up}_N_LAGS {len(taus)}  /* distinct time constants: {lag_notes} */
#define {up}_LAG_SLOTS ({up}_N_LAGS > 0 ? {up}_N_LAGS : 1)  /* C has no zero-length arrays */{nominal}

/* Status returned by the update functions:
 * STEPPED: the lags advanced by the step (a zero step, a repeated timestamp, holds them);
 * RESTARTED: the lags (re)started in equilibrium at T, as twin apply does at the start of a run:
 *   first call after init, or a step that is negative, NaN or infinite (a timestamp earlier than
 *   the last one: a reboot or a new log);
 * REJECTED: T is not finite; the state is untouched and out repeats the previous correction. */
#define {up}_STEPPED 0
#define {up}_RESTARTED 1
#define {up}_REJECTED 2

/* TREF = tref_c + tref_lo_c, coeff + coeff_lo and rate_coeff + rate_coeff_lo: float pairs, so that
 * rounding the constants to {real} costs nothing against the final rounding of the correction. */
static const {r} {prefix}_tref_c = {c_literal(tref_hi, real)};
static const {r} {prefix}_tref_lo_c = {c_literal(tref_lo, real)};
static const {r} {prefix}_coeff[{up}_N_AXES][{up}_N_COEFF] = {{
{_table([[hi for hi, _ in row] for row in coeff], real, AXES)}
}};
static const {r} {prefix}_coeff_lo[{up}_N_AXES][{up}_N_COEFF] = {{
{_table([[lo for _, lo in row] for row in coeff], real, AXES)}
}};
static const {r} {prefix}_rate_coeff[{up}_N_AXES] = {{{row([hi for hi, _ in rate])}}};  /* m/s^2/degC */
static const {r} {prefix}_rate_coeff_lo[{up}_N_AXES] = {{{row([lo for _, lo in rate])}}};

/* 1/tau [1/s] of each distinct lag, and which lag each axis reads (-1: T_die = T, resp. no rate term). */
static const {r} {prefix}_inv_tau_per_s[{slots}] = {{{row([1.0 / t for t in taus] or [0.0])}}};
static const int {prefix}_die_lag[{up}_N_AXES] = {{{ints(str(v) for v in die_index)}}};
static const int {prefix}_rate_lag[{up}_N_AXES] = {{{ints(str(v) for v in rate_index)}}};

typedef struct {{
    {r} lag_c[{slots}];    /* lagged temperature, high part [degC]; true value = lag_c - lag_res */
    {r} lag_res[{slots}];  /* rounding residual of lag_c */
    {r} t_prev_c;          /* previous accepted temperature (first-order hold) */
    {r} correction_m_s2[{up}_N_AXES];  /* last correction, repeated for a rejected sample */
    uint64_t t_prev_us;    /* previous timestamp, for {prefix}_update */
    int started;
}} {prefix}_state;

static inline void {prefix}_init({prefix}_state *state)
{{
    for (int i = 0; i < {slots}; i++) {{
        state->lag_c[i] = state->lag_res[i] = 0;
    }}
    for (int a = 0; a < {up}_N_AXES; a++) {{
        state->correction_m_s2[a] = 0;
    }}
    state->t_prev_c = 0;
    state->t_prev_us = 0;
    state->started = 0;
}}

{hold_coefficients_c(prefix, real)}

/* y += b0*(u - y) + b1*(u_prev - y) by Kahan summation on the pair (hi, res), y = hi - res. */
static inline void {prefix}_lag_step({r} *hi, {r} *res, {r} b0, {r} b1, {r} u, {r} u_prev)
{{
    const {r} step = b0 * ((u - *hi) + *res) + b1 * ((u_prev - *hi) + *res);
    const {r} y = step - *res;
    const {r} t = *hi + y;
    *res = (t - *hi) - y;
    *hi = t;
}}

/* s + err = a + b exactly (Knuth's TwoSum; no products, so FMA contraction cannot touch it). */
static inline void {prefix}_two_sum({r} a, {r} b, {r} *s, {r} *err)
{{
    const {r} sum = a + b, bb = sum - a;
    *err = (a - (sum - bb)) + (b - bb);
    *s = sum;
}}

/* Correction of axis a [m/s^2] from the current lags by the compensated Horner scheme (Graillat,
 * Langlois & Louvet 2005): each product's and sum's rounding error (fma, TwoSum) is carried in err,
 * and the low parts of the coefficients and of dT (the Kahan residual) enter through err and
 * p'(dT)*dT_lo, so only the final rounding remains (half an ulp: 0.003 ug at 80 mg). Plain Horner
 * in float is several ulps off, 0.016 ug on a model fitted to a real log: more than the 0.01 ug
 * the header is held to against float64. */
static inline {r} {prefix}_axis_m_s2(const {prefix}_state *state, int a, {r} temperature_c)
{{
    const int die = {prefix}_die_lag[a], grad = {prefix}_rate_lag[a];
    {r} x, x_lo, acc = {prefix}_coeff[a][{up}_N_COEFF - 1], err = {prefix}_coeff_lo[a][{up}_N_COEFF - 1], slope = 0;
    {prefix}_two_sum(die >= 0 ? state->lag_c[die] : temperature_c, -{prefix}_tref_c, &x, &x_lo);
    x_lo -= (die >= 0 ? state->lag_res[die] : 0) + {prefix}_tref_lo_c;
    for (int k = {up}_N_COEFF - 2; k >= 0; k--) {{
        const {r} p = acc * x, p_err = {fma_fn}(acc, x, -p);
        {r} s_err;
        slope = slope * x + acc;
        {prefix}_two_sum(p, {prefix}_coeff[a][k], &acc, &s_err);
        err = err * x + ((p_err + s_err) + {prefix}_coeff_lo[a][k]);
    }}
    err += slope * x_lo;
    if (grad >= 0) {{  /* b*(T - T_g) the same way: it can be the larger part of the correction */
        const {r} b = {prefix}_rate_coeff[a];
        {r} g, g_lo, s_err;
        {prefix}_two_sum(temperature_c, -state->lag_c[grad], &g, &g_lo);
        g_lo += state->lag_res[grad];
        const {r} p = b * g;
        err += {fma_fn}(b, g, -p) + (b * g_lo + {prefix}_rate_coeff_lo[a] * g);
        {prefix}_two_sum(acc, p, &acc, &s_err);
        err += s_err;
    }}
    return acc + err;
}}

/* Advance the lags by a step of dt_s [s] to the temperature T [degC] and write the correction
 * [m/s^2] (subtract it from the reading). Returns {up}_STEPPED, {up}_RESTARTED or {up}_REJECTED. */
static inline int {prefix}_update_dt({prefix}_state *state, {r} temperature_c, {r} dt_s,
                                     {r} out_correction_m_s2[{up}_N_AXES])
{{
    int status = {up}_STEPPED;
    if (!isfinite(temperature_c)) {{
        for (int a = 0; a < {up}_N_AXES; a++) {{
            out_correction_m_s2[a] = state->correction_m_s2[a];
        }}
        return {up}_REJECTED;
    }}
    if (!state->started || !(dt_s >= 0) || !isfinite(dt_s)) {{
        for (int i = 0; i < {up}_N_LAGS; i++) {{
            state->lag_c[i] = temperature_c;
            state->lag_res[i] = 0;
        }}
        state->started = 1;
        status = {up}_RESTARTED;
    }} else {{
        for (int i = 0; i < {up}_N_LAGS; i++) {{
            {r} b0, b1;
            {prefix}_hold_coefficients(dt_s * {prefix}_inv_tau_per_s[i], &b0, &b1);
            {prefix}_lag_step(&state->lag_c[i], &state->lag_res[i], b0, b1, temperature_c, state->t_prev_c);
        }}
    }}
    state->t_prev_c = temperature_c;
    for (int a = 0; a < {up}_N_AXES; a++) {{
        out_correction_m_s2[a] = state->correction_m_s2[a] = {prefix}_axis_m_s2(state, a, temperature_c);
    }}
    return status;
}}

/* {prefix}_update_dt with the step from the sample's timestamp [us], differenced in integers; a
 * timestamp earlier than the last accepted one restarts the lags. */
static inline int {prefix}_update({prefix}_state *state, {r} temperature_c, uint64_t timestamp_us,
                                  {r} out_correction_m_s2[{up}_N_AXES])
{{
    {r} dt_s = -1;  /* restart unless the clock moved forward or stood still */
    if (!isfinite(temperature_c)) {{  /* rejected: keep the last accepted sample's time too */
        return {prefix}_update_dt(state, temperature_c, 0, out_correction_m_s2);
    }}
    if (state->started && timestamp_us >= state->t_prev_us) {{
        dt_s = ({r})(timestamp_us - state->t_prev_us) / ({r})1000000;
    }}
    state->t_prev_us = timestamp_us;
    return {prefix}_update_dt(state, temperature_c, dt_s, out_correction_m_s2);
}}
{fixed}
#endif /* {up}_H */
"""
    return text


def write_lag_aware_c_header(path, params: dict, sample_rate_hz: float | None = None, **kwargs) -> Path:
    """Write :func:`lag_aware_c_header` atomically to ``path`` (a ``.h`` file); return the path.

    Parameters
    ----------
    path : str or Path
        Output ``.h`` file.
    params, sample_rate_hz, **kwargs
        As :func:`lag_aware_c_header` (rate [Hz]).

    Returns
    -------
    Path
        The file written.
    """
    return atomic_write_text(Path(path), lag_aware_c_header(params, sample_rate_hz, **kwargs))
