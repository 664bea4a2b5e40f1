"""Train/test splits shared by ``twin benchmark`` and the DOE's ``compensated_mse_ratio``.

The paper's set-up: train on every cycle but the last, test on the last. In a test of several
runs the program restarts every run, so a sample's cycle is read from its time within its run,
and the test set is the last cycle of every run. A one-cycle program has no earlier cycle to
train on: the last third of the samples is the test set.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np


def sample_cycles(program, time_s: np.ndarray, run_index: np.ndarray | None = None) -> np.ndarray:
    """Cycle (0-based) of the program segment each sample falls in, by its time within its run.

    Parameters
    ----------
    program : ChamberProgram
        The test's compiled program.
    time_s : ndarray
        Sample times [s].
    run_index : ndarray, optional
        Run of each sample; a run's time starts at its first sample (default: one run).

    Returns
    -------
    ndarray of int
        The cycle of each sample.
    """
    t = np.asarray(time_s, float)
    if run_index is not None and t.size:
        runs = np.asarray(run_index, np.int64)
        start = np.full(runs.max() + 1, np.inf)
        np.minimum.at(start, runs, t)
        t = t - start[runs]
    cycles = np.array([s.cycle for s in program.segments])
    return cycles[program.segment_index(t)]


def last_cycle_test(program, time_s: np.ndarray, run_index: np.ndarray | None = None) -> np.ndarray:
    """Boolean test mask: the last cycle of every run (the last third when there is one cycle).

    Parameters
    ----------
    program : ChamberProgram
        The test's compiled program.
    time_s : ndarray
        Sample times [s].
    run_index : ndarray, optional
        Run of each sample (default: one run).

    Returns
    -------
    ndarray of bool
        True for a test sample.
    """
    cycle = sample_cycles(program, time_s, run_index)
    last = cycle.max() if cycle.size else 0
    if last > 0:
        return cycle == last
    return np.arange(cycle.size) >= 2 * cycle.size // 3


def subset(m, mask: np.ndarray):
    """The samples of measurement ``m`` where ``mask`` is true.

    Parameters
    ----------
    m : Measurement
    mask : ndarray of bool
        One per sample.

    Returns
    -------
    Measurement
        A copy with those samples only.
    """
    return replace(m, time_s=m.time_s[mask], temperature_c=m.temperature_c[mask], output_g=m.output_g[mask],
                   applied_g=m.applied_g[mask], run_index=m.run_index[mask], power_on=m.power_on[mask])
