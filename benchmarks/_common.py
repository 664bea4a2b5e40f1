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


def timed(cmd: list[str], env: dict | None = None) -> dict:
    """Run ``cmd`` under ``/usr/bin/time -v``: wall [s], user+sys CPU [s], peak RSS [MB], its stdout.

    Parameters
    ----------
    cmd : list of str
        The command.
    env : dict, optional
        Variables added to the environment.

    Returns
    -------
    dict
        ``wall_s``, ``cpu_s``, ``peak_rss_mb``, ``stdout``.
    """
    import re
    import subprocess

    r = subprocess.run(["/usr/bin/time", "-v", *cmd], capture_output=True, text=True, check=False,
                       env={**os.environ, **(env or {})})
    if r.returncode:
        raise SystemExit(f"{' '.join(cmd)} failed:\n{r.stderr[-3000:]}")
    grab = lambda key: re.search(rf"{key}: (.+)", r.stderr).group(1).strip()  # noqa: E731
    wall = [float(x) for x in grab(r"Elapsed \(wall clock\) time \(h:mm:ss or m:ss\)").split(":")]
    return {"wall_s": sum(v * 60 ** i for i, v in enumerate(reversed(wall))),
            "cpu_s": float(grab("User time \\(seconds\\)")) + float(grab("System time \\(seconds\\)")),
            "peak_rss_mb": int(grab(r"Maximum resident set size \(kbytes\)")) / 1024, "stdout": r.stdout}


def median_of(runs: list[dict]) -> dict:
    """Per key, the median of the runs' numbers (other values from the first run).

    Parameters
    ----------
    runs : list of dict
        Runs of one measurement.

    Returns
    -------
    dict
        Medians, and ``runs``: how many.
    """
    import statistics

    out = {k: (statistics.median(r[k] for r in runs) if isinstance(v, (int, float)) and not isinstance(v, bool) else v)
           for k, v in runs[0].items()}
    return {**out, "runs": len(runs)}
