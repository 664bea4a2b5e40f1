"""Logs averaged to k-sample means inside each run, for a diagnosis run on means.

Screening works on 10-s block means of a temperature that changes over minutes, so a 100 Hz day
(8.64 M rows) is first averaged to ``MODEL_RATE_HZ`` (k = 10 samples a block, block boundaries
inside runs): the 10-s means it tests are the same sums, and every stateful kernel sees a smooth
input ten times shorter. A long log at any rate is averaged further, to at most ``MAX_MODEL_ROWS``
means.
"""

from __future__ import annotations

import os

import numpy as np

from twin.estimation.noise import BlockAverager
from twin.measurement import Measurement

MODEL_RATE_HZ = 10.0  # 100 means per 10-s screening block
# at most this many rows are diagnosed, whatever the rate: the screening tests 10-s block means, so
# coarser model rows change the finding by little (a day at 100 Hz on 100-sample means: τ 186.79 s
# against 186.78 s on 10-sample means, ΔBIC 13255 against 13286, the calibrated tempcos within 1e-5
# of each other; the 16-h paper export at 10 Hz on 1-s means: the same effect named, τ ≈ 17 s,
# ΔBIC 26 against 28, residual RMS 1.3662 against 1.3665 mg) while every effect's history runs on
# a shorter input (the diagnosis was 55-70 % of those compares' time)
MAX_MODEL_ROWS = 100_000  # a day at 100 Hz: 100-sample means (86.4 k rows); a week: one per 10-s block


def decimation_factor(rate_hz: float, model_rate_hz: float = MODEL_RATE_HZ) -> int:
    """Samples per mean for the rate alone: 1 (no decimation) up to twice the model rate;
    ``TDE_TWIN_FULL_RATE=1`` forces 1. :func:`model_factor` adds the cap on rows.

    Parameters
    ----------
    rate_hz, model_rate_hz : float
        The log's sample rate and the rate diagnosed [Hz].

    Returns
    -------
    int
        Samples per mean (≥ 1).
    """
    if os.environ.get("TDE_TWIN_FULL_RATE") or rate_hz <= 2 * model_rate_hz:
        return 1
    return int(rate_hz / model_rate_hz + 1e-6)  # a rate of 99.999999998 Hz from rounded times is 100


def model_factor(n_rows: int, rate_hz: float, block: int) -> int:
    """Samples per mean diagnosed: the rate's :func:`decimation_factor`, raised so that at most
    :data:`MAX_MODEL_ROWS` means remain, then aligned to the screening block; 1 with
    ``TDE_TWIN_FULL_RATE=1`` or when the log is slow and short enough as it is.

    Parameters
    ----------
    n_rows : int
        Samples in the log.
    rate_hz : float
        Its sample rate [Hz].
    block : int
        Samples per screening block.

    Returns
    -------
    int
        Samples per mean (≥ 1).
    """
    k = decimation_factor(rate_hz)
    if os.environ.get("TDE_TWIN_FULL_RATE") or (k <= 1 and n_rows <= MAX_MODEL_ROWS):
        return 1
    return block_aligned_factor(max(k, -(-n_rows // MAX_MODEL_ROWS)), block)


def block_aligned_factor(k: int, block: int) -> int:
    """The smallest divisor of the screening block (samples) that is at least ``k``: means then
    tile every 10-s block exactly; never coarser than the block itself.

    Parameters
    ----------
    k : int
        Samples per mean wanted.
    block : int
        Samples per screening block.

    Returns
    -------
    int
        Samples per mean.
    """
    block = max(1, block)
    return next((d for d in range(max(1, k), block + 1) if block % d == 0), block)


def decimate(m: Measurement, k: int) -> tuple[Measurement, BlockAverager]:
    """Means of ``k`` consecutive samples inside each run (a partial last block is kept).

    Time, temperature, output and applied acceleration are averaged (the model is linear in the
    output and applied g); a block holding a power-on flag is flagged.

    Parameters
    ----------
    m : Measurement
    k : int
        Samples per block.

    Returns
    -------
    Measurement
        One row per block.
    BlockAverager
        The blocks, for the full-rate figures.
    """
    blocks = BlockAverager.build(m.run_index, k)
    flags = np.asarray(m.power_on, bool)
    power = np.logical_or.reduceat(flags, blocks.starts)
    applied = blocks(m.applied_g) if m.applied_known else np.full(blocks.starts.size, np.nan)
    dec = Measurement(blocks(m.time_s), blocks(m.temperature_c), blocks(m.output_g), applied,
                      np.asarray(m.run_index)[blocks.starts], power, m.applied_known, list(m.sources),
                      m.bad_rows_skipped, list(m.notes))
    return dec, blocks


def time_since_power_on_s(m: Measurement, blocks: BlockAverager, dec: Measurement) -> np.ndarray:
    """Each block's mean time since the latest power-on *sample* of the full-rate log.

    The block's own flag would date the power-on at the block's centre, k/2 samples late: a
    warm-up of τ = 10 s would then be off by 0.5 % at 100 Hz.

    Parameters
    ----------
    m : Measurement
        The full-rate log.
    blocks : BlockAverager
        Its blocks.
    dec : Measurement
        The block means (:func:`decimate`).

    Returns
    -------
    np.ndarray
        Time since power-on per block [s], ≥ 0.
    """
    flags = np.asarray(m.power_on, bool).copy()
    flags[blocks.starts[np.r_[True, np.diff(dec.run_index) != 0]]] = True  # each run starts powered on
    on = np.flatnonzero(flags)
    last = np.r_[blocks.starts[1:], len(m)] - 1
    latest = on[np.searchsorted(on, last, side="right") - 1]
    return np.clip(dec.time_s - m.time_s[latest], 0.0, None)
