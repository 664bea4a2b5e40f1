"""Sensor output model with the IIS328DQ part's figures: white-noise level, PSD, Allan slope, bias
instability, quantisation, saturation."""

import numpy as np
import pytest
from scipy.signal import welch

from sim.sensor import (
    AccelerometerConfig,
    allan_deviation,
    gauss_markov,
    left_justified_register,
    logger_white_sigma_g,
    quantise_digits,
    sensor_output,
    white_noise_sigma_g,
)
from twin.parts import PARTS, PartError, accelerometer_figures

N = 1_000_000
RATE = 10.0


def iis328dq(full_scale_g=None, odr_hz=None, **overrides) -> AccelerometerConfig:
    """The IIS328DQ part at a full scale and ODR (default: its lowest), figures overridden by keyword."""
    choices = {"full_scale_g": full_scale_g, "odr_hz": odr_hz}
    return AccelerometerConfig(**accelerometer_figures(PARTS["IIS328DQ"], choices, overrides))


@pytest.fixture(scope="module")
def white_only():
    sensor = iis328dq(bias_instability_mg=0.0)
    rng = np.random.default_rng(1)
    out = sensor_output(np.zeros(N), sensor, RATE, rng, np.random.default_rng(2))
    return sensor, out


def test_noise_sigma_is_density_times_sqrt_bandwidth():
    # 218 ug/sqrt(Hz) x sqrt(37 Hz) = 1.326 mg (docs/physics.md §1.1, the 1.33 mg)
    assert white_noise_sigma_g(218.0, 37.0) == pytest.approx(1.326e-3, abs=1e-6)
    assert iis328dq().white_sigma_g == pytest.approx(218e-6 * np.sqrt(37.0))


def test_white_noise_matches_model(white_only):
    sensor, out = white_only
    # The sd of the sample sd of N Gaussian samples is σ/√(2N) = 0.071 % at N = 1e6; 0.35 % is
    # 5 of those sds (this seed lands at −0.15 %), so only a wrong model fails.
    assert np.std(out.white_g) == pytest.approx(sensor.white_sigma_g, rel=0.0035)
    assert np.std(out.analog_g) == pytest.approx(sensor.white_sigma_g, rel=0.0035)


def test_welch_psd_level_matches_white_model(white_only):
    sensor, out = white_only
    f, pxx = welch(out.analog_g, fs=RATE, nperseg=4096)
    expected = 2 * sensor.white_sigma_g**2 / RATE  # one-sided PSD of white samples at RATE
    # ~490 averaged segments × ~2000 bins: the mean level is known to well under 1 % (it is the
    # sample variance, 0.14 % sd, plus the per-segment mean removal); 1 % tolerance (seed: −0.38 %).
    assert np.mean(pxx[1:-1]) == pytest.approx(expected, rel=0.01)
    # flat: low and high halves of the band agree
    half = pxx.size // 2
    assert np.mean(pxx[1:half]) == pytest.approx(np.mean(pxx[half:-1]), rel=0.05)


def test_allan_deviation_slope_and_level_for_white_noise(white_only):
    sensor, out = white_only
    taus, adev = allan_deviation(out.analog_g, RATE, np.logspace(-1, 2, 12))
    slope = np.polyfit(np.log(taus), np.log(adev), 1)[0]
    assert slope == pytest.approx(-0.5, abs=0.03)
    # sigma_A(tau) = sigma / sqrt(tau x rate); at tau ≈ 1 s about 1e5 independent averages, so the
    # estimate is good to ~1/sqrt(2e5) = 0.22 %; 1 % is 4.5 of those (seed: +0.01 %).
    i = np.argmin(np.abs(taus - 1.0))
    assert adev[i] == pytest.approx(sensor.white_sigma_g / np.sqrt(taus[i] * RATE), rel=0.01)


def test_gauss_markov_variance_and_correlation():
    sigma, tau, dt = 0.05e-3, 300.0, 0.1
    x = gauss_markov(2_000_000, dt, sigma, tau, np.random.default_rng(3))
    # 2e6 samples span T/τ = 667 correlation times: the sample variance has a relative sd of
    # sqrt(2τ/T) = 5.5 %, so the sample sd has half that, 2.7 % (a Monte Carlo of 40 seeds gives
    # 2.5 %). 8.5 % is about 3 of those sds (this seed lands at −5.8 %, 2.1 sds).
    assert np.std(x) == pytest.approx(sigma, rel=0.085)
    lag = int(tau / dt)
    rho = np.corrcoef(x[:-lag], x[lag:])[0, 1]
    # Bartlett's formula for this autocorrelation at lag τ: sd of the estimate ≈ sqrt(0.59 τ/T) = 3.0 %
    # (Monte Carlo: 2.5 %); 0.08 is 2.7 of those (this seed: −0.063).
    assert rho == pytest.approx(np.exp(-1), abs=0.08)


def test_averaging_logger_reduces_noise_by_sqrt_k():
    sensor = iis328dq()
    assert logger_white_sigma_g(sensor, 10.0, "average") == pytest.approx(sensor.white_sigma_g / np.sqrt(5))
    with pytest.raises(ValueError):
        logger_white_sigma_g(sensor, 100.0)


@pytest.mark.parametrize("fs", [2, 4, 8])
def test_quantisation_step_equals_sensitivity(fs):
    sensor = iis328dq(full_scale_g=fs)
    a = np.linspace(-0.1, 0.1, 200_001)
    digits = quantise_digits(a, sensor.sensitivity_mg_per_digit, sensor.resolution_bits)
    levels = np.unique(digits) * sensor.sensitivity_mg_per_digit * 1e-3
    assert np.allclose(np.diff(levels), sensor.sensitivity_mg_per_digit * 1e-3)
    assert {2: 0.98, 4: 1.95, 8: 3.91}[fs] == sensor.sensitivity_mg_per_digit


def test_quantisation_error_bounded_by_half_lsb(white_only):
    sensor, out = white_only
    assert np.max(np.abs(out.quantisation_g)) <= sensor.sensitivity_mg_per_digit * 1e-3 / 2 + 1e-12


def test_saturation_and_left_justified_register():
    sensor = iis328dq()
    assert sensor.resolution_bits == 12
    d = quantise_digits(np.array([-3.0, 2.5, 1.0]), sensor.sensitivity_mg_per_digit, sensor.resolution_bits)
    assert d.tolist() == [-2048, 2047, 1020]  # 1 g / 0.98 mg = 1020.4 digits; +-2048 x 0.98 mg = +-2.007 g
    reg = left_justified_register(d, sensor.resolution_bits)
    assert (reg >> 4).tolist() == d.tolist()  # ST driver: (raw >> 4) * 0.98
    assert reg[0] == -32768


def test_invalid_configuration_is_rejected():
    with pytest.raises(PartError, match=r"full_scale_g 3 is not a setting of part 'IIS328DQ' \(allowed: 2, 4 or 8\)"):
        iis328dq(full_scale_g=3)
    with pytest.raises(PartError, match="odr_hz 60 .* 50, 100, 400 or 1000"):
        iis328dq(odr_hz=60)
    good = iis328dq()
    for key, bad in (("sensitivity_mg_per_digit", 0.0), ("resolution_bits", 17), ("resolution_bits", 12.5),
                     ("lowpass_hz", -1.0), ("noise_density_ug_per_sqrt_hz", -1.0)):
        with pytest.raises(ValueError, match=key):
            AccelerometerConfig(**{**good.__dict__, key: bad})


def test_figures_are_keyword_only():
    with pytest.raises(TypeError):
        AccelerometerConfig(0.98, 12, 50, 37.0, 218.0, 0.05, 300.0, 2)  # positions could be swapped silently


def test_part_tables_select_the_figures():
    assert iis328dq(full_scale_g=8, odr_hz=400).sensitivity_mg_per_digit == 3.91
    assert iis328dq(odr_hz=1000).lowpass_hz == 780.0
    # the sensor model reads the resolution from the configuration, not a constant
    wide = iis328dq(resolution_bits=16)
    out = sensor_output(np.array([40.0, -40.0]), wide, RATE, np.random.default_rng(0), np.random.default_rng(1))
    assert out.digits.tolist() == [32767, -32768] and out.saturated.all()
