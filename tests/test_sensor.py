"""IIS328DQ model: white-noise level, PSD, Allan slope, bias instability, quantisation, saturation."""

import numpy as np
import pytest
from scipy.signal import welch

from sim.sensor import (
    IIS328DQ,
    allan_deviation,
    gauss_markov,
    left_justified_register,
    logger_white_sigma_g,
    quantise_digits,
    sensor_output,
    white_noise_sigma_g,
)

N = 1_000_000
RATE = 10.0


@pytest.fixture(scope="module")
def white_only():
    sensor = IIS328DQ(bias_instability_mg=0.0)
    rng = np.random.default_rng(1)
    out = sensor_output(np.zeros(N), sensor, RATE, rng, np.random.default_rng(2))
    return sensor, out


def test_noise_sigma_is_density_times_sqrt_bandwidth():
    # 218 ug/sqrt(Hz) x sqrt(37 Hz) = 1.326 mg (physics-notes §1.1, the 1.33 mg)
    assert white_noise_sigma_g(218.0, 37.0) == pytest.approx(1.326e-3, abs=1e-6)
    assert IIS328DQ().white_sigma_g == pytest.approx(218e-6 * np.sqrt(37.0))


def test_white_noise_matches_model_within_2_percent(white_only):
    sensor, out = white_only
    # sd of the sample sd on 1e6 samples is 0.07 %: 2 % leaves room only for a wrong model.
    assert np.std(out.white_g) == pytest.approx(sensor.white_sigma_g, rel=0.02)
    assert np.std(out.analog_g) == pytest.approx(sensor.white_sigma_g, rel=0.02)


def test_welch_psd_level_matches_white_model(white_only):
    sensor, out = white_only
    f, pxx = welch(out.analog_g, fs=RATE, nperseg=4096)
    expected = 2 * sensor.white_sigma_g**2 / RATE  # one-sided PSD of white samples at RATE
    # ~490 averaged segments: the mean level is known to <1 %; 3 % tolerance.
    assert np.mean(pxx[1:-1]) == pytest.approx(expected, rel=0.03)
    # flat: low and high halves of the band agree
    half = pxx.size // 2
    assert np.mean(pxx[1:half]) == pytest.approx(np.mean(pxx[half:-1]), rel=0.05)


def test_allan_deviation_slope_and_level_for_white_noise(white_only):
    sensor, out = white_only
    taus, adev = allan_deviation(out.analog_g, RATE, np.logspace(-1, 2, 12))
    slope = np.polyfit(np.log(taus), np.log(adev), 1)[0]
    assert slope == pytest.approx(-0.5, abs=0.03)
    # sigma_A(tau) = sigma / sqrt(tau x rate); at tau = 1 s about 1e5 averages: 3 %.
    i = np.argmin(np.abs(taus - 1.0))
    assert adev[i] == pytest.approx(sensor.white_sigma_g / np.sqrt(taus[i] * RATE), rel=0.03)


def test_gauss_markov_variance_and_correlation():
    sigma, tau, dt = 0.05e-3, 300.0, 0.1
    x = gauss_markov(2_000_000, dt, sigma, tau, np.random.default_rng(3))
    # 2e6 samples span 670 correlation times: the variance estimate is good to ~5 %.
    assert np.std(x) == pytest.approx(sigma, rel=0.1)
    lag = int(tau / dt)
    rho = np.corrcoef(x[:-lag], x[lag:])[0, 1]
    assert rho == pytest.approx(np.exp(-1), abs=0.08)


def test_averaging_logger_reduces_noise_by_sqrt_k():
    sensor = IIS328DQ()
    assert logger_white_sigma_g(sensor, 10.0, "average") == pytest.approx(sensor.white_sigma_g / np.sqrt(5))
    with pytest.raises(ValueError):
        logger_white_sigma_g(sensor, 100.0)


@pytest.mark.parametrize("fs", [2, 4, 8])
def test_quantisation_step_equals_sensitivity(fs):
    sensor = IIS328DQ(full_scale_g=fs)
    a = np.linspace(-0.1, 0.1, 200_001)
    levels = np.unique(quantise_digits(a, sensor.sensitivity_mg_per_digit)) * sensor.sensitivity_mg_per_digit * 1e-3
    assert np.allclose(np.diff(levels), sensor.sensitivity_mg_per_digit * 1e-3)
    assert {2: 0.98, 4: 1.95, 8: 3.91}[fs] == sensor.sensitivity_mg_per_digit


def test_quantisation_error_bounded_by_half_lsb(white_only):
    sensor, out = white_only
    assert np.max(np.abs(out.quantisation_g)) <= sensor.sensitivity_mg_per_digit * 1e-3 / 2 + 1e-12


def test_saturation_and_left_justified_register():
    sens = IIS328DQ().sensitivity_mg_per_digit
    d = quantise_digits(np.array([-3.0, 2.5, 1.0]), sens)
    assert d.tolist() == [-2048, 2047, 1020]  # 1 g / 0.98 mg = 1020.4 digits; +-2048 x 0.98 mg = +-2.007 g
    reg = left_justified_register(d)
    assert (reg >> 4).tolist() == d.tolist()  # ST driver: (raw >> 4) * 0.98
    assert reg[0] == -32768


def test_invalid_configuration_is_rejected():
    with pytest.raises(ValueError, match="full_scale_g"):
        IIS328DQ(full_scale_g=3)
    with pytest.raises(ValueError, match="odr_hz"):
        IIS328DQ(odr_hz=60)
