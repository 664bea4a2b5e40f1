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

from dataclasses import dataclass, fields

import numpy as np

from twin.diagnosis.diagnose import Diagnosis
from twin.estimation.noise import BlockAverager, white_sigma_in_place
from twin.estimation.decimate import decimate, model_factor, time_since_power_on_s
from twin.estimation.problem import DiagnosisConfig, Problem
from twin.diagnosis.segments import residual_segments
from twin.measurement import Measurement

CHUNK_BLOCKS = 1 << 12  # blocks per chunk of the full-rate pass (≈ 41k samples at k = 10): the
# temporaries stay in cache and are reused; chunks of 1.3 M samples made the pass 3x slower


@dataclass
class BlockSums:
    """Full-rate y = output − applied summarised per block: Σy, Σy², the count, and the
    white-noise floor of the residual against the calibrated model held over each block.

    Attributes
    ----------
    s1, s2 : numpy.ndarray
        Per block Σy [g] and Σy² [g²].
    lengths : numpy.ndarray
        Samples per block (float).
    noise_floor_g : float
        White-noise σ of the full-rate residual [g].
    """

    s1: np.ndarray
    s2: np.ndarray
    lengths: np.ndarray
    noise_floor_g: float

    def sumsq(self, model: np.ndarray) -> np.ndarray:
        """Per-block Σ (y − model_b)² = S2_b − 2 m_b S1_b + L_b m_b² over the full-rate samples.

        Parameters
        ----------
        model : numpy.ndarray
            The model held over each block [g].

        Returns
        -------
        numpy.ndarray
            Sum of squares per block [g²], clipped at 0.
        """
        return np.clip(self.s2 - 2 * model * self.s1 + self.lengths * model * model, 0.0, None)

    def rms(self, model: np.ndarray) -> float:
        """RMS of the full-rate samples about ``model`` held over each block.

        Parameters
        ----------
        model : numpy.ndarray
            The model per block [g].

        Returns
        -------
        float
            Residual RMS [g].
        """
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
        The decimated problem's applied acceleration [g] (per-run constants when not logged).
    model : np.ndarray
        The calibrated model of y on the blocks (``problem.y − residual``) [g].

    Returns
    -------
    BlockSums
        Block sums of y and y² and the full-rate white-noise floor [g].
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


@dataclass(frozen=True, eq=False)
class SampleRateDiagnosis(Diagnosis):
    """A diagnosis run on block means, quoting the residual RMS of the full-rate samples.

    Attributes
    ----------
    sample_rms_g : float
        Residual RMS of the full-rate samples [g].
    factor : int
        Samples per mean.
    full_samples : int
        Samples of the full-rate log.
    full_rate_hz : float
        Its sample rate [Hz].
    """

    sample_rms_g: float = float("nan")
    factor: int = 1
    full_samples: int = 0
    full_rate_hz: float = float("nan")

    @property
    def rms_residual_g(self) -> float:
        """Residual RMS of the full-rate samples [g]."""
        return self.sample_rms_g

    @property
    def samples(self) -> int:
        """Samples of the full-rate log."""
        return self.full_samples

    @property
    def sample_rate_hz(self) -> float:
        """Sample rate of the full-rate log [Hz]."""
        return self.full_rate_hz

    @property
    def means_of(self) -> int | None:
        """Samples per row diagnosed."""
        return self.factor


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
        Residual RMS, noise floor, RMS after each candidate and after the named ones, and the
        residual by segment at the sample rate.
    """
    p, cal = d.problem, d.fit
    model = p.y - cal.residual
    sums = block_sums(m, blocks, p.applied, model)
    A_avg = p.avg(cal.X_full)
    y_avg = p.avg(p.y - cal.fixed_full)
    def rms_with(X: np.ndarray) -> float:  # per sample, with columns X refitted on the means
        beta = np.linalg.lstsq(np.column_stack([A_avg, p.avg(X)]), y_avg, rcond=None)[0]
        return sums.rms(cal.fixed_full + np.column_stack([cal.X_full, X]) @ beta)

    for c in d.candidates:
        c.rms_residual_g = rms_with(c.columns_full)
    values = {f.name: getattr(d, f.name) for f in fields(Diagnosis) if f.init}
    values["noise_floor_g"] = sums.noise_floor_g
    # the RMS with the named effects, per sample too (it was the RMS of the means)
    values["rms_after_selected_g"] = (rms_with(np.column_stack([c.columns_full for c in d.selected]))
                                      if d.selected else sums.rms(model))
    values["segments"] = residual_segments(p, cal.residual, d.segment_kind, sumsq=sums.sumsq(model), counts=sums.lengths)
    return SampleRateDiagnosis(**values, sample_rms_g=sums.rms(model), factor=k, full_samples=len(m),
                               full_rate_hz=m.sample_rate_hz)


def decimated_problem(m: Measurement, rate_hz: float, config: DiagnosisConfig
                      ) -> tuple[Problem, BlockAverager | None, int]:
    """The problem to diagnose: on k-sample means when the log is fast or long (see
    :func:`~twin.estimation.decimate.model_factor`).

    Parameters
    ----------
    m : Measurement
    rate_hz : float
        Its sample rate [Hz].
    config : DiagnosisConfig

    Returns
    -------
    problem, blocks (None when not decimated), k
    """
    k = model_factor(len(m), rate_hz, int(round(config.average_s * rate_hz)))
    if k <= 1:
        return Problem(m, config), None, 1
    dec, blocks = decimate(m, k)
    return Problem(dec, config, time_since_power_on_s=time_since_power_on_s(m, blocks, dec)), blocks, k
