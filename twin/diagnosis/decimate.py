"""High-rate logs diagnosed on k-sample means, per-sample figures restored from the full rate.

Screening already works on 10-s block means of a temperature that changes over minutes, so a
100 Hz day (8.64 M rows) is first averaged to ``MODEL_RATE_HZ`` (k = 10 samples a block, block
boundaries inside runs) and the whole diagnosis — calibration, screening of every effect with
history, selection — runs on those means: the 10-s means it tests are the same sums, and every
stateful kernel sees a smooth input ten times shorter. ``tests/test_long_logs.py`` bounds the
difference against full-rate evaluation.

What is quoted per sample (residual RMS, the white-noise floor, residual by segment, the RMS after
adding each candidate) is computed from the full-rate output against the model held over each
block, in chunks: Σ (y − m_b)² = S2_b − 2 m_b S1_b + L_b m_b² with S1_b, S2_b the block sums of
y and y², so any model on the means gives the exact full-rate sum of squares in O(n / k).
"""

from __future__ import annotations

import os
from dataclasses import dataclass, fields

import numpy as np

from twin.diagnosis.diagnose import Diagnosis
from twin.diagnosis.language import finding_text
from twin.diagnosis.noise import BlockAverager, white_sigma_of_differences
from twin.diagnosis.problem import DiagnosisConfig, Problem
from twin.diagnosis.segments import residual_segments
from twin.measurement import Measurement

MODEL_RATE_HZ = 10.0  # 100 means per 10-s screening block
MAX_MODEL_ROWS = 2_000_000  # a week at 100 Hz is diagnosed on 40-sample means (1.5 M rows)
CHUNK_BLOCKS = 1 << 17  # blocks per chunk of the full-rate pass (≈ 1.3 M samples at k = 10)


def decimation_factor(rate_hz: float, model_rate_hz: float = MODEL_RATE_HZ) -> int:
    """Samples per mean: 1 (no decimation) up to twice the model rate, so 10-20 Hz logs (and
    every recorded result) are diagnosed exactly as before; ``TDE_TWIN_FULL_RATE=1`` forces 1."""
    if os.environ.get("TDE_TWIN_FULL_RATE") or rate_hz <= 2 * model_rate_hz:
        return 1
    return int(rate_hz / model_rate_hz + 1e-6)  # a rate of 99.999999998 Hz from rounded times is 100


def block_aligned_factor(k: int, block: int) -> int:
    """The smallest divisor of the screening block (samples) that is at least ``k``: means then
    tile every 10-s block exactly; never coarser than the block itself."""
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
    """
    flags = np.asarray(m.power_on, bool).copy()
    flags[blocks.starts[np.r_[True, np.diff(dec.run_index) != 0]]] = True  # each run starts powered on
    on = np.flatnonzero(flags)
    last = np.r_[blocks.starts[1:], len(m)] - 1
    latest = on[np.searchsorted(on, last, side="right") - 1]
    return np.clip(dec.time_s - m.time_s[latest], 0.0, None)


@dataclass
class BlockSums:
    """Full-rate y = output − applied summarised per block: Σy, Σy², the count, and the
    white-noise floor of the residual against the calibrated model held over each block."""

    s1: np.ndarray
    s2: np.ndarray
    lengths: np.ndarray
    noise_floor_g: float

    def sumsq(self, model: np.ndarray) -> np.ndarray:
        """Per-block Σ (y − model_b)² over the full-rate samples."""
        return np.clip(self.s2 - 2 * model * self.s1 + self.lengths * model * model, 0.0, None)

    def rms(self, model: np.ndarray) -> float:
        return float(np.sqrt(self.sumsq(model).sum() / self.lengths.sum()))


def block_sums(m: Measurement, blocks: BlockAverager, applied_dec: np.ndarray, model: np.ndarray) -> BlockSums:
    """One chunked pass over the full-rate log (no full-size temporaries).

    Parameters
    ----------
    m : Measurement
        The full-rate log.
    blocks : BlockAverager
        Its blocks.
    applied_dec : np.ndarray
        The decimated problem's applied acceleration (per-run constants when not logged).
    model : np.ndarray
        The calibrated model of y on the blocks (``problem.y − residual``).
    """
    nb = blocks.starts.size
    s1, s2 = np.empty(nb), np.empty(nb)
    diffs = np.empty(max(len(m) - 1, 0), np.float32)  # float32: the floor is quoted to 3 digits
    keep = np.zeros(diffs.size, bool)
    prev = None  # (residual, run) of the sample before the chunk
    for b0 in range(0, nb, CHUNK_BLOCKS):
        b1 = min(b0 + CHUNK_BLOCKS, nb)
        a = int(blocks.starts[b0])
        z = int(blocks.starts[b1]) if b1 < nb else len(m)
        lengths = blocks.lengths[b0:b1]
        applied = m.applied_g[a:z] if m.applied_known else np.repeat(applied_dec[b0:b1], lengths)
        y = m.output_g[a:z] - applied
        rel = blocks.starts[b0:b1] - a
        s1[b0:b1] = np.add.reduceat(y, rel)
        s2[b0:b1] = np.add.reduceat(y * y, rel)
        r = y - np.repeat(model[b0:b1], lengths)
        runs = np.asarray(m.run_index[a:z])
        if prev is not None:
            r, runs = np.r_[prev[0], r], np.r_[prev[1], runs]
        lo = a - 1 if prev is not None else a
        diffs[lo:z - 1] = np.diff(r)
        keep[lo:z - 1] = np.diff(runs) == 0
        prev = (r[-1:], runs[-1:])
    floor = white_sigma_in_place(diffs if keep.all() else diffs[keep])  # float32 throughout: half the memory
    return BlockSums(s1, s2, blocks.lengths.astype(float), floor)


def white_sigma_in_place(d: np.ndarray) -> float:
    """:func:`~twin.diagnosis.noise.white_sigma_of_differences` of ``d``, overwriting ``d`` with
    ``|d|``: the same value (neither the trim nor the squares see the sign) with one full-length
    temporary instead of four, which set the peak memory of a week-long log."""
    if d.size == 0:
        return 0.0
    magnitude = np.abs(d)
    scale = np.percentile(magnitude, 75, overwrite_input=True) / 0.6745  # partitions the temporary
    del magnitude
    if not scale > 0:  # mostly zero differences: the fallback scale needs the signed values
        return white_sigma_of_differences(d)
    np.abs(d, out=d)
    kept = d[d <= 8 * scale]
    np.square(kept, out=kept)
    return float(np.sqrt(np.mean(kept) / 2.0))


@dataclass
class SampleRateDiagnosis(Diagnosis):
    """A diagnosis run on block means, quoting the residual RMS of the full-rate samples."""

    sample_rms_g: float = float("nan")
    factor: int = 1

    @property
    def rms_residual_g(self) -> float:
        return self.sample_rms_g


def restore_sample_rate(d: Diagnosis, m: Measurement, blocks: BlockAverager, k: int) -> SampleRateDiagnosis:
    """``d`` (diagnosed on block means) with its per-sample figures from the full-rate log.

    Parameters
    ----------
    d : Diagnosis
        Run on the decimated problem.
    m : Measurement
        The full-rate log.
    blocks : BlockAverager
        Its blocks (one per row of ``d.problem``).
    k : int
        Samples per block.

    Returns
    -------
    SampleRateDiagnosis
        Residual RMS, noise floor, RMS after each candidate and the residual by segment at the
        sample rate; the finding re-worded with them.
    """
    p, cal = d.problem, d.calibration
    model = p.y - cal.residual
    sums = block_sums(m, blocks, p.applied, model)
    A_avg = p.avg(cal.X_full)
    y_avg = p.avg(p.y - cal.fixed_full)
    for c in d.candidates:
        X = c.columns_full
        beta = np.linalg.lstsq(np.column_stack([A_avg, p.avg(X)]), y_avg, rcond=None)[0]
        c.rms_residual_g = sums.rms(cal.fixed_full + np.column_stack([cal.X_full, X]) @ beta)
    values = {f.name: getattr(d, f.name) for f in fields(Diagnosis) if f.init}
    values["noise_floor_g"] = sums.noise_floor_g
    values["segments"] = residual_segments(p, cal.residual, sumsq=sums.sumsq(model), counts=sums.lengths)
    out = SampleRateDiagnosis(**values, sample_rms_g=sums.rms(model), factor=k)
    out.finding = finding_text(out)
    return out


def decimated_problem(m: Measurement, rate_hz: float, config: DiagnosisConfig
                      ) -> tuple[Problem, BlockAverager | None, int]:
    """The problem to diagnose: on k-sample means when the log is fast (see :func:`decimation_factor`).

    Parameters
    ----------
    m : Measurement
    rate_hz : float
        Its sample rate.
    config : DiagnosisConfig

    Returns
    -------
    problem, blocks (None when not decimated), k
    """
    k = decimation_factor(rate_hz)
    if k > 1:
        k = block_aligned_factor(max(k, -(-len(m) // MAX_MODEL_ROWS)), int(round(config.average_s * rate_hz)))
    if k <= 1:
        return Problem(m, config), None, 1
    dec, blocks = decimate(m, k)
    return Problem(dec, config, time_since_power_on_s=time_since_power_on_s(m, blocks, dec)), blocks, k
