"""ST IIS328DQ output model: full scale, 12-bit left-justified output, noise, quantisation.

Values and their provenance (physics-notes §1.1, ``physics_reference.json``):

* full scale ±2/±4/±8 g at 0.98/1.95/3.91 mg/digit, 12-bit data left-justified in a 16-bit
  register (raw >> 4 = digits) — verified from ST's driver;
* ODR 50/100/400/1000 Hz with digital low-pass 37/74/292/780 Hz — verified (same family);
* noise density 218 µg/√Hz — **recalled, unverified** (LIS331DLH family); overridable;
* TCOff ±0.8 mg/°C — the paper's figure, unverified; TCSo ±0.01 %/°C — **recalled**;
* bias instability (Gauss–Markov σ and τ) — **typical values, not from the datasheet**.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.signal import lfilter

SENSITIVITY_MG_PER_DIGIT = {2: 0.98, 4: 1.95, 8: 3.91}
LOWPASS_HZ_AT_ODR = {50: 37.0, 100: 74.0, 400: 292.0, 1000: 780.0}
RESOLUTION_BITS = 12


@dataclass(frozen=True)
class IIS328DQ:
    """Configuration of one IIS328DQ axis.

    Parameters
    ----------
    full_scale_g : {2, 4, 8}
    odr_hz : {50, 100, 400, 1000}
        Output data rate in normal mode; sets the digital low-pass cut-off.
    noise_density_ug_per_sqrt_hz : float
        White-noise density [µg/√Hz] (recalled family value, unverified).
    bias_instability_mg : float
        Stationary σ of a first-order Gauss–Markov bias [mg] (typical, not from the datasheet).
    bias_instability_tau_s : float
        Its correlation time [s].
    """

    full_scale_g: int = 2
    odr_hz: int = 50
    noise_density_ug_per_sqrt_hz: float = 218.0
    bias_instability_mg: float = 0.05
    bias_instability_tau_s: float = 300.0

    def __post_init__(self) -> None:
        if self.full_scale_g not in SENSITIVITY_MG_PER_DIGIT:
            raise ValueError(f"full_scale_g must be one of {sorted(SENSITIVITY_MG_PER_DIGIT)}, got {self.full_scale_g}")
        if self.odr_hz not in LOWPASS_HZ_AT_ODR:
            raise ValueError(f"odr_hz must be one of {sorted(LOWPASS_HZ_AT_ODR)}, got {self.odr_hz}")

    @property
    def sensitivity_mg_per_digit(self) -> float:
        return SENSITIVITY_MG_PER_DIGIT[self.full_scale_g]

    @property
    def lowpass_hz(self) -> float:
        return LOWPASS_HZ_AT_ODR[self.odr_hz]

    @property
    def white_sigma_g(self) -> float:
        """Per-ODR-sample white-noise σ [g]: density × √(low-pass bandwidth)."""
        return white_noise_sigma_g(self.noise_density_ug_per_sqrt_hz, self.lowpass_hz)


def white_noise_sigma_g(noise_density_ug_per_sqrt_hz: float, bandwidth_hz: float) -> float:
    """σ [g] of white noise of one-sided density ``nd`` [µg/√Hz] in ``bandwidth_hz``: nd·√B.

    218 µg/√Hz × √37 Hz = 1.326 mg (physics-notes §1.1; the issue's ≈ 1.33 mg).
    """
    return noise_density_ug_per_sqrt_hz * 1e-6 * np.sqrt(bandwidth_hz)


def logger_white_sigma_g(sensor: IIS328DQ, logger_rate_hz: float, mode: str = "latest") -> float:
    """σ [g] of the white noise in one logged sample.

    ``latest`` keeps the newest ODR sample (σ of one sample); ``average`` averages the
    ``ODR / logger_rate`` samples of each logger interval (σ/√k; ODR samples are independent
    because the 37 Hz low-pass lies above the 25 Hz Nyquist frequency of a 50 Hz ODR).
    """
    if logger_rate_hz > sensor.odr_hz:
        raise ValueError(f"logger rate {logger_rate_hz} Hz exceeds the ODR {sensor.odr_hz} Hz")
    if mode == "latest":
        return sensor.white_sigma_g
    if mode == "average":
        return sensor.white_sigma_g / np.sqrt(max(1, int(sensor.odr_hz // logger_rate_hz)))
    raise ValueError(f"logger mode must be 'latest' or 'average', got {mode!r}")


def gauss_markov(n: int, dt_s: float, sigma: float, tau_s: float, rng: np.random.Generator) -> np.ndarray:
    """Stationary first-order Gauss–Markov sequence (exact AR(1) discretisation).

    x[k+1] = φ x[k] + σ√(1−φ²) w[k], φ = exp(−dt/τ), x[0] ~ N(0, σ²).
    Reference: Maybeck (1979), *Stochastic Models, Estimation and Control*, vol. 1, §4.9.
    """
    if n == 0 or sigma == 0:
        return np.zeros(n)
    phi = np.exp(-dt_s / tau_s)
    w = rng.standard_normal(n)
    w[0] /= np.sqrt(1 - phi**2)  # so that x[0] = σ w0 has the stationary variance
    return lfilter([sigma * np.sqrt(1 - phi**2)], [1.0, -phi], w)


def quantise_digits(a_g: np.ndarray, sensitivity_mg_per_digit: float, bits: int = RESOLUTION_BITS) -> np.ndarray:
    """Round to the nearest digit and saturate at the 12-bit two's-complement limits."""
    lim = 2 ** (bits - 1)
    return np.clip(np.rint(np.asarray(a_g) * 1e3 / sensitivity_mg_per_digit), -lim, lim - 1).astype(np.int16)


def left_justified_register(digits: np.ndarray, bits: int = RESOLUTION_BITS) -> np.ndarray:
    """The 16-bit OUT register: 12-bit data shifted left by 4 (driver: ``(raw >> 4) * 0.98``)."""
    return (np.asarray(digits, np.int16).astype(np.int32) << (16 - bits)).astype(np.int16)


@dataclass
class SensorOutput:
    """Output and its parts [g]."""

    white_g: np.ndarray
    bias_instability_g: np.ndarray
    analog_g: np.ndarray  # before quantisation
    digits: np.ndarray
    output_g: np.ndarray
    saturated: np.ndarray

    @property
    def quantisation_g(self) -> np.ndarray:
        return self.output_g - self.analog_g


def sensor_output(
    true_g: np.ndarray,
    sensor: IIS328DQ,
    logger_rate_hz: float,
    rng_white: np.random.Generator,
    rng_bias: np.random.Generator,
    *,
    logger_mode: str = "latest",
) -> SensorOutput:
    """Noise, quantisation and saturation applied to the noiseless output ``true_g`` [g].

    Separate generators for white noise and bias instability keep each stream unchanged when
    the other is switched off.
    """
    true_g = np.asarray(true_g, float)
    n = true_g.size
    white = rng_white.normal(0.0, logger_white_sigma_g(sensor, logger_rate_hz, logger_mode), n)
    bi = gauss_markov(n, 1.0 / logger_rate_hz, sensor.bias_instability_mg * 1e-3, sensor.bias_instability_tau_s, rng_bias)
    analog = true_g + white + bi
    digits = quantise_digits(analog, sensor.sensitivity_mg_per_digit)
    lim = 2 ** (RESOLUTION_BITS - 1)
    saturated = (digits <= -lim) | (digits >= lim - 1)
    return SensorOutput(white, bi, analog, digits, digits * sensor.sensitivity_mg_per_digit * 1e-3, saturated)


def allan_deviation(x: np.ndarray, rate_hz: float, taus_s: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Overlapping Allan deviation of a rate-sampled signal.

    Reference: IEEE Std 952-1997, Annex C; Riley (2008), NIST SP 1065, eq. 14.

    Returns
    -------
    taus_s, adev : arrays
    """
    x = np.asarray(x, float)
    n = x.size
    if taus_s is None:
        m = np.unique(np.logspace(0, np.log10(max(1, n // 10)), 40).astype(int))
    else:
        m = np.unique(np.maximum(1, np.rint(np.asarray(taus_s) * rate_hz).astype(int)))
    cum = np.concatenate([[0.0], np.cumsum(x)])
    adev = np.empty(m.size)
    for j, mj in enumerate(m):  # one vectorised pass per averaging time
        avg = (cum[mj:] - cum[:-mj]) / mj
        d = avg[mj:] - avg[:-mj]
        adev[j] = np.sqrt(0.5 * np.mean(d * d)) if d.size else np.nan
    return m / rate_hz, adev
