"""The one-pole recursion y[n] = u[n] + a·y[n−1], in one compiled pass without scipy.signal.

Every first-order filter of the twin (thermal modes, first-order lags, Gauss–Markov noise, the
walk filter of the noise model) is this recursion after a feed-forward step done with whole-array
arithmetic. It is solved as the unit lower-bidiagonal system (I − a·S) y = u, S the shift, by
LAPACK's banded triangular solve (``dtbtrs``): forward substitution, y[n] = u[n] − (−a)·y[n−1],
the arithmetic of ``scipy.signal.lfilter([1], [1, −a], u)`` to the bit, without importing
scipy.signal, which brings scipy.stats with it at every command's start. Per call it is slower
than lfilter (BLAS steps the band one column at a time); the benchmarks of ``twin compare`` and
``twin calibrate`` count both (docs/long_logs.md).
"""

from __future__ import annotations

import numpy as np


def one_pole(u: np.ndarray, pole: float, *, overwrite: bool = False) -> np.ndarray:
    """y[n] = u[n] + pole·y[n−1] along the first axis, from y[−1] = 0.

    Parameters
    ----------
    u : ndarray
        Input, shape (n,) or (n, m) [any unit].
    pole : float
        The pole a [1] (|a| < 1 for a stable filter; any value is computed).
    overwrite : bool
        ``u`` may be overwritten (no copy of a 1-D float64 input).

    Returns
    -------
    ndarray
        y, C-ordered, the shape of ``u`` [unit of u].

    References
    ----------
    Oppenheim & Schafer, *Discrete-Time Signal Processing*, 3rd ed., §6.3 (the recursion);
    Anderson et al., *LAPACK Users' Guide*, 3rd ed. (``dtbtrs``, banded triangular solve).
    """
    from scipy.linalg import lapack  # scipy.linalg is imported by every command already

    u = np.asarray(u, float)
    n = u.shape[0] if u.ndim else 0
    if n == 0 or u.size == 0:
        return u.copy()
    band = np.empty((2, n), order="F")
    band[0] = 1.0  # the diagonal: not read with diag="U", set so that no LAPACK can read garbage
    band[1] = -pole  # sub-diagonal; its last entry is not read
    rhs = u.reshape(n, -1)  # a view of a 1-D input, F-ordered as LAPACK wants it
    rhs = np.asfortranarray(rhs) if overwrite else np.array(rhs, order="F")
    y, info = lapack.dtbtrs(band, rhs, uplo="L", diag="U", overwrite_b=1)
    if info != 0:  # pragma: no cover - unit diagonal: never singular
        raise ArithmeticError(f"dtbtrs info {info}")
    return np.ascontiguousarray(y).reshape(u.shape)


def first_order_filter(x: np.ndarray, b0: float, b1: float, pole: float, initial: float = 0.0) -> np.ndarray:
    """y[n] = b0·x[n] + b1·x[n−1] + pole·y[n−1] along the first axis, y[0] = b0·x[0] + ``initial``.

    The filter ``lfilter([b0, b1], [1, −pole], x, zi=[initial])``: its feed-forward part as
    whole-array arithmetic, then :func:`one_pole`. With ``b1 = 0`` the bits are lfilter's; with
    ``b1 ≠ 0`` the sum b0·x[n] + b1·x[n−1] is formed before the pole's term, a rounding apart.

    Parameters
    ----------
    x : ndarray
        Input, shape (n,) or (n, m) [any unit].
    b0, b1 : float
        Feed-forward coefficients [1].
    pole : float
        The pole [1].
    initial : float
        Added to y[0] (the filter's state before the first sample) [unit of x].

    Returns
    -------
    ndarray
        y, C-ordered, the shape of ``x`` [unit of x].

    References
    ----------
    Oppenheim & Schafer, *Discrete-Time Signal Processing*, 3rd ed., §6.3 (first-order sections).
    """
    x = np.asarray(x, float)
    drive = b0 * x
    if b1 != 0.0:
        drive[1:] += b1 * x[:-1]
    if initial != 0.0 and x.shape[0]:
        drive[0] += initial
    return one_pole(drive, pole, overwrite=True)
