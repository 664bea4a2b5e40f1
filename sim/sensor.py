"""Output model of a digital MEMS accelerometer axis: noise, bias instability, quantisation,
saturation, the left-justified output register, and the logger.

This module holds the physics only. Every datasheet figure (sensitivity per full scale,
resolution, low-pass cut-off per ODR, noise density, bias instability) arrives as data in an
:class:`AccelerometerConfig`, which the scenario builds from a part file (``twin/parts/``, one
YAML file per part with the value, unit, source and verification of each figure) and the
scenario's own choices and overrides.

Modelling choices (docs/physics.md §1.1): the white noise per ODR sample is the noise density over
the digital low-pass cut-off as the bandwidth (datasheets state no noise bandwidth); the bias
instability is a first-order Gauss–Markov process; the output is rounded to whole digits and
saturates at the two's-complement limits of the resolution.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from sim.recursion import first_order_filter

REGISTER_BITS = 16  # the output register the data are left-justified in


@dataclass(frozen=True, kw_only=True)
class AccelerometerConfig:
    """One accelerometer axis at one full scale and output data rate: the figures the output model needs.

    Taken from a part file and the scenario (no defaults here: see ``twin/parts/``).

    Parameters
    ----------
    sensitivity_mg_per_digit : float
        One digit of the output [mg] at the chosen full scale.
    resolution_bits : int
        Bits of output data (left-justified in a 16-bit register); sets the saturation limits.
    odr_hz : float
        Output data rate [Hz].
    lowpass_hz : float
        Digital low-pass cut-off at that ODR [Hz]; taken as the white-noise bandwidth.
    noise_density_ug_per_sqrt_hz : float
        White-noise density [µg/√Hz].
    bias_instability_mg : float
        Stationary σ of a first-order Gauss–Markov bias [mg].
    bias_instability_tau_s : float
        Its correlation time [s].
    full_scale_g : float
        Nominal full scale [±g] (the saturation follows from the resolution and sensitivity).
    """

    sensitivity_mg_per_digit: float
    resolution_bits: int
    odr_hz: float
    lowpass_hz: float
    noise_density_ug_per_sqrt_hz: float
    bias_instability_mg: float
    bias_instability_tau_s: float
    full_scale_g: float

    def __post_init__(self) -> None:
        positive = ("sensitivity_mg_per_digit", "odr_hz", "lowpass_hz", "bias_instability_tau_s", "full_scale_g")
        for name in positive:
            if not getattr(self, name) > 0:
                raise ValueError(f"{name} must be > 0, got {getattr(self, name)}")
        for name in ("noise_density_ug_per_sqrt_hz", "bias_instability_mg"):
            if not getattr(self, name) >= 0:
                raise ValueError(f"{name} must be >= 0, got {getattr(self, name)}")
        if int(self.resolution_bits) != self.resolution_bits or not 2 <= self.resolution_bits <= REGISTER_BITS:
            raise ValueError(f"resolution_bits must be a whole number of bits in 2..{REGISTER_BITS}, "
                             f"got {self.resolution_bits}")

    @property
    def white_sigma_g(self) -> float:
        """Per-ODR-sample white-noise σ [g]: density × √(low-pass bandwidth)."""
        return white_noise_sigma_g(self.noise_density_ug_per_sqrt_hz, self.lowpass_hz)


def white_noise_sigma_g(noise_density_ug_per_sqrt_hz: float, bandwidth_hz: float) -> float:
    """σ [g] of white noise of one-sided density nd [µg/√Hz] in a bandwidth B: nd·√B.

    The bandwidth is the low-pass cut-off, a modelling choice (docs/physics.md §1.1).

    Parameters
    ----------
    noise_density_ug_per_sqrt_hz : float
        One-sided noise density nd [µg/√Hz].
    bandwidth_hz : float
        Noise bandwidth B [Hz].

    Returns
    -------
    float
        σ [g].

    References
    ----------
    Standard result for band-limited white noise (σ² = nd² B); docs/physics.md §1.1.
    """
    return noise_density_ug_per_sqrt_hz * 1e-6 * np.sqrt(bandwidth_hz)


def logger_white_sigma_g(sensor: AccelerometerConfig, logger_rate_hz: float, mode: str = "latest") -> float:
    """σ [g] of the white noise in one logged sample.

    ``latest`` keeps the newest ODR sample (σ of one sample); ``average`` averages the
    ``ODR / logger_rate`` samples of each logger interval (σ/√k; taken as independent, which
    holds while the low-pass cut-off lies above the ODR's Nyquist frequency, as the ODR tables
    of the parts shipped do).

    Parameters
    ----------
    sensor : AccelerometerConfig
        The axis (ODR [Hz], per-sample σ [g]).
    logger_rate_hz : float
        Logger sample rate [Hz], ≤ the ODR.
    mode : {"latest", "average"}
        How the logger reduces the ODR samples of one interval.

    Returns
    -------
    float
        σ [g] per logged sample.

    References
    ----------
    σ/√k for the mean of k independent samples (standard result).
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

    Parameters
    ----------
    n : int
        Number of samples.
    dt_s : float
        Sample interval [s].
    sigma : float
        Stationary standard deviation σ [unit of the output, e.g. g].
    tau_s : float
        Correlation time τ [s].
    rng : numpy.random.Generator
        Source of the white sequence w.

    Returns
    -------
    ndarray
        x [unit of ``sigma``], length ``n``.

    References
    ----------
    Maybeck (1979), *Stochastic Models, Estimation and Control*, vol. 1, §4.9.
    """
    if n == 0 or sigma == 0:
        return np.zeros(n)
    phi = np.exp(-dt_s / tau_s)
    w = rng.standard_normal(n)
    w[0] /= np.sqrt(1 - phi**2)  # so that x[0] = σ w0 has the stationary variance
    return first_order_filter(w, sigma * np.sqrt(1 - phi**2), 0.0, phi)


def quantise_digits(a_g: np.ndarray, sensitivity_mg_per_digit: float, bits: int) -> np.ndarray:
    """Round to the nearest digit and saturate at the ``bits``-bit two's-complement limits.

    Parameters
    ----------
    a_g : ndarray
        Acceleration [g].
    sensitivity_mg_per_digit : float
        One digit [mg].
    bits : int
        Output resolution [bit].

    Returns
    -------
    ndarray of int16
        Output [digit].
    """
    lim = 2 ** (bits - 1)
    return np.clip(np.rint(np.asarray(a_g) * 1e3 / sensitivity_mg_per_digit), -lim, lim - 1).astype(np.int16)


def left_justified_register(digits: np.ndarray, bits: int) -> np.ndarray:
    """The 16-bit output register: ``bits``-bit data shifted left by ``16 − bits``.

    Drivers convert with ``(raw >> (16 − bits)) × sensitivity``.

    Parameters
    ----------
    digits : ndarray
        Output [digit].
    bits : int
        Output resolution [bit].

    Returns
    -------
    ndarray of int16
        Raw register value [LSB of the 16-bit register].
    """
    return (np.asarray(digits, np.int16).astype(np.int32) << (REGISTER_BITS - bits)).astype(np.int16)


@dataclass
class SensorOutput:
    """Output and its parts [g].

    Attributes
    ----------
    white_g : ndarray
        White noise [g].
    bias_instability_g : ndarray
        Gauss–Markov bias [g].
    analog_g : ndarray
        Noiseless output plus noise, before quantisation [g].
    digits : ndarray
        Quantised output [digit].
    output_g : ndarray
        Quantised output [g].
    saturated : ndarray of bool
        Samples at a saturation limit.
    """

    white_g: np.ndarray
    bias_instability_g: np.ndarray
    analog_g: np.ndarray  # before quantisation
    digits: np.ndarray
    output_g: np.ndarray
    saturated: np.ndarray

    @property
    def quantisation_g(self) -> np.ndarray:
        """Quantisation (and saturation) error, output minus analog [g]."""
        return self.output_g - self.analog_g


def sensor_output(
    true_g: np.ndarray,
    sensor: AccelerometerConfig,
    logger_rate_hz: float,
    rng_white: np.random.Generator,
    rng_bias: np.random.Generator,
    *,
    logger_mode: str = "latest",
) -> SensorOutput:
    """Noise, quantisation and saturation applied to the noiseless output ``true_g`` [g].

    Separate generators for white noise and bias instability keep each stream unchanged when
    the other is switched off.

    Parameters
    ----------
    true_g : ndarray
        Noiseless output at the logger rate [g].
    sensor : AccelerometerConfig
        The axis.
    logger_rate_hz : float
        Logger sample rate [Hz].
    rng_white, rng_bias : numpy.random.Generator
        Generators of the white noise and of the bias instability.
    logger_mode : {"latest", "average"}
        See :func:`logger_white_sigma_g`.

    Returns
    -------
    SensorOutput
        Output and its parts [g].
    """
    true_g = np.asarray(true_g, float)
    n = true_g.size
    white = rng_white.normal(0.0, logger_white_sigma_g(sensor, logger_rate_hz, logger_mode), n)
    bi = gauss_markov(n, 1.0 / logger_rate_hz, sensor.bias_instability_mg * 1e-3, sensor.bias_instability_tau_s, rng_bias)
    analog = true_g + white + bi
    digits = quantise_digits(analog, sensor.sensitivity_mg_per_digit, sensor.resolution_bits)
    lim = 2 ** (sensor.resolution_bits - 1)
    saturated = (digits <= -lim) | (digits >= lim - 1)
    return SensorOutput(white, bi, analog, digits, digits * sensor.sensitivity_mg_per_digit * 1e-3, saturated)


def allan_deviation(x: np.ndarray, rate_hz: float, taus_s: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Overlapping Allan deviation of a rate-sampled signal.

    Parameters
    ----------
    x : ndarray
        Signal [any unit, e.g. g].
    rate_hz : float
        Sample rate [Hz].
    taus_s : ndarray, optional
        Averaging times [s] (rounded to whole samples); default 40 log-spaced up to N/10 samples.

    Returns
    -------
    taus_s : ndarray
        Averaging times [s].
    adev : ndarray
        Allan deviation [unit of x].

    References
    ----------
    IEEE Std 952-1997, Annex C; Riley (2008), NIST SP 1065, eq. 14.
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
