"""The optional compiler of sim's sequential recursions (numba), behind one switch.

The recursions it compiles (the play operator, the variable-step lag) all have NumPy or Python
paths giving the same output, so numba is an accelerator only: absent, or switched off with
``TDE_TWIN_NO_NUMBA=1``, those paths run.
"""

from __future__ import annotations

import os


def njit():
    """numba's ``njit(cache=True, nogil=True)`` decorator, or ``None`` without numba or with
    ``TDE_TWIN_NO_NUMBA`` set (imported here, on first use: importing numba costs ~0.3 s).

    Returns
    -------
    callable or None
        The decorator: compiled once, cached on disk, releasing the interpreter lock.
    """
    if os.environ.get("TDE_TWIN_NO_NUMBA"):
        return None
    try:
        import numba
    except ImportError:
        return None
    return numba.njit(cache=True, nogil=True)
