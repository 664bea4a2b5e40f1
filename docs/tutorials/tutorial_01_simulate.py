"""
Simulate a thermal-chamber test
===============================

This tutorial runs the source paper's experiment (Qi et al. 2022) on the twin: an ST IIS328DQ
accelerometer on the base of a thermal chamber, sensing axis along gravity, three cycles of
−20 °C → 50 °C → −20 °C. We

1. load the scenario ``scenarios/paper_iis328dq.yaml``,
2. simulate it into a :class:`~twin.model.dataset.Dataset` (every logged column *and* the truth
   behind it),
3. write the self-describing HDF5 file that ``twin run`` writes, and read it back,
4. look at the temperatures along the thermal chain and at the output against time and against
   temperature.

The same thing from the command line is ``twin run scenarios/paper_iis328dq.yaml -o paper.h5``.
"""

# %%
# Find the project
# ----------------
# The scenarios live in ``scenarios/`` at the root of the repository. When sphinx-gallery builds
# the documentation it runs this script from its own folder (``docs/tutorials``), without
# ``__file__``; run by hand, ``__file__`` is defined. Both lead to the same root. A copy of the
# script elsewhere falls back on where the project is installed (``pip install -e .``).

from pathlib import Path

import twin

try:
    HERE = Path(__file__).resolve().parent
except NameError:  # sphinx-gallery runs the script from its own folder, without __file__
    HERE = Path.cwd().resolve()
# docs/tutorials/../.. is the repository; a copy of this script elsewhere finds the installed project
ROOT = next((p for p in (HERE.parent.parent, Path(twin.__file__).resolve().parent.parent)
             if (p / "scenarios").is_dir()), None)
if ROOT is None:
    raise RuntimeError("no scenarios/ folder found: run this script from docs/tutorials of the project, "
                       "or install the project (pip install -e .)")

SCENARIO = ROOT / "scenarios" / "paper_iis328dq.yaml"

# %%
# Load and simulate
# -----------------
# :func:`~twin.model.scenario.load_scenario` validates every key (a typo is refused with its
# file, line and the closest valid key) and compiles the chamber program.
# :func:`~twin.model.simulate.simulate` runs program → thermal chain → the device's drift
# effects → the sensor (noise, bias instability, 12-bit quantisation). The seed makes it
# reproducible: the same seed gives identical arrays.

import numpy as np

from twin.model.scenario import load_scenario
from twin.model.simulate import simulate, summary

loaded = load_scenario(SCENARIO)
scn = loaded.scenario
print(f"{scn.name}: {scn.description}")
print(f"program: {loaded.program.duration_s / 3600:.2f} h per run, logged at {scn.test_plan.logger_rate_hz:g} Hz")
print(f"device effects: {list(scn.device.effects)}; thermometer on the {scn.chamber.thermometer.attached_to}")

ds = simulate(loaded, seed=20221)
s = summary(ds)
print(f"{s.samples} samples over {s.duration_h:.1f} h; set-point {s.setpoint_range_c[0]:.0f}…{s.setpoint_range_c[1]:.0f} °C")
print(f"true drift {s.drift_range_mg[0]:+.1f} … {s.drift_range_mg[1]:+.1f} mg; white noise σ {s.white_noise_sigma_mg:.2f} mg")
print(f"largest |die − thermometer|: {s.die_minus_thermometer_max_abs_c:.3f} °C")

# %%
# Write the HDF5 dataset and read it back
# ---------------------------------------
# :func:`~twin.model.dataset.write_hdf5` writes atomically (built in memory, then renamed into
# place). Every array carries its unit and a description; the file attributes keep the
# scenario text, the seed and the software version, so a dataset explains itself.

import tempfile

from twin.model.dataset import read_hdf5, write_hdf5

with tempfile.TemporaryDirectory() as tmp:
    path = write_hdf5(ds, Path(tmp) / "paper.h5")
    print(f"wrote {path.name}: {path.stat().st_size / 1e6:.1f} MB")
    back = read_hdf5(path)

print(f"read back {len(back)} samples, seed {back.attrs['seed']}, twin {back.attrs['twin_version']}")
for name in ("temperature/thermometer_c", "temperature/die_c", "output/output_g", "truth/drift_g"):
    print(f"  {name:28s} [{back.units[name]:4s}] {back.descriptions[name]}")
assert np.array_equal(back["output/output_g"], ds["output/output_g"])

# %%
# The temperatures along the thermal chain
# ----------------------------------------
# The chamber air follows the set-point through its controller, the board follows the air, the
# die follows the board. The reference thermometer is taped to the board, so on the ramps the
# die — whose temperature no real IIS328DQ reports — lags what is logged.

import matplotlib.pyplot as plt

t_h = back["time_s"] / 3600
step = 20  # 583k samples: every 20th draws the same picture
temperatures = {
    "set-point": "program/setpoint_c",
    "air": "temperature/air_c",
    "board": "temperature/board_c",
    "die (truth)": "temperature/die_c",
    "thermometer (logged)": "temperature/thermometer_c",
}

fig, (ax, zoom) = plt.subplots(1, 2, figsize=(11, 3.8), gridspec_kw={"width_ratios": [2, 1]})
for label, key in temperatures.items():
    ax.plot(t_h[::step], back[key][::step], lw=1, label=label)
ax.set_xlabel("time [h]")
ax.set_ylabel("temperature [°C]")
ax.set_title("Three cycles of the paper's program")
ax.legend(fontsize=8, loc="lower right")

# zoom on the first minutes of the first heating ramp
ramp = (back["program/segment"] == 1) & (back["test/run_index"] == 0)
first = np.flatnonzero(ramp)[0]
window = slice(first, first + int(15 * 60 * scn.test_plan.logger_rate_hz))
for label, key in temperatures.items():
    zoom.plot(back["time_s"][window] / 60, back[key][window], lw=1, label=label)
zoom.set_xlabel("time [min]")
zoom.set_title("First ramp: 0.4 °C every 35 s")
fig.tight_layout()

lag = back["temperature/die_c"][ramp] - back["temperature/thermometer_true_c"][ramp]
print(f"on the heating ramps the die runs {np.median(lag):+.3f} °C from the thermometer element (median)")

# %%
# The output against time
# -----------------------
# The output is 1 g (the sensing axis points along gravity) plus the drift, plus noise and
# quantisation. The truth is stored beside it: ``truth/drift_g`` is the drift the device really
# had, so any compensation can be scored against it.

out_mg = (back["output/output_g"] - back["test/applied_g"]) * 1e3
drift_mg = back["truth/drift_g"] * 1e3

fig, ax = plt.subplots(figsize=(10, 3.6))
ax.plot(t_h[::step], out_mg[::step], ",", color="0.6", label="output − 1 g (logged)")
ax.plot(t_h[::step], drift_mg[::step], color="C3", lw=1.2, label="true drift")
ax.set_xlabel("time [h]")
ax.set_ylabel("[mg]")
ax2 = ax.twinx()
ax2.plot(t_h[::step], back["temperature/thermometer_c"][::step], color="C1", lw=0.8)
ax2.set_ylabel("thermometer [°C]", color="C1")
ax.legend(loc="upper left", fontsize=8)
ax.set_title("Output and true drift over the test")
fig.tight_layout()

# %%
# The output against temperature
# ------------------------------
# Plotted against the logged temperature, the drift is nearly a static curve: a linear TCOff of
# 0.8 mg/°C with a small quadratic term, plus the scale-factor tempco of 100 ppm/°C acting on
# the 1 g input. Subtract the best quadratic in temperature and average over one minute (right):
# the heating and cooling branches sit apart, because the die lags the thermometer. That part
# of the drift is the one no static map of temperature can compensate.

thermo = back["temperature/thermometer_c"]
seg = back["program/segment"]
coef = np.polyfit(thermo - 25.0, out_mg, 2)  # about 25 °C, the effects' reference temperature
sb, sf = scn.device.effects["static_bias_tc"], scn.device.effects["scale_factor_tc"]
expected = sb["tc1_mg_per_c"] + sf["tc1_ppm_per_c"] * 1e-6 * 1e3  # TCOff + TCSo × 1 g, in mg/°C
print(f"quadratic fit about 25 °C: slope {coef[1]:+.3f} mg/°C (device: TCOff + TCSo·1 g = {expected:+.3f}), "
      f"curvature {coef[0] * 1e3:+.2f} µg/°C² (device: {sb['tc2_mg_per_c2'] * 1e3:+.2f})")

per_min = int(60 * scn.test_plan.logger_rate_hz)
n = len(back) // per_min * per_min


def minute_means(x):
    return x[:n].reshape(-1, per_min).mean(axis=1)


residual = out_mg - np.polyval(coef, thermo - 25.0)
t_min, r_min = minute_means(thermo), minute_means(residual)
seg_min = seg[:n].reshape(-1, per_min)[:, per_min // 2]

fig, (ax, right) = plt.subplots(1, 2, figsize=(11, 4))
for kind, label, color in ((1, "heating", "C3"), (-1, "cooling", "C0"), (0, "dwell", "0.5")):
    sel = np.flatnonzero(seg == kind)[::step]
    ax.plot(thermo[sel], out_mg[sel], ".", ms=1, color=color, alpha=0.4, label=label)
    right.plot(t_min[seg_min == kind], r_min[seg_min == kind], ".", ms=4, color=color, label=label)
ax.plot(thermo[::step], drift_mg[::step], ",", color="k", label="true drift")
ax.set_xlabel("thermometer [°C]")
ax.set_ylabel("output − 1 g [mg]")
ax.set_title("Drift against the logged temperature")
ax.legend(fontsize=8, markerscale=8)
right.axhline(0, color="k", lw=0.5)
right.set_xlabel("thermometer [°C]")
right.set_ylabel("1-min mean [mg]")
right.set_title("After the best quadratic in temperature")
right.legend(fontsize=8)
fig.tight_layout()
for kind, label in ((1, "heating"), (-1, "cooling")):
    print(f"{label}: mean residual {r_min[seg_min == kind].mean():+.3f} mg")

# %%
# Where next
# ----------
# * :doc:`tutorial_02_compare` compares this kind of data with the twin and names what the twin
#   is missing.
# * ``docs/dataset.md`` lists every array of the file; ``docs/scenario.md`` every scenario key.
