"""``twin calibrate`` at the scale of real logs (issue 28): the whole process against PX4's method
on the same file, wall time, µs per row and peak memory; JSON out.

Logs (generated here, known truth):

* **PX4 thermal-calibration ULog**: 2 hours, 4 accelerometers logged at 10 Hz (what the PX4 logger's
  thermal-calibration profile records), written by the project's own ULog writer
  (``tests/logfixtures.write_ulog``). The board is cold-soaked and warms in a heated enclosure,
  −10 → 65 °C, then cools for the last half hour with the heater off; each IMU sits at its own
  place on the board (its own offset and lag), each axis with its own cubic offset, rate term and
  noise.
* **Production tester CSV**: 3 axes at 100 Hz through a chamber program repeating every 1.5 h
  (10 min dwell at −20 °C, 2 °C/min to 50 °C, 10 min dwell, 2 °C/min back); the board follows the
  air through τ = 300 s, the thermometer the board through 2 s (±0.01 °C noise, 0.01 °C
  resolution), the die the board through 120 s; per axis a cubic in the die temperature, a rate
  term through 60 s and 1 mg white noise. 0.54 / 1.08 / 2.16 M rows are its first 1.5 / 3 / 6 hours.

Each log is timed three times, each in a process of its own under ``/usr/bin/time -v`` (wall, CPU,
peak RSS): ``twin calibrate`` (every method, the held-out validation, the document), and two
baselines of PX4's ``Tools/process_sensor_caldata.py``:

* ``px4_method`` — its core alone: read the accelerometer topic, then per sensor and axis a cubic
  in temperature by ``np.polyfit`` over the whole log (the project's
  :class:`~twin.calibration.models.CubicCompensator` form). A lower bound of the script: no
  filtering, binning, plots or parameter file.
* ``px4_script_equivalent`` — what running the script does for its user, written here in this
  project's own code (:data:`PX4_SCRIPT_EQUIVALENT`): every topic parsed, per gyro, accelerometer
  and barometer instance the median filter, the 2000 temperature bins filled sample by sample (the
  script's loop), the polynomial, a PDF page of plots per sensor (matplotlib) and the ``.params``
  file. The issue measured the script itself at 5.25 s on its 2-hour ULog.

The ratios of ``twin calibrate`` to each are the figures: the CPU is shared, so absolute times move
from run to run while ratios in one run hold.

Targets (issue 28, AMD EPYC, 2 cores): the ULog ≤ 1× PX4's method (both baselines reported); the
2.16 M-row log ≤ 30 s and ≤ 1 GB, µs per row at 2.16 M no higher than at 0.54 M.

``--baseline DIR`` also times an earlier version (a folder holding its ``twin`` package, e.g. a
``git worktree`` of the commit before) on the logs of ``--baseline-sizes``, in the same run.

Usage: python benchmarks/bench_calibrate_scale.py [--sizes ulog,0.54M,1.08M,2.16M] [--quick]
[--runs N] [--baseline DIR [--baseline-sizes ulog,0.54M]] [--tmp DIR] [--merge]
[--json benchmarks/results/bench_calibrate_scale.json]
"""

from __future__ import annotations

import argparse
import json
import re
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
from scipy.signal import lfilter

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "tests"))
sys.path.insert(0, str(Path(__file__).resolve().parent))

from _common import write_json  # noqa: E402

G0 = 9.80665
SIZES = {"0.54M": 540_000, "1.08M": 1_080_000, "2.16M": 2_160_000}
TESTER_RATE_HZ = 100.0
# chamber program [s, °C], repeated: dwell, 2 °C/min up, dwell, 2 °C/min down (1.5 h)
PROGRAM = [(0.0, -20.0), (600.0, -20.0), (2700.0, 50.0), (3300.0, 50.0), (5400.0, -20.0)]
BOARD_TAU_S, PROBE_TAU_S, DIE_TAU_S, RATE_TAU_S = 300.0, 2.0, 120.0, 60.0
T_REF_C = 25.0
# per axis: cubic offset [mg, mg/°C, mg/°C², mg/°C³] in T_die − 25 °C and rate amplitude [mg/°C]
TESTER_CUBIC_MG = np.array([[3.0, 0.40, 4e-3, -6e-5], [-2.0, -0.25, -3e-3, 4e-5], [5.0, 0.60, 2e-3, 8e-5]])
TESTER_RATE_MG = np.array([1.5, -1.0, 2.0])
NOISE_MG = 1.0
TESTER_COLUMNS = ["--time-col", "time_s", "--temperature-col", "temp_c", "--x-col", "ax_g", "--y-col", "ay_g",
                  "--z-col", "az_g", "--output-unit", "g"]
ULOG_HOURS, ULOG_RATE_HZ, ULOG_IMUS = 2.0, 10.0, 4



def _describe(baseline: Path) -> str:
    """The baseline by its git commit when it is a checkout (a path of this machine means nothing
    in the published figures)."""
    r = subprocess.run(["git", "-C", str(baseline), "log", "-1", "--format=%h %s"], capture_output=True, text=True)
    return f"commit {r.stdout.strip()[:80]}" if r.returncode == 0 and r.stdout.strip() else "an earlier version's copy"

def _lag(u: np.ndarray, dt_s: float, tau_s: float, zi: np.ndarray | None = None):
    """First-order lag (exact for a held input) from equilibrium, or carrying the state ``zi``."""
    a = np.exp(-dt_s / tau_s)
    zi = np.array([a * u[0]]) if zi is None else zi
    return lfilter([1 - a], [1, -a], u, zi=zi)


def chamber_c(t_s: np.ndarray) -> np.ndarray:
    """The chamber program [°C] at ``t_s``, repeating."""
    t, v = np.array(PROGRAM).T
    return np.interp(np.mod(t_s, t[-1]), t, v)


def write_tester_csv(path: Path, rows: int, seed: int = 28) -> Path:
    """The production tester's log: ``time_s,temp_c,ax_g,ay_g,az_g`` at 100 Hz, written an hour at a time."""
    rng = np.random.default_rng(seed)
    dt = 1.0 / TESTER_RATE_HZ
    state = {}
    import pyarrow as pa
    import pyarrow.csv as pacsv

    chunk = int(3600 * TESTER_RATE_HZ)
    names = ("time_s", "temp_c", "ax_g", "ay_g", "az_g")
    with open(path, "wb") as sink, pacsv.CSVWriter(sink, pa.schema([(c, pa.float64()) for c in names]),
                                                   write_options=pacsv.WriteOptions(include_header=False,
                                                                                    quoting_style="none")) as writer:
        sink.write((",".join(names) + "\n").encode())
        for start in range(0, rows, chunk):
            k = np.arange(start, min(start + chunk, rows))
            t = k * dt
            board, state["board"] = _lag(chamber_c(t), dt, BOARD_TAU_S, state.get("board"))
            probe, state["probe"] = _lag(board, dt, PROBE_TAU_S, state.get("probe"))
            die, state["die"] = _lag(board, dt, DIE_TAU_S, state.get("die"))
            temp = np.round(probe + rng.normal(0, 0.01, k.size), 2)
            slow, state["slow"] = _lag(probe, dt, RATE_TAU_S, state.get("slow"))
            d = die - T_REF_C
            offset_mg = (TESTER_CUBIC_MG[:, :1] + TESTER_CUBIC_MG[:, 1:2] * d + TESTER_CUBIC_MG[:, 2:3] * d**2
                         + TESTER_CUBIC_MG[:, 3:] * d**3 + TESTER_RATE_MG[:, None] * (probe - slow))
            acc = offset_mg.T * 1e-3 + rng.normal(0, NOISE_MG * 1e-3, (k.size, 3))
            acc[:, 2] += 1.0
            # rounded as a tester writes them (ms, 0.01 °C, µg); Arrow prints each double's shortest form
            writer.write_table(pa.table({"time_s": np.round(t, 3), "temp_c": temp, "ax_g": np.round(acc[:, 0], 6),
                                         "ay_g": np.round(acc[:, 1], 6), "az_g": np.round(acc[:, 2], 6)}))
    return path


def ulog_imus(hours: float = ULOG_HOURS, rate_hz: float = ULOG_RATE_HZ, n_imus: int = ULOG_IMUS, seed: int = 4):
    """Four IMUs of one board through a PX4 thermal calibration (module docstring), as ``ImuTruth``."""
    from logfixtures import ImuTruth

    rng = np.random.default_rng(seed)
    n = int(hours * 3600 * rate_hz)
    dt = 1.0 / rate_hz
    t = np.arange(n) * dt
    heat_until = hours * 3600 - 1800.0
    # heater on: the enclosure approaches 70 °C through 40 min from a −10 °C soak; then off, back to −10 °C
    enclosure = np.where(t < heat_until, 70.0, -10.0)
    air, _ = _lag(np.r_[-10.0, enclosure[1:]], dt, 2400.0, np.array([np.exp(-dt / 2400.0) * -10.0]))
    out = []
    for k in range(n_imus):
        board, _ = _lag(air, dt, 200.0 + 60.0 * k)
        temp = board + 3.0 * k + rng.normal(0, 0.02, n)
        die, _ = _lag(board + 3.0 * k, dt, 40.0 + 25.0 * k)
        slow, _ = _lag(temp, dt, 30.0)
        d = die - T_REF_C
        coef = TESTER_CUBIC_MG * (1.0 + 0.3 * k) * np.array([1, 1, 1, 0.5])
        offset_mg = (coef[:, :1] + coef[:, 1:2] * d + coef[:, 2:3] * d**2 + coef[:, 3:] * d**3
                     + (TESTER_RATE_MG * (1 - 0.2 * k))[:, None] * (temp - slow))
        acc = (offset_mg.T * 1e-3 + rng.normal(0, NOISE_MG * 1e-3, (n, 3))) * G0
        acc[:, 2] -= G0
        time_us = (1_000_000 + np.round(t * 1e6) + 137 * k).astype(np.uint64)
        out.append(ImuTruth(k, 2424842 + 65536 * k, time_us, temp.astype(np.float32), acc.astype(np.float32)))
    return out


def write_px4_ulog(path: Path, hours: float = ULOG_HOURS) -> Path:
    """The PX4 thermal-calibration ULog (module docstring), by the project's ULog writer."""
    from logfixtures import write_ulog

    return write_ulog(path, ulog_imus(hours))


# PX4's method as a process of its own (Tools/process_sensor_caldata.py without its plots): read the
# log (pyulog, as PX4's script; pandas for the tester's CSV), then per sensor instance and axis
# np.polyfit of a cubic in T − TREF over the whole log, TREF the middle of the temperature range
PX4_METHOD = r"""
import json, sys
import json

import numpy as np
path = sys.argv[1]
if path.endswith(".ulg"):
    from pyulog import ULog
    ulog = ULog(path, ["sensor_accel"])
    sensors = [(d.multi_id, d.data["temperature"].astype(float), np.column_stack([d.data[a] for a in "xyz"]).astype(float))
               for d in ulog.data_list if d.name == "sensor_accel"]
else:
    import pandas as pd
    d = pd.read_csv(path)
    sensors = [(0, d["temp_c"].to_numpy(float), d[["ax_g", "ay_g", "az_g"]].to_numpy(float) * 9.80665)]
out = {}
for instance, temp, accel in sensors:
    tref = 0.5 * (temp.min() + temp.max())
    out[int(instance)] = {"tref_c": tref, "coef": [np.polyfit(temp - tref, accel[:, k], 3).tolist() for k in range(3)],
                          "rows": int(temp.size)}
print(json.dumps(out))
"""


# What running PX4's Tools/process_sensor_caldata.py gives its user, in this project's own code: the
# whole ULog parsed by pyulog (every topic: the script passes no filter); per sensor_gyro, sensor_accel
# and sensor_baro instance the device id (median), TMIN/TMAX/TREF, scipy's medfilt(31) per axis (the
# accelerometer's median subtracted), the readings binned into 2000 equal temperature bins one sample
# at a time in a Python loop (the script's resampleWithDeltaX is such a loop, and its user waits for
# it), np.polyfit of degree 3 (the barometer's pressure: 5); a page per sensor in a PDF (the filtered
# readings and the fitted curve against temperature, an axis per subplot, matplotlib) and the
# QGroundControl .params file of every TC_* value. A tester's CSV (no ULog) is read with pandas and
# processed as one accelerometer.
PX4_SCRIPT_EQUIVALENT = r"""
import sys
from pathlib import Path

import matplotlib
matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np
from matplotlib.backends.backend_pdf import PdfPages
from scipy.signal import medfilt

G0 = 9.80665
BINS = 2000
path, out = Path(sys.argv[1]), Path(sys.argv[2])


def binned(x, y):
    lo, hi = x.min(), x.max()
    width = (hi - lo) / BINS
    sx, sy, n = np.zeros(BINS), np.zeros(BINS), np.zeros(BINS)
    for xi, yi in zip(x.tolist(), y.tolist()):  # per sample, as the script's loop
        k = BINS - 1 if xi >= hi else max(int((xi - lo) / width), 0)
        sx[k] += xi
        sy[k] += yi
        n[k] += 1
    keep = n > 0
    return sx[keep] / n[keep], sy[keep] / n[keep]


def sensors():
    if path.suffix == ".ulg":
        from pyulog import ULog

        for d in ULog(str(path), None).data_list:
            kind = {"sensor_gyro": "G", "sensor_accel": "A", "sensor_baro": "B"}.get(d.name)
            if kind:
                cols = ["pressure"] if kind == "B" else ["x", "y", "z"]
                yield kind, d.multi_id, int(np.median(d.data["device_id"])), d.data["temperature"].astype(float),                     np.column_stack([d.data[c] for c in cols]).astype(float)
    else:
        import pandas as pd

        d = pd.read_csv(path)
        yield "A", 0, 0, d["temp_c"].to_numpy(float), d[["ax_g", "ay_g", "az_g"]].to_numpy(float) * G0


params = []
with PdfPages(out / (path.name + ".pdf")) as pdf:
    for kind, inst, dev, temp, data in sensors():
        tmin, tmax = float(temp.min()), float(temp.max())
        tref = 0.5 * (tmin + tmax)
        rel = temp - tref
        grid = np.linspace(tmin - tref, tmax - tref, 100)
        degree = 5 if kind == "B" else 3
        name = f"TC_{kind}{inst}"
        params += [(f"{name}_ID", dev, 6), (f"{name}_TMIN", tmin, 9), (f"{name}_TMAX", tmax, 9), (f"{name}_TREF", tref, 9)]
        fig, axes = plt.subplots(data.shape[1], 1, figsize=(20, 13), squeeze=False)
        for k in range(data.shape[1]):
            y = medfilt(data[:, k], 31)
            if kind == "A":
                y = y - np.median(y)
            coef = np.polyfit(*binned(rel, y), degree)
            params += [(f"{name}_X{p}_{k}" if kind != "B" else f"{name}_X{p}", float(c), 9)
                       for p, c in zip(range(degree, -1, -1), coef)]
            ax = axes[k, 0]
            ax.plot(temp, y, "b")
            ax.plot(grid + tref, np.polyval(coef, grid), "r")
            ax.set_xlabel("temperature (degC)")
            ax.grid()
        axes[0, 0].set_title(f"{name} ({dev}) bias vs temperature")
        pdf.savefig(fig)
        plt.close(fig)
with open(out / (path.name + ".params"), "w") as f:
    f.write("# Onboard parameters\n#\n# Vehicle-Id Component-Id Name Value Type\n")
    for key, value, kind in params:
        f.write(f"1\t1\t{key}\t{value:.20f}\t{kind}\n" if kind == 9 else f"1\t1\t{key}\t{value}\t{kind}\n")
print(len(params), "parameters")
"""


def timed(cmd: list[str], cwd: Path = ROOT) -> dict:
    """Run ``cmd`` under /usr/bin/time -v: wall [s], user + system CPU [s], peak RSS [MB]."""
    r = subprocess.run(["/usr/bin/time", "-v", *cmd], capture_output=True, text=True, check=False, cwd=cwd)
    if r.returncode:
        raise SystemExit(f"{' '.join(cmd)} failed:\n{r.stderr[-3000:]}")
    grab = lambda key: re.search(rf"{key}: (.+)", r.stderr).group(1).strip()  # noqa: E731
    wall = [float(x) for x in grab(r"Elapsed \(wall clock\) time \(h:mm:ss or m:ss\)").split(":")]
    return {"wall_s": sum(v * 60 ** i for i, v in enumerate(reversed(wall))),
            "cpu_s": float(grab(r"User time \(seconds\)")) + float(grab(r"System time \(seconds\)")),
            "peak_rss_mb": int(grab(r"Maximum resident set size \(kbytes\)")) / 1024}


def calibrate_cmd(log: Path, out: Path) -> list[str]:
    cols = TESTER_COLUMNS if log.suffix == ".csv" else []
    return [sys.executable, "-m", "twin.cli", "calibrate", str(log), *cols, "-o", str(out)]


def measure(log: Path, rows: int, tmp: Path, runs: int, baseline: Path | None = None) -> dict:
    """``twin calibrate`` and PX4's method on ``log``, alternating, ``runs`` times each: medians;
    with ``baseline`` (a folder holding another version's ``twin`` package) that version once too."""
    ours, px4, script = [], [], []
    (tmp / "px4_script").mkdir(exist_ok=True)
    for _ in range(runs):
        ours.append(timed(calibrate_cmd(log, tmp / f"{log.stem}.cal.json")))
        px4.append(timed([sys.executable, "-c", PX4_METHOD, str(log)]))
        script.append(timed([sys.executable, "-c", PX4_SCRIPT_EQUIVALENT, str(log), str(tmp / "px4_script")]))
    before = timed(calibrate_cmd(log, tmp / f"{log.stem}.before.json"), cwd=baseline) if baseline else None
    med = lambda rs, key: float(np.median([r[key] for r in rs]))  # noqa: E731
    doc = json.loads((tmp / f"{log.stem}.cal.json").read_text())
    twin = {k: med(ours, k) for k in ("wall_s", "cpu_s", "peak_rss_mb")}
    base = {k: med(px4, k) for k in ("wall_s", "cpu_s", "peak_rss_mb")}
    whole = {k: med(script, k) for k in ("wall_s", "cpu_s", "peak_rss_mb")}
    return {
        "rows": rows, "file_mb": log.stat().st_size / 1e6, "runs": runs,
        "twin_calibrate": {**twin, "us_per_row": twin["wall_s"] / rows * 1e6, "cpu_us_per_row": twin["cpu_s"] / rows * 1e6,
                           "all_wall_s": [r["wall_s"] for r in ours]},
        "px4_method": {**base, "us_per_row": base["wall_s"] / rows * 1e6, "all_wall_s": [r["wall_s"] for r in px4]},
        "px4_script_equivalent": {**whole, "us_per_row": whole["wall_s"] / rows * 1e6,
                                  "all_wall_s": [r["wall_s"] for r in script]},
        "ratio_wall_to_px4": twin["wall_s"] / base["wall_s"], "ratio_cpu_to_px4": twin["cpu_s"] / base["cpu_s"],
        "ratio_wall_to_px4_script": twin["wall_s"] / whole["wall_s"],
        "ratio_cpu_to_px4_script": twin["cpu_s"] / whole["cpu_s"],
        **({"before": {**before, "us_per_row": before["wall_s"] / rows * 1e6,
                       "ratio_wall_to_px4": before["wall_s"] / base["wall_s"], "source": _describe(baseline)}}
           if before else {}),
        "imus": [{"instance": imu["instance"], "samples": imu["samples"],
                  "twin_tau_die_s": imu["methods"]["twin"]["tau_die_s"],
                  "twin_tau_rate_s": imu["methods"]["twin"]["tau_rate_s"],
                  "heldout_rms_mg": imu["validation"]["heldout_rms_mg"]} for imu in doc["imus"]],
    }


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--json", default=str(ROOT / "benchmarks" / "results" / "bench_calibrate_scale.json"))
    ap.add_argument("--sizes", default="ulog," + ",".join(SIZES),
                    help="comma-separated subset of: ulog, " + ", ".join(SIZES))
    ap.add_argument("--runs", type=int, default=1, help="runs of each process per log (medians)")
    ap.add_argument("--quick", action="store_true", help="a 30-minute ULog and the 0.54 M-row log only")
    ap.add_argument("--tmp", default=None, help="folder for the generated logs (default: system temp)")
    ap.add_argument("--baseline", type=Path, default=None,
                    help="folder holding an earlier version's twin package (run from there, once per log)")
    ap.add_argument("--baseline-sizes", default="ulog,0.54M", help="the logs the baseline runs on")
    ap.add_argument("--merge", action="store_true", help="keep the logs --json holds that this run does not measure")
    args = ap.parse_args()
    sizes = ["ulog", "0.54M"] if args.quick else [s.strip() for s in args.sizes.split(",") if s.strip()]
    unknown = [s for s in sizes if s != "ulog" and s not in SIZES]
    if unknown:
        ap.error(f"unknown size(s) {unknown}; expected ulog or {', '.join(SIZES)}")
    hours = 0.5 if args.quick else ULOG_HOURS
    result: dict = {"targets": {"ulog_ratio_wall_to_px4": 1.0, "ulog_ratio_wall_to_px4_script": 1.0,
                                "tester_2.16M_wall_s": 30.0, "tester_2.16M_peak_mb": 1000.0,
                                "us_per_row_2.16M_at_most_0.54M": True},
                    "tester_log": {"rate_hz": TESTER_RATE_HZ, "program": PROGRAM, "axes": 3,
                                   "board_probe_die_rate_tau_s": [BOARD_TAU_S, PROBE_TAU_S, DIE_TAU_S, RATE_TAU_S]},
                    "logs": {}}
    with tempfile.TemporaryDirectory(dir=args.tmp) as d:
        tmp = Path(d)
        for label in sizes:
            start = time.perf_counter()
            if label == "ulog":
                log, rows = write_px4_ulog(tmp / "px4_thermal.ulg", hours), int(hours * 3600 * ULOG_RATE_HZ) * ULOG_IMUS
            else:
                log, rows = write_tester_csv(tmp / f"tester_{label}.csv", SIZES[label]), SIZES[label]
            generated = time.perf_counter() - start
            before = args.baseline if args.baseline and label in args.baseline_sizes.split(",") else None
            res = measure(log, rows, tmp, args.runs, before)
            res["generate_s"] = generated
            if label == "ulog":
                res.update(hours=hours, imus=ULOG_IMUS, rate_hz=ULOG_RATE_HZ, imu_results=res.pop("imus"))
            result["logs"][label] = res
            print(label, json.dumps({k: v for k, v in res.items() if k not in ("imus", "imu_results")}), flush=True)
            log.unlink()
    keep_previous(Path(args.json), result)  # the logs measured now carry the last run's figures
    if args.merge and Path(args.json).exists():
        kept = json.loads(Path(args.json).read_text()).get("logs", {})
        result["logs"] = {label: result["logs"].get(label, kept.get(label))
                          for label in ["ulog", *SIZES] if label in result["logs"] or label in kept}
    logs = result["logs"]
    verdict = {}
    if "ulog" in logs:
        verdict["ulog_within_px4"] = logs["ulog"]["ratio_wall_to_px4"] <= 1.0
        verdict["ulog_within_px4_script_equivalent"] = logs["ulog"]["ratio_wall_to_px4_script"] <= 1.0
    if "2.16M" in logs:
        big = logs["2.16M"]["twin_calibrate"]
        verdict["tester_2.16M_within_30s_1GB"] = big["wall_s"] <= 30.0 and big["peak_rss_mb"] <= 1000.0
        if "0.54M" in logs:
            verdict["us_per_row_not_growing"] = big["us_per_row"] <= logs["0.54M"]["twin_calibrate"]["us_per_row"]
    result["meets_targets"] = verdict
    write_json(args.json, result)


def keep_previous(path: Path, result: dict) -> None:
    """Carry the figures of the run ``path`` holds into ``result`` (per log ``previous_run``: its
    ``twin calibrate``, and its ``before`` when this run has no baseline of its own), so a re-run
    does not erase what the last one measured."""
    if not path.exists():
        return
    try:
        old = json.loads(path.read_text()).get("logs", {})
    except (ValueError, OSError):
        return
    for label, res in result["logs"].items():
        prev = old.get(label)
        if not prev:
            continue
        res["previous_run"] = {"twin_calibrate": {k: prev["twin_calibrate"].get(k) for k in
                                                  ("wall_s", "cpu_s", "peak_rss_mb", "us_per_row")},
                               "px4_method_wall_s": prev.get("px4_method", {}).get("wall_s"),
                               "before": prev.get("before")}
        if "before" not in res and prev.get("before"):
            res["before"] = prev["before"]


if __name__ == "__main__":
    main()
