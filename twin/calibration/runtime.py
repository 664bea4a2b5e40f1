"""How a calibration runs on the machine: BLAS on one thread, and freed arrays kept for reuse.

A calibration of a long log is many passes of a few columns over millions of rows, fold after
fold. Two defaults of the runtime cost it more than the arithmetic does:

* a BLAS thread pool: every product has a few columns (≤ 10), every step of the τ search is a
  tiny solve, so threads add their hand-over to each call and, on a machine whose cores are
  shared, spin waiting for work (the 2-hour 4-IMU ULog's fits took half the time on one thread);
* glibc's allocator hands every array above 32 MB back to the kernel when it is freed and maps
  fresh zeroed pages for the next one: a fold's (n, 3) temporaries are faulted in again in every
  fold (4 s of system time on the 6-hour tester log, 1.2 s with the freed memory kept).

:func:`calibration_runtime` changes both for the duration of a calibration, then sets them back
(the allocator to glibc's initial thresholds).
"""

from __future__ import annotations

import contextlib
import ctypes
import ctypes.util

M_TRIM_THRESHOLD, M_MMAP_THRESHOLD = -1, -3  # mallopt parameters (glibc malloc.h)
KEEP_BYTES = 1 << 30  # arrays up to this size come from, and go back to, the heap while calibrating
GLIBC_MMAP_THRESHOLD = 128 * 1024  # glibc's own defaults, set back afterwards
GLIBC_TRIM_THRESHOLD = 128 * 1024


def one_blas_thread():
    """A context in which BLAS runs on one thread (module docstring).

    Returns
    -------
    contextlib.AbstractContextManager
    """
    from threadpoolctl import threadpool_limits  # installed with scikit-learn; only this path needs it

    return threadpool_limits(1, user_api="blas")


@contextlib.contextmanager
def freed_memory_kept():
    """A context in which glibc keeps freed arrays of up to :data:`KEEP_BYTES` for reuse instead of
    unmapping them (module docstring); afterwards its thresholds are set back and the memory kept is
    returned. Elsewhere than glibc (macOS, musl) nothing changes.

    Yields
    ------
    bool
        Whether the allocator was tuned.
    """
    libc = None
    try:
        libc = ctypes.CDLL(ctypes.util.find_library("c") or "libc.so.6")
        tuned = bool(libc.mallopt(M_MMAP_THRESHOLD, KEEP_BYTES) and libc.mallopt(M_TRIM_THRESHOLD, 2 * KEEP_BYTES))
    except (OSError, AttributeError):
        tuned = False
    try:
        yield tuned
    finally:
        if tuned:
            libc.mallopt(M_MMAP_THRESHOLD, GLIBC_MMAP_THRESHOLD)
            libc.mallopt(M_TRIM_THRESHOLD, GLIBC_TRIM_THRESHOLD)
            libc.malloc_trim(0)


@contextlib.contextmanager
def calibration_runtime():
    """:func:`one_blas_thread` and :func:`freed_memory_kept` together, for one calibration.

    Yields
    ------
    None
    """
    with one_blas_thread(), freed_memory_kept():
        yield
