"""The paper's test-design calculators, as printed, beside physically consistent time scales.

References
----------
Qi et al. (2022), eqs. (26)–(35); docs/physics.md §2.1–2.3 and §3 rows 15–19.
"""

from __future__ import annotations

import numpy as np

R_AIR_J_PER_KGK = 287.05


def paper_beta_mg_per_c(
    tcso_pct_per_c: float = 0.02,
    full_scale_span_g: float = 4.0,
    t_low_c: float = -40.0,
    t_high_c: float = 85.0,
    honour_percent: bool = False,
) -> float:
    """Scale-factor drift β of the paper's eq. (33) as printed: β = TCSo × FS / (T_high − T_low).

    The printed 0.64 mg/°C appears only when the % sign is dropped (``honour_percent=False``);
    honouring it gives 0.0064 mg/°C. Both divide a per-°C figure by a temperature span a second
    time (docs/physics.md §2.1).

    Parameters
    ----------
    tcso_pct_per_c : float
        Scale-factor tempco TCSo [%/°C].
    full_scale_span_g : float
        Full-scale span FS [g].
    t_low_c, t_high_c : float
        Operating temperature range [°C].
    honour_percent : bool
        Divide TCSo by 100 (the unit as written) instead of dropping the % sign.

    Returns
    -------
    float
        β [mg/°C].

    References
    ----------
    Qi et al. (2022), Micromachines 13, 2156, eq. (33).
    """
    pct = tcso_pct_per_c / 100.0 if honour_percent else tcso_pct_per_c
    return pct * full_scale_span_g * 1e3 / (t_high_c - t_low_c)


def physical_beta_mg_per_c(tcso_pct_per_c: float = 0.01, applied_g: float = 1.0) -> float:
    """Scale-factor drift per °C at the applied acceleration: TCSo × a_in [mg/°C].

    Parameters
    ----------
    tcso_pct_per_c : float
        Scale-factor tempco TCSo [%/°C].
    applied_g : float
        Applied acceleration a_in [g].

    Returns
    -------
    float
        β [mg/°C].

    References
    ----------
    Definition of a relative scale-factor tempco (docs/physics.md §2.1); no further source.
    """
    return tcso_pct_per_c / 100.0 * applied_g * 1e3


def control_interval_c(lsb_mg: float = 0.98, tcoff_mg_per_c: float = 0.8, beta_mg_per_c: float = 0.64) -> float:
    """Temperature control interval of eq. (34): ΔT = 1 LSB / [(+TCOff) − (−TCOff) + β].

    With the defaults 0.98 / 2.24 = 0.4375 °C.

    Parameters
    ----------
    lsb_mg : float
        One output LSB [mg].
    tcoff_mg_per_c : float
        Zero-g offset tempco TCOff [mg/°C].
    beta_mg_per_c : float
        Scale-factor drift β [mg/°C].

    Returns
    -------
    float
        ΔT [°C].

    References
    ----------
    Qi et al. (2022), Micromachines 13, 2156, eq. (34).
    """
    return lsb_mg / (2.0 * tcoff_mg_per_c + beta_mg_per_c)


def paper_control_period_s(
    specific_heat: float = 1.005,
    density_kg_per_m3: float = 1.293,
    conductivity_w_per_mk: float = 0.0267,
    b1_m: float = 0.600,
    b2_m: float = 0.605,
) -> float:
    """Control period of eq. (31)/(35) exactly as printed: t_s = C (b2 − b1) ρ / (λ |ln b2 − ln b1|).

    With C in kJ/(kg K) (1.005, the paper's value) and b1 = 0.600 m, b2 = 0.605 m this gives
    29.323 s. The expression has units of s/m, not s (eq. 29 integrates an energy over length),
    so it is **not a physical time**: docs/physics.md §2.3 and §3 row 17.

    Parameters
    ----------
    specific_heat : float
        Specific heat of air C [kJ/(kg K)] (the paper's unit).
    density_kg_per_m3 : float
        Air density ρ [kg/m³].
    conductivity_w_per_mk : float
        Thermal conductivity λ [W/(m K)].
    b1_m, b2_m : float
        The paper's lengths b1 and b2 of eq. (31) [m].

    Returns
    -------
    float
        t_s as printed [s, nominally; dimensionally s/m].

    References
    ----------
    Qi et al. (2022), Micromachines 13, 2156, eqs. (31) and (35).
    """
    return specific_heat * (b2_m - b1_m) * density_kg_per_m3 / (conductivity_w_per_mk * abs(np.log(b2_m) - np.log(b1_m)))


def air_density_kg_per_m3(temperature_c: float, pressure_pa: float = 101325.0) -> float:
    """Ideal-gas air density ρ = p / (R T), R = 287.05 J/(kg K) (docs/physics.md §1.5).

    Parameters
    ----------
    temperature_c : float
        Air temperature [°C].
    pressure_pa : float
        Pressure [Pa].

    Returns
    -------
    float
        ρ [kg/m³].

    References
    ----------
    Ideal-gas law with the specific gas constant of dry air (standard result).
    """
    return pressure_pa / (R_AIR_J_PER_KGK * (temperature_c + 273.15))


def thermal_diffusivity_m2_per_s(
    conductivity_w_per_mk: float = 0.0267, density_kg_per_m3: float = 1.293, specific_heat_j_per_kgk: float = 1005.0
) -> float:
    """Thermal diffusivity a = λ / (ρ c) [m²/s]; the paper's constants give 2.05e-5 m²/s.

    Parameters
    ----------
    conductivity_w_per_mk : float
        Thermal conductivity λ [W/(m K)].
    density_kg_per_m3 : float
        Density ρ [kg/m³].
    specific_heat_j_per_kgk : float
        Specific heat c [J/(kg K)].

    Returns
    -------
    float
        a [m²/s].

    References
    ----------
    Definition of thermal diffusivity (Incropera & DeWitt, *Fundamentals of Heat and Mass
    Transfer*; standard result).
    """
    return conductivity_w_per_mk / (density_kg_per_m3 * specific_heat_j_per_kgk)


def conduction_time_scale_s(half_width_m: float, diffusivity_m2_per_s: float) -> float:
    """Diffusion time l²/a of a slab of half-width l (4380 s for l = 0.3 m of still air).

    Parameters
    ----------
    half_width_m : float
        Slab half-width l [m].
    diffusivity_m2_per_s : float
        Thermal diffusivity a [m²/s].

    Returns
    -------
    float
        l²/a [s].

    References
    ----------
    Standard conduction time scale (Fourier number Fo = a t / l² = 1); docs/physics.md §2.3.
    """
    return half_width_m**2 / diffusivity_m2_per_s


def first_mode_time_constant_s(half_width_m: float, diffusivity_m2_per_s: float) -> float:
    """Slowest mode of a slab with both walls stepped: 4 l² / (π² a) (1775 s for l = 0.3 m).

    Parameters
    ----------
    half_width_m : float
        Slab half-width l [m].
    diffusivity_m2_per_s : float
        Thermal diffusivity a [m²/s].

    Returns
    -------
    float
        Time constant of the first Fourier mode [s].

    References
    ----------
    First term of the slab series solution, Carslaw & Jaeger §3.3 (see :func:`centre_response`).
    """
    return 4.0 * half_width_m**2 / (np.pi**2 * diffusivity_m2_per_s)


def centre_response(fourier: float | np.ndarray, terms: int = 200) -> np.ndarray:
    """Fraction of a wall step reached at the centre plane of a slab, at Fourier number a t / l².

    θ_c = 1 − Σ 4(−1)ⁿ / ((2n+1)π) · exp(−((2n+1)π/2)² Fo).

    Parameters
    ----------
    fourier : float or ndarray
        Fourier number Fo = a t / l² [1].
    terms : int
        Number of series terms.

    Returns
    -------
    ndarray
        θ_c [1], 0 before the step, → 1 at equilibrium.

    References
    ----------
    Carslaw & Jaeger, *Conduction of Heat in Solids*, §3.3.
    """
    fo = np.atleast_1d(np.asarray(fourier, float))
    n = np.arange(terms)[:, None]
    k = (2 * n + 1) * np.pi
    series = (4 * (-1.0) ** n / k * np.exp(-(k / 2) ** 2 * fo[None, :])).sum(axis=0)
    return 1.0 - series


def centre_response_fourier(fraction: float) -> float:
    """Fourier number at which the centre plane reaches ``fraction`` of a wall step.

    Parameters
    ----------
    fraction : float
        Target fraction of the step [1], in (0, 1).

    Returns
    -------
    float
        Fo = a t / l² [1] (root of :func:`centre_response`, Carslaw & Jaeger §3.3).
    """
    from scipy.optimize import brentq  # here only: every command imports this module, few call this

    return brentq(lambda fo: centre_response(fo)[0] - fraction, 1e-4, 20.0, xtol=1e-12)
