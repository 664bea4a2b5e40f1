"""The validation split of the fitting package: interleaved blocks of a time series.

``fitting`` imports nothing from ``twin`` (whose one fold builder is ``twin.arrays.interleaved_folds``),
so its estimators hold out rows with this one function.
"""

from __future__ import annotations

import numpy as np


def interleaved_validation_mask(n: int, fraction: float, blocks: int = 200) -> np.ndarray:
    """Rows held out for validation: the record cut into blocks of ``n // blocks`` rows, every
    ``round(1 / fraction)``-th block held out (at least every other one), so every part of the
    record is seen in both sets and neighbouring, correlated rows stay together.

    Parameters
    ----------
    n : int
        Rows [1].
    fraction : float
        Share of the rows to hold out [1].
    blocks : int
        Blocks the record is cut into [1].

    Returns
    -------
    ndarray of bool
        True on the validation rows.
    """
    block = max(1, n // blocks)
    return (np.arange(n) // block) % max(2, int(round(1 / fraction))) == 0
