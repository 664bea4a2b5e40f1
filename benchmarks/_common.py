"""Shared by the benchmark scripts: the machine a figure was measured on, and the JSON writer."""

import json
import os
import platform
import sys
from importlib.metadata import PackageNotFoundError, version
from pathlib import Path


def machine() -> dict:
    """CPU model, logical CPUs, BLAS thread settings and library versions: figures from different
    machines must never be mixed."""
    cpu = platform.processor() or platform.machine()
    try:
        with open("/proc/cpuinfo") as f:
            cpu = next((line.split(":", 1)[1].strip() for line in f if line.startswith("model name")), cpu)
    except OSError:
        pass
    libs = {}
    for name in ("tde-twin", "numpy", "scipy", "torch", "pandas", "scikit-learn", "pyulog", "pymavlink", "numba",
                 "pyarrow", "scikit-fem", "dask", "distributed", "polars"):
        try:
            libs[name] = version(name)
        except PackageNotFoundError:
            pass
    threads = {k: os.environ[k] for k in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS") if k in os.environ}
    if "torch" in sys.modules:  # the thread count torch actually ran with, when the benchmark used it
        threads["torch_num_threads"] = sys.modules["torch"].get_num_threads()
    return {"cpu_model": cpu, "logical_cpus": os.cpu_count(), "python": platform.python_version(),
            "platform": platform.platform(), "thread_env": threads, "libraries": libs}


def write_json(path: str | Path, result: dict) -> None:
    """Write ``result`` with the machine it was measured on, and echo it."""
    out = Path(path)
    out.parent.mkdir(parents=True, exist_ok=True)
    result = {**result, "machine": machine()}
    out.write_text(json.dumps(result, indent=2) + "\n")
    print(json.dumps(result, indent=2))
