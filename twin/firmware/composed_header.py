"""A self-contained C header for the composed twin (a static cubic in the die temperature plus
library effects, :class:`twin.calibration.composed.ComposedCompensator`).

Every stateful effect becomes a per-sample recursion on the measured step dt:

* ``thermal_lag`` — the die temperature, one or two first-order lags of T in series;
* ``stress_relaxation`` — Σ k_i·(T_die − lag(T_die, τ_i)) (Maxwell elements, a Prony sum);
* ``thermal_gradient`` — c·60·(T_die − lag(T_die, τ))/τ (the rate seen through a node of τ);
* ``thermal_hysteresis`` — k·(p − T_die), p the play operator p = clamp(p, T_die − r, T_die + r);
* ``warmup`` — A·exp(−t_on/τ), t_on the time since init (power-on).

Each lag is the exact response of τ dy/dt = u − y to a piecewise-linear input over the step
(first-order hold: y += b0·(u − y) + b1·(u_prev − y), b0 = 1 − (1 − e)/h, b1 = (1 − e)/h − e,
e = exp(−h), h = dt/τ), the discretisation the effect library runs (``sim.thermal.first_order_lag``);
a lag of a lag runs it on the first lag's samples, as the library does. Effects that need what a
flight controller does not know (the applied acceleration of a scale-factor term, a device's age)
are refused. Arithmetic is plain ``float`` or ``double`` (``twin firmware`` writes double). A
float32 lag without compensated summation has a dead band of ulp(T)/(2(1 − e)) per step: 1 mK for
τ = 3000 s at 5-s steps (≈ 1 µg at 1 mg/°C), but 8 mK for τ = 7200 s at 100 Hz — use double there.
"""

from __future__ import annotations

from twin.firmware.common import AXES, G0_M_S2, FirmwareCalError, generator_name
from twin.firmware.hold_coefficients import c_literal, hold_coefficients_c

SUPPORTED = ("thermal_lag", "stress_relaxation", "thermal_gradient", "thermal_hysteresis", "warmup")
MG = G0_M_S2 * 1e-3  # 1 mg in m/s²


def _axis_code(a: int, entry: dict, reference_c: float, real: str, lags: list) -> tuple[str, str]:
    """(update statements, correction expression) of axis ``a``; ``lags`` collects (input, τ) filters."""
    lit = lambda v: c_literal(v, real)  # noqa: E731

    def lag(source: str, tau: float) -> str:
        lags.append((source, float(tau)))
        return f"s->lag[{len(lags) - 1}]"

    effects = {e["name"]: e["values"] for e in entry["effects"]}
    unknown = [n for n in effects if n not in SUPPORTED]
    if unknown:
        raise FirmwareCalError(f"axis {AXES[a]}: effect {unknown[0]!r} has no C form (the header runs "
                               f"{', '.join(SUPPORTED)}); apply it with twin apply")
    die = "T"
    if "thermal_lag" in effects:
        for key in ("tau_s", "tau2_s"):
            if effects["thermal_lag"][key] > 0:
                die = lag(die, effects["thermal_lag"][key])
    coef = [float(c) for c in entry["coef_mg"]]
    horner = lit(coef[-1] * MG)
    for c in reversed(coef[1:-1]):
        horner = f"{lit(c * MG)} + x * ({horner})"
    terms = [f"x * ({horner})" if len(coef) > 1 else lit(0.0)]
    pre = [f"    {{ const {real} x = {die} - {lit(reference_c)};"]
    v = effects.get("stress_relaxation")
    if v:
        for k, tau in (("k1_mg_per_c", "tau_s"), ("k2_mg_per_c", "tau2_s")):
            if v[k] != 0:
                terms.append(f"{lit(v[k] * MG)} * ({die} - {lag(die, v[tau])})")
    v = effects.get("thermal_gradient")
    if v and v["coef_mg_per_c_per_min"] != 0:
        terms.append(f"{lit(v['coef_mg_per_c_per_min'] * 60.0 * MG / v['tau_s'])} * ({die} - {lag(die, v['tau_s'])})")
    v = effects.get("thermal_hysteresis")
    if v and v["k_mg_per_c"] != 0:
        terms.append(f"{lit(v['k_mg_per_c'] * MG)} * (s->play[{a}] - {die})")
        pre.append(f"      if (restart) s->play[{a}] = {die};\n"
                   f"      else s->play[{a}] = fmin(fmax(s->play[{a}], {die} - {lit(v['half_width_c'])}), "
                   f"{die} + {lit(v['half_width_c'])});")
    v = effects.get("warmup")
    if v and v["amplitude_mg"] != 0:
        terms.append(f"{lit(v['amplitude_mg'] * MG)} * exp(-s->t_on_s / {lit(v['tau_s'])})")
    return "\n".join(pre), " + ".join(terms)


def composed_c_header(params: dict, *, prefix: str = "twin_composed", real: str = "double") -> str:
    """The header text for a stored composed model (``method_json`` of a ComposedCompensator).

    ``{prefix}_update(&s, T, timestamp_us, out)`` / ``{prefix}_update_dt(&s, T, dt_s, out)`` write the
    correction [m/s²] the firmware subtracts, per axis; the first call after ``{prefix}_init``, or a
    step that is negative or not finite, starts every state in equilibrium at T (as ``twin apply``
    starts a run); a non-finite T repeats the previous correction.

    Parameters
    ----------
    params : dict
        The stored model: ``reference_c`` [°C] and per axis the effects with their parameters.
    prefix : str
        Prefix of every C name.
    real : {"float", "double"}
        C type of the arithmetic.

    Returns
    -------
    str
        The header text.
    """
    if real not in ("float", "double"):
        raise FirmwareCalError(f"real must be 'float' or 'double', got {real!r}")
    axes = params.get("axes")
    if not isinstance(axes, list) or len(axes) != 3:
        raise FirmwareCalError("a composed model holds one entry per axis x, y, z")
    up, lags, blocks = prefix.upper(), [], []
    for a, entry in enumerate(axes):
        pre, expr = _axis_code(a, entry, float(params["reference_c"]), real, lags)
        blocks.append(f"{pre}\n      s->out[{a}] = ({real})({expr}); }}")
    lag_updates = "\n".join(
        f"    {{ const {real} u = {src}, u_prev = restart ? u : s->in_prev[{i}];\n"
        f"      if (restart) s->lag[{i}] = u;\n"
        f"      else {{ {real} b0, b1; {prefix}_hold_coefficients(dt_s / {c_literal(tau, real)}, &b0, &b1);\n"
        f"             s->lag[{i}] += b0 * (u - s->lag[{i}]) + b1 * (u_prev - s->lag[{i}]); }}\n"
        f"      s->in_prev[{i}] = u; }}"
        for i, (src, tau) in enumerate(lags))
    n_lag = max(len(lags), 1)
    return f"""/* {prefix}.h: composed-twin accelerometer temperature compensation, generated by {generator_name()}.
 * Per axis: a static polynomial in the die temperature plus the library effects fitted by
 * twin calibrate (see its equation), as per-sample recursions on the measured step.
 * Use: {prefix}_init(&s) at power-on; per sample {prefix}_update(&s, T, timestamp_us, corr);
 * accel[a] -= corr[a];  (sensor frame, m/s^2; the level is left to the ordinary calibration).
 * Needs <math.h> (link with -lm on hosted systems).
 */
#ifndef {up}_H
#define {up}_H

#include <math.h>
#include <stdint.h>

typedef {real} {prefix}_real;
#define {up}_N_AXES 3
#define {up}_N_LAGS {len(lags)}

typedef struct {{
    {real} lag[{n_lag}], in_prev[{n_lag}], play[3], out[3], t_on_s;
    uint64_t t_prev_us;
    int started;
}} {prefix}_state;

static inline void {prefix}_init({prefix}_state *s)
{{
    for (int i = 0; i < {n_lag}; i++) s->lag[i] = s->in_prev[i] = 0;
    for (int a = 0; a < 3; a++) s->play[a] = s->out[a] = 0;
    s->t_on_s = 0;
    s->t_prev_us = 0;
    s->started = 0;
}}

{hold_coefficients_c(prefix, real)}

/* 0: stepped; 1: (re)started in equilibrium at T; 2: T not finite, previous correction repeated */
static inline int {prefix}_update_dt({prefix}_state *s, {real} T, {real} dt_s, {real} out[3])
{{
    if (!isfinite(T)) {{
        for (int a = 0; a < 3; a++) out[a] = s->out[a];
        return 2;
    }}
    const int restart = !s->started || !(dt_s >= 0) || isinf(dt_s);
    if (restart) {{
        s->t_on_s = 0;
        dt_s = 0;
    }} else {{
        s->t_on_s += dt_s;
    }}
{lag_updates}
{chr(10).join(blocks)}
    s->started = 1;
    for (int a = 0; a < 3; a++) out[a] = s->out[a];
    return restart;
}}

static inline int {prefix}_update({prefix}_state *s, {real} T, uint64_t timestamp_us, {real} out[3])
{{
    const {real} dt_s = !s->started ? 0 : timestamp_us >= s->t_prev_us
        ? ({real})(timestamp_us - s->t_prev_us) * ({real})1e-6 : ({real})-1;
    const int status = {prefix}_update_dt(s, T, dt_s, out);
    if (status != 2) s->t_prev_us = timestamp_us;
    return status;
}}

#endif /* {up}_H */
"""
