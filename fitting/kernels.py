"""Compiled population fitness of tanh networks: one pass over the samples per network, no tanh call.

The population search (GA, PSO-GA) spends nearly all its time in the mean squared error of P
networks on n samples. The torch kernel (:func:`fitting.network.population_mse`) writes the
(P·h, chunk) hidden block to memory three times (GEMM, activation, output GEMV); here each network
keeps a chunk of its hidden pre-activations and outputs in L1 and the activation is a rational
function, plain multiply-adds that the compiler vectorises, so the speed does not depend on a
vendor's tanh (on an AMD EPYC torch's float32 tanh runs at 0.8 G/s, its sigmoid at 4.6 G/s).

tanh is Eigen's float32 approximation (``ptanh_float``, Eigen 3.4, ``GenericPacketMathFunctions.h``):
x·P(x²)/Q(x²) with P of degree 6 and Q of degree 3 in x², the argument clamped to ±7.9053, where the
result is within 2.4e-7 of ±1. Its error against the float64 tanh is below
:data:`TANH_MAX_ABS_ERROR` (tested on a dense grid against ``torch.tanh``). Each network's sum runs
in its own order whatever the thread count, so the same seed gives the same fitness on one machine.
"""

from __future__ import annotations

import numpy as np
from numba import njit, prange

#: bound on abs(tanh_rational(x) − tanh(x)) over all float32 x (measured 2.7e-7 on [−20, 20]: ~4 ulp of 1)
TANH_MAX_ABS_ERROR = 5e-7


@njit(fastmath=True, error_model="numpy", inline="always", cache=True)
def tanh_rational(x):  # pragma: no cover - compiled
    """float32 tanh as Eigen's rational approximation (see the module docstring).

    Parameters
    ----------
    x : float32
        Argument [1].

    Returns
    -------
    float32
        tanh(x) [1], within :data:`TANH_MAX_ABS_ERROR`.

    References
    ----------
    Eigen 3.4, ``ptanh_float`` in ``GenericPacketMathFunctions.h``.
    """
    # the constants are written as float32 here: numba would take module-level ones as float64
    f = np.float32
    c = f(7.90531110763549805)  # beyond it the result is ±1 to within 2.4e-7
    x = x if x < c else c
    x = x if x > -c else -c
    x2 = x * x
    p = (((((f(-2.76076847742355e-16) * x2 + f(2.00018790482477e-13)) * x2 + f(-8.60467152213735e-11)) * x2
           + f(5.12229709037114e-08)) * x2 + f(1.48572235717979e-05)) * x2 + f(6.37261928875436e-04)) * x2 \
        + f(4.89352455891786e-03)
    q = ((f(1.19825839466702e-06) * x2 + f(1.18534705686654e-04)) * x2 + f(2.26843463243900e-03)) * x2 \
        + f(4.89352518554385e-03)
    return x * p / q


@njit(fastmath=True, error_model="numpy", cache=True)
def tanh_rational_array(x):  # pragma: no cover - compiled
    """:func:`tanh_rational` of every element of a float32 array (for tests and benchmarks).

    Parameters
    ----------
    x : ndarray of float32
        Arguments [1].

    Returns
    -------
    ndarray of float32
        tanh(x) [1].
    """
    out = np.empty_like(x)
    for i in range(x.size):
        out[i] = tanh_rational(x[i])
    return out


@njit(fastmath=True, error_model="numpy", cache=True)
def _network_mse(W1, b1, W2, b2, XT, y, z, out, chunk):  # pragma: no cover - compiled
    groups = W1.shape[0] // 4  # inputs padded to a multiple of 4: each group is one fused pass
    hidden, n = W1.shape[1], XT.shape[1]
    total = 0.0
    for a in range(0, n, chunk):
        c = min(chunk, n - a)
        for t in range(c):
            out[t] = b2 - y[a + t]
        j0 = 0
        if groups == 1:  # the common case (≤ 4 inputs): two hidden units per pass share the loads
            x0, x1, x2, x3 = XT[0, a : a + c], XT[1, a : a + c], XT[2, a : a + c], XT[3, a : a + c]
            for j in range(0, hidden - 1, 2):
                u0, u1, u2, u3, ub, uo = W1[0, j], W1[1, j], W1[2, j], W1[3, j], b1[j], W2[j]
                v0, v1, v2, v3, vb, vo = W1[0, j + 1], W1[1, j + 1], W1[2, j + 1], W1[3, j + 1], b1[j + 1], W2[j + 1]
                for t in range(c):
                    out[t] += (uo * tanh_rational(ub + u0 * x0[t] + u1 * x1[t] + u2 * x2[t] + u3 * x3[t])
                               + vo * tanh_rational(vb + v0 * x0[t] + v1 * x1[t] + v2 * x2[t] + v3 * x3[t]))
            j0 = hidden - hidden % 2
        for j in range(j0, hidden):
            for g in range(groups):
                k = 4 * g
                # 1-D views: unit stride known to the compiler, so the loops below vectorise over t
                x0, x1, x2, x3 = XT[k, a : a + c], XT[k + 1, a : a + c], XT[k + 2, a : a + c], XT[k + 3, a : a + c]
                w0, w1, w2, w3 = W1[k, j], W1[k + 1, j], W1[k + 2, j], W1[k + 3, j]
                if groups == 1:  # the common case (≤ 4 inputs): the pre-activation stays in a register
                    for t in range(c):
                        out[t] += W2[j] * tanh_rational(b1[j] + w0 * x0[t] + w1 * x1[t] + w2 * x2[t] + w3 * x3[t])
                elif g == 0:
                    for t in range(c):
                        z[t] = b1[j] + w0 * x0[t] + w1 * x1[t] + w2 * x2[t] + w3 * x3[t]
                elif g < groups - 1:
                    for t in range(c):
                        z[t] += w0 * x0[t] + w1 * x1[t] + w2 * x2[t] + w3 * x3[t]
                else:
                    for t in range(c):
                        out[t] += W2[j] * tanh_rational(z[t] + w0 * x0[t] + w1 * x1[t] + w2 * x2[t] + w3 * x3[t])
        s = np.float32(0.0)
        for t in range(c):
            s += out[t] * out[t]
        total += s  # float32 within a chunk, float64 across chunks
    return total / n


@njit(parallel=True, fastmath=True, error_model="numpy", cache=True)
def _population_mse(W1, b1, W2, b2, XT, y, chunk):  # pragma: no cover - compiled
    P = W1.shape[0]
    mse = np.zeros(P)
    for p in prange(P):
        z = np.empty(chunk, np.float32)
        out = np.empty(chunk, np.float32)
        mse[p] = _network_mse(W1[p], b1[p], W2[p], b2[p], XT, y, z, out, chunk)
    return mse


def population_mse_tanh(theta: np.ndarray, XT: np.ndarray, y: np.ndarray, hidden: int,
                        chunk: int | None = None) -> np.ndarray:
    """Mean squared error of each of P tanh networks (flat weights, rows of ``theta``) on (X, y).

    Parameters
    ----------
    theta : np.ndarray
        (P, n_params) weights [W1 (d·h, input-major), b1 (h), W2 (h), b2 (1)].
    XT : np.ndarray
        (d, n) float32 inputs, one row per input (sample-contiguous).
    y : np.ndarray
        (n,) float32 targets [unit of the (standardised) target].
    hidden : int
        Hidden neurons h per network.
    chunk : int, optional
        Samples kept in L1 per network at a time (default 1024: 8 KB; the speed is flat over 256–4096).

    Returns
    -------
    np.ndarray
        (P,) float64 mean squared errors [unit of y squared].
    """
    th = np.ascontiguousarray(theta, dtype=np.float32)
    P, d = th.shape[0], XT.shape[0]
    i = d * hidden
    padded = -(-d // 4) * 4  # zero inputs with zero weights up to a multiple of 4
    W1 = np.zeros((P, padded, hidden), np.float32)
    W1[:, :d] = th[:, :i].reshape(P, d, hidden)
    if padded == d:  # no copy of the inputs
        XT4 = np.ascontiguousarray(XT, dtype=np.float32)
    else:
        XT4 = np.zeros((padded, XT.shape[1]), np.float32)
        XT4[:d] = XT
    b1 = np.ascontiguousarray(th[:, i : i + hidden])
    W2 = np.ascontiguousarray(th[:, i + hidden : i + 2 * hidden])
    b2 = np.ascontiguousarray(th[:, -1])
    return _population_mse(W1, b1, W2, b2, XT4, np.ascontiguousarray(y, dtype=np.float32),
                           1024 if chunk is None else int(chunk))
