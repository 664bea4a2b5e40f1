"""The paper's derived numbers next to what the code computes (``twin test-design``)."""

from __future__ import annotations

from sim import calculators as calc


def design_report(
    lsb_mg: float = 0.98, tcoff_mg_per_c: float = 0.8, tcso_pct_per_c: float = 0.02, chamber_length_m: float = 0.6
) -> dict:
    """Eq. (33)-(35) as printed, and the physical time scales they should be read against.

    Returns ``{"items": [{name, value, unit, kind, note}, ...]}``; ``kind`` is ``paper-as-printed``
    or ``physical`` so nobody mistakes eq. (31) for a time.
    """
    beta = calc.paper_beta_mg_per_c(tcso_pct_per_c)
    l_half = chamber_length_m / 2
    a = calc.thermal_diffusivity_m2_per_s()
    items = [
        ("eq33_beta", beta, "mg/degC", "paper-as-printed",
         "TCSo x FS / span with the % sign dropped; honouring it gives "
         f"{calc.paper_beta_mg_per_c(tcso_pct_per_c, honour_percent=True):.4g}"),
        ("beta_physical_at_1g", calc.physical_beta_mg_per_c(0.01, 1.0), "mg/degC", "physical",
         "TCSo x a_in with TCSo = 0.01 %/degC (recalled) at 1 g"),
        ("eq34_control_interval", calc.control_interval_c(lsb_mg, tcoff_mg_per_c, beta), "degC", "paper-as-printed",
         "1 LSB / (2 TCOff + beta); the paper's '0.43' is a truncation of 0.4375"),
        ("eq31_35_control_period", calc.paper_control_period_s(b1_m=chamber_length_m, b2_m=chamber_length_m + 0.005),
         "s (s/m)", "paper-as-printed",
         "C in kJ/(kg K), b1 = L, b2 = L + 5 mm; NOT a time: eq. (31) has units of s/m "
         "(eq. 29 integrates energy over length, eq. 30 omits rho)"),
        ("air_diffusivity", a, "m^2/s", "physical", "lambda / (rho c) with the paper's air constants"),
        ("conduction_time_l2_over_a", calc.conduction_time_scale_s(l_half, a), "s", "physical",
         f"still-air slab, half-width {l_half:g} m: l^2/a"),
        ("first_mode_time_constant", calc.first_mode_time_constant_s(l_half, a), "s", "physical",
         "4 l^2 / (pi^2 a): slowest mode, both walls stepped"),
        ("centre_63pct_time", calc.centre_response_fourier(0.632) * l_half**2 / a, "s", "physical",
         "centre plane reaches 63.2 % of a wall step (Fo = 0.503); a fan-stirred chamber is far faster"),
    ]
    return {"items": [dict(name=n, value=float(v), unit=u, kind=k, note=note) for n, v, u, k, note in items]}
