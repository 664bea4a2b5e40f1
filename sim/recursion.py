"""The one-pole recursion y[n] = u[n] + a·y[n−1] in NumPy alone, without scipy.

Every first-order filter of the twin (thermal modes, first-order lags, Gauss–Markov noise, the
walk filter of the noise model) is this recursion after a feed-forward step done with whole-array
arithmetic. It is evaluated in two levels (the blocked form of a first-order linear recurrence):
the samples are laid out as about 4√n blocks of √(n/16) rows, the recursion steps row by row
through every block at once from a zero state, the blocks' end states are chained, and each block
then adds its entering state times a^(k+1). That is √(n/16) vector steps and 4√n float steps
instead of n, so no compiled loop is needed, and no scipy module is imported: ``scipy.linalg``, ``scipy.special``
and ``scipy.ndimage`` share an array-API layer that costs 0.25-0.3 s at the start of a command.
The first block is lfilter's arithmetic to the bit; later ones differ from the sequential
recursion by rounding (``tests/test_recursion.py`` bounds it by the recursion of |u| with |a|).
"""

from __future__ import annotations

import numpy as np


def one_pole(u: np.ndarray, pole: float) -> np.ndarray:
    """y[n] = u[n] + pole·y[n−1] along the first axis, from y[−1] = 0.

    Parameters
    ----------
    u : ndarray
        Input, shape (n,) or (n, m) [any unit].
    pole : float
        The pole a [1] (|a| < 1 for a stable filter; any value is computed).

    Returns
    -------
    ndarray
        y, C-ordered, the shape of ``u`` [unit of u].

    References
    ----------
    Oppenheim & Schafer, *Discrete-Time Signal Processing*, 3rd ed., §6.3 (the recursion);
    Blelloch, "Prefix sums and their applications", CMU-CS-90-190 (1990), §1.4 (first-order
    linear recurrences evaluated by blocks).
    """
    u = np.asarray(u, float)
    n = u.shape[0] if u.ndim else 0
    if n == 0 or u.size == 0:
        return u.copy()
    x = u.reshape(n, -1)
    # short blocks, many of them: a row step is a NumPy call (≈ 1.5 µs), a chaining step a Python
    # float operation (≈ 0.1 µs); √(n/16) rows of 4√n blocks costs about a third of √n by √n
    rows = int(np.sqrt((n - 1) / 16.0)) + 1
    blocks = -(-n // rows)
    z = np.zeros((blocks * rows, x.shape[1]))
    z[:n] = x
    z = np.ascontiguousarray(z.reshape(blocks, rows, -1).transpose(1, 0, 2))  # z[k, j] = u[j·rows + k]
    scaled = np.empty(z.shape[1:])
    for k in range(1, rows):  # every block from a zero state: the sequential arithmetic
        np.multiply(z[k - 1], pole, out=scaled)
        z[k] += scaled
    # the state entering each block: s_j = end_{j−1} + a^rows · s_{j−1}, s_0 = 0
    step = pole ** rows
    if x.shape[1] == 1:  # one column: plain floats, the same IEEE arithmetic without NumPy's call cost
        state, entering = 0.0, [0.0]
        for end in z[-1, :-1, 0].tolist():
            state = end + step * state
            entering.append(state)
        carried = np.array(entering)[:, None]
    else:
        carried = np.zeros(z.shape[1:])
        for j in range(1, blocks):
            carried[j] = z[-1, j - 1] + step * carried[j - 1]
    z[:, 1:] += np.power(pole, np.arange(1.0, rows + 1.0))[:, None, None] * carried[None, 1:]
    return np.ascontiguousarray(z.transpose(1, 0, 2).reshape(blocks * rows, -1)[:n]).reshape(u.shape)


def first_order_filter(x: np.ndarray, b0: float, b1: float, pole: float, initial: float = 0.0) -> np.ndarray:
    """y[n] = b0·x[n] + b1·x[n−1] + pole·y[n−1] along the first axis, y[0] = b0·x[0] + ``initial``.

    The filter ``lfilter([b0, b1], [1, −pole], x, zi=[initial])``: its feed-forward part as
    whole-array arithmetic, then :func:`one_pole`, within rounding of lfilter (the sum
    b0·x[n] + b1·x[n−1] is formed before the pole's term; later blocks are chained).

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
    return one_pole(drive, pole)
