"""
Studies and fleets on a Dask cluster
====================================

Two ways to run the twin many times:

* a **design-of-experiment study** (``twin doe``, ``docs/doe.md``) sweeps parameters of a base
  scenario, simulates each design point and computes responses — here, *how large must a
  die–thermometer lag be, and how fast the ramp, before the diagnosis names the lag?*
* a **fleet** (``twin fleet``, ``docs/fleet.md``) runs one analysis over many units' logs and
  looks at the population: how often each effect is named, how the fitted parameters spread,
  which units are outliers. Here the fleet is simulated, so its truth is known.

Both are resumable (every finished run or unit is appended durably to a ledger) and both run
on a local process pool or on a Dask cluster. We start a small local cluster — two workers, one
thread each, as threads of this process so it starts in a second — and hand its address to
both.
"""

# %%
# A local Dask cluster
# --------------------
# ``executor="dask"`` with a ``scheduler`` address attaches to a running cluster (on a real one
# the address comes from ``dask scheduler``, dask-jobqueue or the Kubernetes operator). Without
# an address the workflows start their own ``LocalCluster`` of worker processes.

import tempfile
from pathlib import Path

from dask.distributed import LocalCluster

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

cluster = LocalCluster(n_workers=2, threads_per_worker=1, processes=False, dashboard_address=None)
print(f"{len(cluster.workers)} workers; scheduler at {cluster.scheduler_address.split('://')[0]}://… (in this process)")
work_dir = tempfile.TemporaryDirectory(prefix="twin_study_fleet_")  # removed at the end, or at exit
work = Path(work_dir.name)

# %%
# A study: lag size × ramp rate
# -----------------------------
# The base is ``scenarios/hidden_thermal_lag.yaml`` (the die lags the board thermometer; the twin
# has no lag). Two factors — the die's time constant and the heating ramp rate — on a full
# factorial, each run at 1 Hz. The responses are computed per run: ``hidden_detected`` (the
# diagnosis detects a missing effect), ``hidden_rank`` (rank of the lag's family in the
# ranking; 1 = first), ``residual_rms_mg`` and ``chamber_hours``. A study file is YAML; its
# ``base`` is relative to the study file, or absolute as here.

STUDY = f"""
name: lag_detection
description: die time constant x heating rate -> is the lag named?
base: {ROOT / "scenarios" / "hidden_thermal_lag.yaml"}
seed: 3
logger_rate_hz: 1.0
factors:
  chamber.lumped.die_tau_s: {{levels: [5, 15, 45, 190]}}
  program.steps.1.ramp_c_per_h: {{levels: [30, 120]}}
design: {{type: full_factorial}}
responses: [hidden_detected, hidden_rank, residual_rms_mg, chamber_hours]
max_runs: 20
"""
study_file = work / "lag_detection.yaml"
study_file.write_text(STUDY)

from twin.workflows.study import StudyOptions, run_study

study = run_study(StudyOptions(study=study_file, output=work / "study", executor="dask",
                               scheduler=cluster.scheduler_address))
print(f"{study.runs} of {study.planned} runs finished, {study.failed} failed")
for factor, responses in study.main_effects.items():
    means = responses["hidden_detected"].means
    print(f"main effect of {factor} on hidden_detected: " + ", ".join(f"{k}: {v:.2f}" for k, v in means.items()))

# %%
# The table, one row per run (``table.csv`` in the output folder; ``table.h5`` too).

import csv

with open(work / "study" / "table.csv", newline="") as f:
    rows = [r for r in csv.DictReader(f) if r["status"] == "ok"]
print(f"{'die τ [s]':>9s} {'ramp [°C/h]':>11s} {'detected':>8s} {'rank':>5s} {'residual [mg]':>13s} {'hours':>6s}")
for r in sorted(rows, key=lambda r: (float(r["program.steps.1.ramp_c_per_h"]), float(r["chamber.lumped.die_tau_s"]))):
    print(f"{float(r['chamber.lumped.die_tau_s']):9.0f} {float(r['program.steps.1.ramp_c_per_h']):11.0f} "
          f"{float(r['hidden_detected']):8.0f} {float(r['hidden_rank']):5.0f} {float(r['residual_rms_mg']):13.3f} "
          f"{float(r['chamber_hours']):6.2f}")

# %%
# One response against the two factors: the residual the twin without a lag leaves grows with
# the lag and with the ramp rate (the die falls behind by τ × dT/dt); filled markers where the
# diagnosis detected a missing effect and ranked the lag first.

import matplotlib.pyplot as plt

fig, ax = plt.subplots(figsize=(6.5, 4))
for k, rate in enumerate(sorted({float(r["program.steps.1.ramp_c_per_h"]) for r in rows})):
    sel = sorted((r for r in rows if float(r["program.steps.1.ramp_c_per_h"]) == rate),
                 key=lambda r: float(r["chamber.lumped.die_tau_s"]))
    tau = [float(r["chamber.lumped.die_tau_s"]) for r in sel]
    rms = [float(r["residual_rms_mg"]) for r in sel]
    named = [float(r["hidden_detected"]) == 1 and float(r["hidden_rank"]) == 1 for r in sel]
    ax.plot(tau, rms, "-", color=f"C{k}", label=f"heating at {rate:g} °C/h")
    ax.scatter(tau, rms, s=50, color=[f"C{k}" if n else "white" for n in named], edgecolors=f"C{k}", zorder=3)
ax.set_xscale("log")
ax.set_xlabel("die time constant behind the thermometer [s]")
ax.set_ylabel("residual RMS of the twin [mg]")
ax.set_title("Study: residual without a lag (filled: lag detected, ranked first)", fontsize=10)
ax.legend(fontsize=8)
fig.tight_layout()

# %%
# A simulated fleet
# -----------------
# ``twin fleet-simulate`` draws units from a fleet scenario: every unit through the 6-h
# production test of ``scenarios/fleet_base.yaml``, each with its own bias tempco, a share of
# them with a die that lags the thermometer, another share with a hysteresis loop. It writes
# each unit's log (canonical CSV), keeps the truth apart in ``truth.json``, and writes the fleet
# spec that analyses the logs blind.

FLEET = f"""
name: small_line
base: {ROOT / "scenarios" / "fleet_base.yaml"}
units: 8
seed: 2026
id_prefix: unit
draw: exclusive
logger_rate_hz: 1.0
vary:
  device.effects.static_bias_tc.tc1_mg_per_c: {{normal: [0.5, 0.15]}}
effects:
  thermal_lag:
    prevalence: 0.4
    set: {{chamber.thermometer.attached_to: board}}
    draw: {{chamber.lumped.die_tau_s: {{uniform: [120.0, 400.0]}}}}
  thermal_hysteresis:
    prevalence: 0.25
    draw:
      device.effects.thermal_hysteresis.k_mg_per_c: {{uniform: [0.2, 0.4]}}
      device.effects.thermal_hysteresis.half_width_c: {{uniform: [1.5, 5.0]}}
"""
fleet_file = work / "small_line.yaml"
fleet_file.write_text(FLEET)

from twin.workflows.fleet import (
    FleetOptions,
    SimulateFleetOptions,
    run_fleet,
    run_fleet_simulation,
)

simulated = run_fleet_simulation(SimulateFleetOptions(fleet_scenario=fleet_file, output=work / "sim"))
print(f"{simulated.written} unit logs written; true prevalence: "
      + ", ".join(f"{k} {100 * v:.0f} %" for k, v in simulated.prevalence.items()))

# %%
# Analyse every unit blind, on the cluster. The population view comes back typed: prevalence of
# each named effect with its Wilson 95 % interval, the spread of each fitted parameter, outliers.

fleet = run_fleet(FleetOptions(spec=simulated.spec, output=work / "fleet", executor="dask",
                               scheduler=cluster.scheduler_address))
print(f"{fleet.ok} units analysed, {fleet.errors} failed")
for name, p in fleet.prevalence.items():
    print(f"named {name:20s} in {100 * p.share:5.1f} % of units (95 % CI {100 * p.ci95[0]:.0f}–{100 * p.ci95[1]:.0f} %)")
print(f"nothing named in {100 * (fleet.none_named.share or 0):.0f} % of units")

# %%
# Against the truth, which the analysis never read:

import json

from twin.fleet.ledger import read_ledger
from twin.fleet.simulate import score_against_truth

truth = json.loads(Path(simulated.truth).read_text())
for name, s in score_against_truth(fleet, truth).items():
    print(f"{name:20s} true {s['true_percent']:5.1f} %, named {s['estimated_percent']:5.1f} % "
          f"(its family: {s['estimated_family_percent']:5.1f} %)")

# %%
# The population, unit by unit: the residual of the twin over the noise floor (1 = nothing left
# but noise), coloured by what the blind analysis named, and the true hidden effect beside it.

records = read_ledger(work / "fleet" / "units.jsonl")
true_effects = {t["unit"]: (t["effects"] or ["none"])[0] for t in truth["units"]}
ids = sorted(records)
ratio = [records[u].residual_over_floor for u in ids]
named = [(records[u].named or ("none",))[0] for u in ids]
colors = {"none": "0.6", "thermal_lag": "C0", "thermal_hysteresis": "C3"}

fig, ax = plt.subplots(figsize=(8, 3.8))
ax.bar(ids, ratio, color=[colors.get(n, "C2") for n in named])
for i, u in enumerate(ids):
    ax.text(i, ratio[i], f"truth:\n{true_effects[u]}", ha="center", va="bottom", fontsize=7)
for n, c in colors.items():
    ax.bar([ids[0]], [0], color=c, label=f"named: {n}")
ax.axhline(1.0, color="k", ls=":")
ax.set_ylabel("residual RMS / noise floor")
ax.set_ylim(0, max(ratio) * 1.3)
ax.tick_params(axis="x", rotation=30)
ax.set_title("Fleet: each unit compared blind with the twin", fontsize=10)
ax.legend(fontsize=7, loc="upper right")
fig.tight_layout()

# %%
# Close the cluster and remove the outputs.

cluster.close()
work_dir.cleanup()
print("cluster closed, outputs removed")
