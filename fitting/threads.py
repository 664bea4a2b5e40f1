"""Back-propagation on one thread: the tensors of one network are too small to share.

One L-BFGS evaluation of a 4-10-1 network on 350k samples is ~24 chunks × 12 tensor operations of
16384 × 10 values. Split over two threads, each operation ends in a barrier, and when another
process holds one of the cores every barrier waits for its time slice: measured on a shared
2-core AMD EPYC, 0.95 s per evaluation on torch's two threads against 0.08 s on one (scikit-learn's
MLPRegressor, single-threaded NumPy: 0.11 s). scipy's BLAS on 61-vectors gains nothing from
threads either, and its spinning threads fight torch's for the cores.
"""

from __future__ import annotations

from contextlib import contextmanager


@contextmanager
def one_thread(torch):
    """torch's intra-op threads and the BLAS thread pools limited to one, restored on exit.

    Parameters
    ----------
    torch : module
        The torch module (imported by the caller: this package imports it lazily).

    Yields
    ------
    None
    """
    from threadpoolctl import threadpool_limits  # installed with scikit-learn

    before = torch.get_num_threads()
    torch.set_num_threads(1)
    try:
        with threadpool_limits(1, user_api="blas"):
            yield
    finally:
        torch.set_num_threads(before)
