"""Datasets with an effect outside the library, drawn by a seeded generator, for the discovery
acceptance tests and benchmark; and null data with coloured noise.

Each case starts from the ``none`` case of :mod:`twin.datasets.hidden` (the twin's own effects, the
full noise stack, two runs at ±1 g, 1 Hz) and adds one term whose form is not among the library's:

- ``rate_squared``: a bias in (dT/dt)² (even in the rate: heating and cooling push the same way);
- ``threshold_step``: a bias step when the temperature crosses a threshold (a contact or a phase
  change), smooth over 0.3–1 °C;
- ``temp_rate``: a ΔT·dT/dt cross-term (a gradient whose coupling grows with temperature);
- ``controller_oscillation``: the chamber controller's limit cycle at each set-point (0.1–0.3 °C,
  4–12-min period) in the logged temperature, coupled into the output at a gain unlike the slow
  tempco's;
- ``null_coloured``: nothing added to the physics, but a bias random walk and a 1/f-like term
  added to the noise.

The generating forms are computed with the generator's own smoothing (a 30-s Gaussian on the
logged temperature), not with the dictionary's code. The clear level is set as in
:mod:`twin.datasets.hidden`: the hidden term's detectable RMS over σ of the noise on 10-s means,
drawn in 1.5–3.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.ndimage import gaussian_filter1d

from twin.arrays import run_slices, temperature_rate_c_per_s
from twin.datasets.hidden import LEVEL_BANDS, Case, detectable_ratio, draw_case

#: case → the dictionary feature kinds that generate it (empty: nothing to find)
OUTSIDE_CASES = {"rate_squared": ("rate2",), "threshold_step": ("step",), "temp_rate": ("temp_rate",),
                 "controller_oscillation": ("oscillation", "hold_sine"), "null_coloured": ()}


@dataclass
class OutsideCase:
    """One dataset with an effect outside the library, and its truth.

    Attributes
    ----------
    kind : str
        A key of :data:`OUTSIDE_CASES`.
    seed : int
    case : Case
        Measurement, twin, noise-only RMS [g]; ``hidden_g`` is the added term [g].
    generating_kinds : tuple of str
        The dictionary feature kinds that generate it (empty: nothing to find).
    truth : dict
        Drawn parameters, in each one's unit (``coefficient_mg`` [mg per unit of the form] …).
    """

    kind: str
    seed: int
    case: Case  # measurement, twin, noise-only RMS; ``hidden_g`` is the added term
    generating_kinds: tuple[str, ...]
    truth: dict


def _smooth(x: np.ndarray, run_index: np.ndarray, sigma_samples: float) -> np.ndarray:
    out = np.empty_like(x, dtype=float)
    for s in run_slices(run_index):
        out[s] = gaussian_filter1d(np.asarray(x[s], float), sigma_samples, mode="nearest")
    return out


def _pink(rng: np.random.Generator, n: int) -> np.ndarray:
    """Unit-variance 1/f noise: white noise shaped by 1/√f in the frequency domain."""
    f = np.fft.rfftfreq(n)
    spec = (rng.standard_normal(f.size) + 1j * rng.standard_normal(f.size)) / np.sqrt(np.maximum(f, 1.0 / n))
    spec[0] = 0.0
    x = np.fft.irfft(spec, n)
    return x / np.std(x)


def draw_outside(kind: str, seed: int, level: str = "clear", rate_hz: float = 1.0) -> OutsideCase:
    """Draw one dataset of ``kind`` (see :data:`OUTSIDE_CASES`) at ``level`` (a band of
    :data:`~twin.datasets.hidden.LEVEL_BANDS`), logged at ``rate_hz``.

    Parameters
    ----------
    kind : str
        A key of :data:`OUTSIDE_CASES`.
    seed : int
    level : str
        A key of :data:`~twin.datasets.hidden.LEVEL_BANDS`.
    rate_hz : float
        Logger rate [Hz].

    Returns
    -------
    OutsideCase

    Raises
    ------
    ValueError
        An unknown kind.
    """
    if kind not in OUTSIDE_CASES:
        raise ValueError(f"unknown case {kind!r}; cases: {', '.join(OUTSIDE_CASES)}")
    base = draw_case("none", seed, "clear", rate_hz=rate_hz)
    rng = np.random.default_rng(np.random.SeedSequence([seed, 7919, sum(map(ord, kind))]))
    m = base.measurement
    t, run = m.time_s, m.run_index
    rate_hz = m.sample_rate_hz
    temp = _smooth(m.temperature_c, run, 30.0 * rate_hz)
    rate = temperature_rate_c_per_s(t, temp, run) * 60.0  # °C/min, of the smoothed temperature
    truth: dict = {}
    if kind == "null_coloured":
        # bias random walk (0.004 mg/√s: ≈0.5 mg over a 5-h run) and 1/f-like noise (0.1 mg RMS)
        walk = np.concatenate([np.cumsum(rng.standard_normal(s.stop - s.start)) for s in run_slices(run)])
        extra = 0.004e-3 * walk / np.sqrt(rate_hz) + 0.1e-3 * _pink(rng, t.size)
        m.output_g = m.output_g + extra
        base.noise_g = base.noise_g + extra
        base.noise_only_rms_g = float(np.sqrt(np.mean(base.noise_g ** 2)))
        return OutsideCase(kind, seed, base, (), truth)
    if kind == "rate_squared":
        shape = rate ** 2
    elif kind == "threshold_step":
        lo, hi = np.percentile(temp, [20, 80])
        at, w = float(rng.uniform(lo, hi)), float(rng.uniform(0.3, 1.0))
        shape = 0.5 * (1 + np.tanh((temp - at) / w))
        truth.update(at_c=at, width_c=w)
    elif kind == "temp_rate":
        shape = (temp - 25.0) * rate
    else:  # controller_oscillation: a limit cycle at each set-point (where the chamber holds)
        amp, period = float(rng.uniform(0.1, 0.3)), float(rng.uniform(240, 720))
        holding = _smooth((np.abs(rate) < 0.05).astype(float), run, 60.0 * rate_hz)
        osc = amp * holding * np.sin(2 * np.pi * t / period + rng.uniform(0, 2 * np.pi))
        m.temperature_c = m.temperature_c + osc
        shape = osc
        truth.update(amplitude_c=amp, period_s=period)
    shape = np.asarray(shape, float)
    unit = detectable_ratio(m, base.twin, shape * 1e-3, base.noise_g)  # ratio of 1 mg per unit of the form
    target = float(rng.uniform(*LEVEL_BANDS[level]))
    coef_mg = target / unit if unit > 0 else 0.0
    coef_mg *= 1 if rng.random() < 0.5 else -1
    hidden = coef_mg * 1e-3 * shape
    m.output_g = m.output_g + hidden
    base.hidden_g = hidden
    truth.update(coefficient_mg=coef_mg, target_ratio=target)
    return OutsideCase(kind, seed, base, OUTSIDE_CASES[kind], truth)
