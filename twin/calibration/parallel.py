"""The IMUs of one calibration side by side, one process each: a flight controller logs up to four
accelerometers, and each is calibrated on its own (its own folds, methods and validation), so on a
machine with several cores their wall time is that of the slowest rather than the sum.

Workers are forked (:func:`twin.processes.fork_context`): they start with the parent's imports and
its logs in memory, so nothing large is pickled and no worker re-imports the stack; each returns
its IMU's result (pickled back) and ends with the parent. Where fork is missing, or with one worker
or one IMU, the IMUs are calibrated one after the other in this process — the same results, as
every IMU's calibration depends on its own logs only.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Iterator

from twin.errors import TwinError
from twin.processes import die_with_parent, fork_context, usable_cpus

_JOB: list = []  # the job a forked worker runs: set in the parent just before the fork


def imu_workers(requested: int | None, imus: int) -> int:
    """Processes for ``imus`` IMUs: ``requested`` (≥ 1) or one per IMU up to the usable CPUs.

    Parameters
    ----------
    requested : int, optional
        Asked for (``--workers``).
    imus : int
        IMUs to calibrate.

    Returns
    -------
    int
        Between 1 and ``imus``; 1 in a daemonic process, which may not start workers of its own.
    """
    import multiprocessing

    if multiprocessing.current_process().daemon:  # a daemonic worker (a Dask or Pool worker) may not fork
        return 1
    wanted = usable_cpus() if requested is None else max(1, int(requested))
    return max(1, min(wanted, imus))


def _run(instance: int, position: int):
    outcome = _JOB[0](instance, position)
    # a refusal travels back as the base error with its message (a subclass's own constructor
    # arguments need not survive pickling); anything else is a bug and is raised as it is
    return TwinError(str(outcome)) if isinstance(outcome, TwinError) else outcome


def each_imu(job: Callable[[int, int], object], instances: Iterable[int],
             workers: int | None = None) -> Iterator[tuple[int, object]]:
    """``(instance, job(instance, position))`` for each instance, in the given order.

    Parameters
    ----------
    job : callable
        ``job(instance, position)`` → the IMU's result or the :class:`TwinError` refusing it;
        ``position`` is the row of its progress bar.
    instances : iterable of int
        IMU instances, in the order the results are wanted.
    workers : int, optional
        See :func:`imu_workers`.

    Yields
    ------
    (int, object)
        The instance and what ``job`` returned for it.
    """
    instances = list(instances)
    n = imu_workers(workers, len(instances))
    context = fork_context() if n > 1 else None
    if context is None:
        for position, instance in enumerate(instances):
            yield instance, job(instance, position)
        return
    from concurrent.futures import ProcessPoolExecutor

    _JOB[:] = [job]
    try:
        with ProcessPoolExecutor(n, mp_context=context, initializer=die_with_parent) as pool:
            futures = [pool.submit(_run, instance, position) for position, instance in enumerate(instances)]
            for instance, future in zip(instances, futures):
                yield instance, future.result()
    finally:
        _JOB.clear()
