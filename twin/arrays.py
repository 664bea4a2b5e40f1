"""Array helpers every subsystem shares."""

from __future__ import annotations

import numpy as np


def run_slices(run_index: np.ndarray) -> list[slice]:
    """Contiguous stretches of equal run index, in sample order (stateful filters restart at each).

    Parameters
    ----------
    run_index : np.ndarray
        Run of each sample.

    Returns
    -------
    list[slice]
        One slice per run; empty for an empty input.
    """
    run_index = np.asarray(run_index)
    if run_index.size == 0:
        return []
    edges = np.r_[0, np.flatnonzero(np.diff(run_index)) + 1, run_index.size]
    return [slice(int(a), int(b)) for a, b in zip(edges[:-1], edges[1:])]
