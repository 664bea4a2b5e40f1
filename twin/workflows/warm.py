"""Importing the analysis while the log is read.

A command such as ``twin compare`` spends its first seconds importing the numerical stack (SciPy's
signal and statistics modules, the effect library, the diagnosis) and then reading the log. The
two are independent, and the log's parser (pandas' C tokenizer) runs without Python's global
interpreter lock for most of its work, so on a machine with two cores the imports can run on a
thread while the main thread reads: the command then waits for the longer of the two, not their
sum. The main thread still imports every module itself afterwards — an import that failed on the
thread fails again there, with its own traceback, where the command reports it.
"""

from __future__ import annotations

import importlib
import threading


def import_in_background(*modules: str) -> threading.Thread:
    """Start importing ``modules`` on a daemon thread; ``join()`` it before using them.

    Parameters
    ----------
    *modules : str
        Dotted module names.

    Returns
    -------
    threading.Thread
        The started thread.
    """
    def run() -> None:
        for name in modules:
            try:
                importlib.import_module(name)
            except Exception:  # noqa: BLE001  re-raised by the main thread's own import of it
                return

    thread = threading.Thread(target=run, name="twin-import", daemon=True)
    thread.start()
    return thread
