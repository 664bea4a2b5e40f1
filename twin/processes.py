"""Worker processes that end with their parent, and how many a job on this machine should use."""

from __future__ import annotations

import ctypes
import multiprocessing
import os
import signal
import sys
import threading
import time


def die_with_parent() -> None:
    """Pool initialiser: end this worker when its parent dies, a kill -9 included (Linux: the
    kernel's PR_SET_PDEATHSIG; elsewhere, and as a backstop, a thread polling the parent)."""
    parent = os.getppid()
    if sys.platform.startswith("linux"):
        try:
            ctypes.CDLL(None, use_errno=True).prctl(1, int(signal.SIGKILL))  # 1 = PR_SET_PDEATHSIG
        except (OSError, AttributeError):
            pass

    def watch() -> None:
        while os.getppid() == parent:
            time.sleep(1.0)
        os._exit(1)

    threading.Thread(target=watch, daemon=True).start()


def usable_cpus() -> int:
    """CPUs this process may run on (its affinity mask where the OS has one, else the count).

    Returns
    -------
    int
        At least 1.
    """
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except AttributeError:  # macOS, Windows
        return max(1, os.cpu_count() or 1)


def fork_context():
    """The ``fork`` start method where the platform has it, else None.

    A forked worker starts with the parent's imports and data (no re-import, no pickling of the
    inputs), which is what makes a pool worth it for jobs of a few seconds; where only ``spawn``
    exists the caller runs its jobs in this process instead.

    Returns
    -------
    multiprocessing.context.BaseContext or None
    """
    if "fork" not in multiprocessing.get_all_start_methods() or sys.platform == "darwin":
        return None  # macOS: fork is unsafe with its system frameworks
    return multiprocessing.get_context("fork")
