"""The play (backlash) operator: the elementary hysteron of the Prandtl–Ishlinskii model.

p[k] = clamp(p[k−1], x[k] − r, x[k] + r). Three evaluations of the same recursion, bit-identical
(min/max only, no rounding): a compiled loop for very long inputs, a two-level blocked scan in
NumPy for everything else, and the log-step prefix scan as the pure-NumPy reference.
"""

from __future__ import annotations

import math

import numpy as np

from sim import compiled


def play_operator_scan(x: np.ndarray, half_width: float, initial: float | None = None) -> np.ndarray:
    """Play operator by a parallel prefix scan of composed clamps: the pure-NumPy reference.

    Each step is a clamp, clamps compose into clamps, and composition is associative, so a
    log-step prefix scan replaces the recursion: about log2(N) vectorised passes over 2N arrays.
    Every output is one of x[k] ± r or ``initial`` (min/max only, no rounding), so any correct
    evaluation order gives bit-identical results.

    Parameters
    ----------
    x : ndarray
        Input path [any unit].
    half_width : float
        Half-width r of the play [unit of x], ≥ 0.
    initial : float, optional
        Output before the first sample [unit of x]; default x[0].

    Returns
    -------
    ndarray
        Play output p [unit of x].

    References
    ----------
    Krasnosel'skii & Pokrovskii (1989), as :func:`play_operator`.
    """
    x = np.asarray(x, float)
    if x.size == 0:
        return x.copy()
    r = _half_width(half_width)
    lo, hi = x - r, x + r  # clamp interval of step k
    shift = 1
    while shift < x.size:
        # compose step k (later) with the accumulated map ending at k − shift (earlier);
        # the right-hand sides are evaluated before the in-place assignment.
        l_lo, l_hi = lo[shift:], hi[shift:]
        new_lo = np.minimum(np.maximum(lo[:-shift], l_lo), l_hi)
        hi[shift:] = np.minimum(np.maximum(hi[:-shift], l_lo), l_hi)
        lo[shift:] = new_lo
        shift *= 2
    p0 = x[0] if initial is None else float(initial)
    return np.minimum(np.maximum(p0, lo), hi)


def play_operator_blocked(x: np.ndarray, half_width: float, initial: float | None = None) -> np.ndarray:
    """Play operator by a two-level scan of composed clamps in O(N): the NumPy path for most sizes.

    The samples are cut into m blocks of b ≈ √N steps, laid out as a (b, m) array so that step k
    of every block is one contiguous row. A loop over the b rows composes each block's clamps
    (one vector operation per row across all blocks), a scalar loop over the m block ends gives
    each block's starting state, and one clamp of those states by the composed maps gives every
    output: about three passes over the data, against log2(N) for :func:`play_operator_scan`.
    Min/max only, so the result is bit-identical to the recursion.

    Parameters
    ----------
    x : ndarray
        Input path [any unit].
    half_width : float
        Half-width r of the play [unit of x], ≥ 0.
    initial : float, optional
        Output before the first sample [unit of x]; default x[0].

    Returns
    -------
    ndarray
        Play output p [unit of x].

    References
    ----------
    Krasnosel'skii & Pokrovskii (1989), as :func:`play_operator`; the two-level scan is the
    blocked form of Blelloch (1990), *Prefix sums and their applications*.
    """
    x = np.asarray(x, float)
    r = _half_width(half_width)
    n = x.size
    if n == 0:
        return x.copy()
    b = math.isqrt(n)
    m = -(-n // b)
    full = (m - 1) * b  # samples in the m − 1 full blocks; the last holds n − full
    lo, hi = np.empty((b, m)), np.empty((b, m))  # lo[k, j], hi[k, j]: the clamp of sample j·b + k
    np.subtract(x[:full].reshape(m - 1, b), r, out=lo.T[: m - 1])
    np.add(x[:full].reshape(m - 1, b), r, out=hi.T[: m - 1])
    tail = n - full
    lo[:tail, -1], hi[:tail, -1] = x[full:] - r, x[full:] + r
    lo[tail:, -1], hi[tail:, -1] = -np.inf, np.inf  # padding past the end (outputs dropped)
    row = np.empty(m)
    for k in range(1, b):
        # the map of steps 0..k of each block: clamp k after the map of steps 0..k−1. hi first,
        # then lo against the new hi: clip(lo, a, clip(hi, a, b)) = clip(lo, a, b) as lo ≤ hi.
        # (two ufuncs with out=: np.clip's Python wrapper costs twice as much on rows this short)
        np.minimum(np.maximum(hi[k - 1], lo[k], out=row), hi[k], out=hi[k])
        np.minimum(np.maximum(lo[k - 1], lo[k], out=row), hi[k], out=lo[k])
    start = np.empty(m)
    p = x[0] if initial is None else float(initial)
    for j, (a, c) in enumerate(zip(lo[-1].tolist(), hi[-1].tolist())):
        start[j] = p
        p = min(max(p, a), c)
    out = np.empty(m * b)
    np.clip(start, lo, hi, out=out.reshape(m, b).T)
    return out[:n]


def play_operator(x: np.ndarray, half_width: float, initial: float | None = None) -> np.ndarray:
    """Play (backlash) operator: p[k] = clamp(p[k−1], x[k] − r, x[k] + r), p[−1] = ``initial``.

    Rate-independent memory of the input path (the elementary hysteron of the
    Prandtl–Ishlinskii model). Runs :func:`play_operator_blocked` (NumPy, O(N)) up to
    ``COMPILED_MIN_SIZE`` samples, and the recursion as one compiled pass beyond that or once the
    compiled kernel is loaded (when numba is installed; compiled once, cached on disk). Both
    return bit-identical arrays (min/max only).

    Parameters
    ----------
    x : ndarray
        Input path [any unit].
    half_width : float
        Half-width r of the play [unit of x], ≥ 0.
    initial : float, optional
        Output before the first sample [unit of x]; default x[0].

    Returns
    -------
    ndarray
        Play output p [unit of x].

    References
    ----------
    Krasnosel'skii & Pokrovskii (1989), *Systems with Hysteresis*.
    """
    x = np.asarray(x, float)
    r = _half_width(half_width)
    # importing numba and loading the cached kernel costs ~0.9 s (bench_long.json): the blocked
    # scan (~30 ns per sample) runs ten calls on 3 M samples in about that time
    kernel = _play_kernel() if (_KERNEL or x.size >= COMPILED_MIN_SIZE) else None
    if kernel is None or x.size == 0:
        return play_operator_blocked(x, r, initial)
    p0 = x[0] if initial is None else float(initial)
    out = np.empty_like(x)
    kernel(np.ascontiguousarray(x), r, p0, out)
    return out


def _half_width(half_width: float) -> float:
    r = float(half_width)
    if r < 0:
        raise ValueError(f"half_width must be >= 0, got {r}")
    return r


COMPILED_MIN_SIZE = 4_000_000
_KERNEL: list = []  # [compiled kernel or None], filled on first use: importing numba costs ~0.3 s


def _play_kernel():
    """The numba kernel of the play recursion, or None without numba (or with TDE_TWIN_NO_NUMBA=1)."""
    if not _KERNEL:
        _KERNEL.append(_compile_play())
    return _KERNEL[0]


def _compile_play():
    jit = compiled.njit()
    if jit is None:  # optional accelerator: the blocked scan gives the same output
        return None

    @jit
    def play_loop(x, r, p, out):  # pragma: no cover - compiled
        for k in range(x.size):
            p = min(max(p, x[k] - r), x[k] + r)  # branch-free: the clamp's branch would mispredict
            out[k] = p

    return play_loop
