"""
Compare the twin with a measurement, find the missing physics, add it
=====================================================================

A twin is only as good as the physics it holds. ``twin compare`` closes the loop: it calibrates
the twin to a measurement, shows where the calibrated twin still fails, screens every effect of
the library that the twin lacks, and names the one the data ask for. Add it, compare again, and
the error falls — down to the noise floor when nothing else is missing.

We run the loop twice:

1. on a simulated device whose die lags the thermometer (``scenarios/hidden_thermal_lag.yaml``:
   the device has the lag, the twin does not), where the truth is known;
2. on a real log, the TofuPilot IMU thermal cycle (51.6 → −17.6 → 74.0 → 36.3 °C in 71 min),
   where it is not.

The comparison is *blind*: it reads only what a laboratory logs (time, temperature, output and
the orientation), never the simulation's truth.
"""

# %%
# Find the project and the real data
# ----------------------------------
# The real log is not part of the repository. Its folder is named by the environment variable
# ``TWIN_REAL_DATA`` (the documentation build sets it), and the file we read is
# ``$TWIN_REAL_DATA/tofupilot_imu_thermal/imu_raw_data.tsv``.

import os
import textwrap
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

DATA = os.environ.get("TWIN_REAL_DATA")
REAL = Path(DATA) / "tofupilot_imu_thermal" / "imu_raw_data.tsv" if DATA else None
if REAL is None or not REAL.is_file():
    raise RuntimeError("this tutorial reads the TofuPilot IMU log: set the environment variable TWIN_REAL_DATA to the "
                       "folder that holds tofupilot_imu_thermal/imu_raw_data.tsv "
                       + (f"(it is {DATA!r}, and {REAL} is missing)" if DATA else "(it is not set)"))


def say(text: str) -> None:
    """Print a long sentence of the finding wrapped to 100 columns."""
    print(textwrap.fill(text, 100))


# %%
# A device with a lag the twin lacks
# ----------------------------------
# The thermometer sits on the board; the die follows the board with a time constant of 190 s.
# The program heats at 60 °C/h and cools at 30 °C/h with one-hour dwells, so a lag — which scales
# with the ramp rate and settles in a dwell — can be told from the look-alikes. The twin holds
# only the bias and scale-factor tempcos.

from twin.measurement import from_dataset
from twin.model.scenario import load_scenario
from twin.model.simulate import simulate

loaded = load_scenario(ROOT / "scenarios" / "hidden_thermal_lag.yaml")
print("device effects:", list(loaded.scenario.device.effects), "| die τ:", loaded.scenario.chamber.lumped.die_tau_s, "s")
print("twin effects:  ", loaded.scenario.twin.effects)

ds = simulate(loaded, seed=3)
m = from_dataset(ds)  # the logged columns only: what a laboratory would have
print(f"measurement: {m.time_s.size} samples, {m.temperature_c.min():.1f}…{m.temperature_c.max():.1f} °C")

# %%
# Compare
# -------
# :func:`~twin.finding.build.compare_measurement` returns the diagnosis (what the plots read)
# and the typed :class:`~twin.finding.result.CompareResult` (what ``twin compare --json``
# writes). The finding is a few plain sentences: the signature in the residual, the effect
# named, how sure, and what this test plan cannot separate.

from twin.finding.build import compare_measurement

diagnosis, base = compare_measurement(loaded, m, with_effects=[])
say(base.finding)

# %%
# Every effect of the library that the twin lacks was screened on top of the calibrated twin.
# A candidate is *significant* when its Bonferroni-corrected p-value is below 0.01, its ΔBIC
# above 10 and its held-out gain above 5 %.

print(f"{'candidate':20s} {'family':14s} {'signif.':8s} {'ΔBIC':>8s} {'held-out gain':>14s} {'RMS after':>10s}")
for c in base.candidates:
    print(f"{c.effect:20s} {c.family:14s} {'yes' if c.significant else 'no':8s} {c.delta_bic:8.1f} "
          f"{100 * c.heldout_gain:13.1f}% {c.rms_residual_g * 1e3:8.3f} mg")
named = base.selected[0]
refined = base.candidate(named).parameters_refined or base.candidate(named).parameters
print(f"named: {named} ({base.confidence}); screening estimate τ ≈ {refined['tau_s']:.0f} s; the truth: die τ = "
      f"{loaded.scenario.chamber.lumped.die_tau_s:g} s")

# %%
# Add the named effect and compare again
# --------------------------------------
# The twin with ``thermal_lag`` is calibrated again; the lag's time constant now gets a
# profile-likelihood interval. Nothing further is significant: the residual is at the noise floor.

diagnosis_after, after = compare_measurement(loaded, m, with_effects=[named])
say(after.finding)
tau = after.parameters[named]["tau_s"]
print(f"{named}.tau_s = {tau.value:.0f} s, 95 % interval [{tau.ci95[0]:.0f}, {tau.ci95[1]:.0f}] s")

# %%
# The hysteresis view shows why: before, the residual against temperature is a loop (heating
# below, cooling above: the die is colder than the thermometer on the way up); with the lag
# in the twin the loop is gone. These are the displays of the compare report
# (:mod:`twin.reporting.diagnosis_plots`), drawn onto our own axes.

import matplotlib.pyplot as plt

from twin.reporting.diagnosis_plots import HysteresisDisplay

fig, axes = plt.subplots(1, 2, figsize=(11, 4), sharey=True)
HysteresisDisplay.from_diagnosis(diagnosis).plot(ax=axes[0])
HysteresisDisplay.from_diagnosis(diagnosis_after).plot(ax=axes[1])
axes[0].set_xlabel("temperature [°C]\n(twin: bias and scale-factor tempcos)")
axes[1].set_xlabel(f"temperature [°C]\n(twin + {named})")
fig.tight_layout()

# %%
# The error falling to the noise floor
# ------------------------------------
# The noise floor is estimated from the data (the differences of consecutive samples), so it
# needs no truth. Here we also have the truth: the RMS of the sensor noise alone.

import numpy as np

noise = ds["truth/noise_white_g"] + ds["truth/noise_bias_instability_g"] + ds["truth/quantisation_g"]
true_floor_mg = float(np.sqrt(np.mean(noise**2))) * 1e3
labels = ["twin", f"twin + {named}", "noise floor\n(from the data)", "noise RMS\n(truth)"]
values = [base.rms_residual_g * 1e3, after.rms_residual_g * 1e3, after.noise_floor_g * 1e3, true_floor_mg]
for label, v in zip(labels, values):
    print(f"{label.replace(chr(10), ' '):32s} {v:.3f} mg")

fig, ax = plt.subplots(figsize=(6.5, 3.6))
bars = ax.bar(labels, values, color=["C3", "C2", "0.6", "0.8"])
ax.bar_label(bars, fmt="%.3f")
ax.margins(y=0.15)
ax.set_ylabel("residual RMS [mg]")
ax.set_title("hidden_thermal_lag: the error after each compare")
fig.tight_layout()

# %%
# A real log: the TofuPilot IMU thermal cycle
# -------------------------------------------
# One IMU, still, z axis down (it reads −1 g), logged at about 2 Hz with the IMU's own
# temperature. The command line would be::
#
#     twin compare scenarios/paper_iis328dq.yaml imu_raw_data.tsv --time-col timestamp --time-unit us \
#         --temperature-col imu.temperature --output-col imu.acc.z --output-unit m/s^2 --applied-g -1
#
# From Python the command is :func:`~twin.workflows.compare.run_compare` of one validated
# options object; the column options are a :class:`~twin.measurement.ColumnMap`. With a
# ``ledger_dir`` every compare appends its errors to ``ledger.jsonl`` there, and the result
# carries the ledger: the error model after model.

import tempfile

from twin.measurement import ColumnMap
from twin.workflows.compare import CompareOptions, run_compare

columns = ColumnMap(time="timestamp", time_unit="us", temperature="imu.temperature", output="imu.acc.z",
                    output_unit="m/s^2")
paper = ROOT / "scenarios" / "paper_iis328dq.yaml"

with tempfile.TemporaryDirectory() as tmp:
    options = {"scenario": paper, "measurements": [REAL], "columns": columns, "applied_g": -1.0,
               "ledger_dir": Path(tmp)}
    real = run_compare(CompareOptions(**options))
    say(real.finding)
    real_named = real.selected[0] if real.selected else "stress_relaxation"
    real_after = run_compare(CompareOptions(**options, with_effects=[real_named]))

print()
say(real_after.finding)

# %%
# The ledger of the two compares on the same data, with the noise floor estimated from the log.
# On real data the library explains most of the error but not all of it: what is left is not
# white noise (the finding says where its structure is, and suggests ``--discover``).

print(f"{'model':55s} {'RMS':>8s} {'held-out':>9s} {'floor':>7s}  ΔBIC")
for e in real_after.ledger:
    dbic = "-" if e.delta_bic is None else f"{e.delta_bic:.0f}"
    print(f"{' + '.join(e.model):55s} {e.rms_residual_g * 1e3:6.2f} mg {e.heldout_rms_g * 1e3:6.2f} mg "
          f"{e.noise_floor_g * 1e3:5.2f} mg  {dbic}")

fig, ax = plt.subplots(figsize=(6.5, 3.6))
labels = ["twin", f"twin + {real_named}", "noise floor\n(from the data)"]
values = [real_after.ledger[0].rms_residual_g * 1e3, real_after.ledger[-1].rms_residual_g * 1e3,
          real_after.noise_floor_g * 1e3]
bars = ax.bar(labels, values, color=["C3", "C2", "0.6"])
ax.bar_label(bars, fmt="%.2f")
ax.margins(y=0.15)
ax.set_ylabel("residual RMS [mg]")
ax.set_title("TofuPilot IMU, z axis: the error after each compare")
fig.tight_layout()

# %%
# What the finding does not claim
# -------------------------------
# One thermal cycle at one ramp rate cannot tell every mechanism apart: the result lists the
# rivals it could not exclude and the test that would separate them.

print("confidence:", real.confidence, "| rivals:", ", ".join(real.rivals) or "none")
for a in real.aliases[:3]:
    say(f"- {', '.join(a.effects)}: {a.remedy}")
