"""
Drift against temperature
=========================

The paper's three chamber cycles (−20 → 50 °C, ``scenarios/paper_iis328dq.yaml``) simulated and
drawn as the output minus 1 g against the logged temperature, in 10-s means coloured by the
ramp rate. The black line is the drift the device truly had; the heating and cooling branches
sit a little either side of it (the inset) because the die lags the board thermometer.
"""

from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np

import twin
from twin.model.scenario import load_scenario
from twin.model.simulate import simulate

try:
    HERE = Path(__file__).resolve().parent
except NameError:  # sphinx-gallery runs the script from its own folder, without __file__
    HERE = Path.cwd().resolve()
# docs/gallery/../.. is the repository; a copy of this script elsewhere finds the installed project
ROOT = next((p for p in (HERE.parent.parent, Path(twin.__file__).resolve().parent.parent)
             if (p / "scenarios").is_dir()), None)
if ROOT is None:
    raise RuntimeError("no scenarios/ folder found: run this script from docs/gallery of the project, "
                       "or install the project (pip install -e .)")

loaded = load_scenario(ROOT / "scenarios" / "paper_iis328dq.yaml")
ds = simulate(loaded, seed=20221)

per = int(10 * loaded.scenario.test_plan.logger_rate_hz)  # samples in 10 s
n = len(ds) // per * per


def means(x):
    return np.asarray(x)[:n].reshape(-1, per).mean(axis=1)


t_s = means(ds["time_s"])
temp = means(ds["temperature/thermometer_c"])
out_mg = means(ds["output/output_g"] - ds["test/applied_g"]) * 1e3
rate = np.gradient(temp, t_s) * 60  # °C/min
die = ds["temperature/die_c"]
order = np.argsort(die)
die_sorted, drift_sorted = die[order][::50], ds["truth/drift_g"][order][::50] * 1e3  # the drift is static in the die's T

fig, ax = plt.subplots(figsize=(7.5, 4.8))
sc = ax.scatter(temp, out_mg, c=rate, cmap="coolwarm", vmin=-1, vmax=1, s=4)
ax.plot(die_sorted, drift_sorted, color="k", lw=1, label="true drift (at the die's temperature)")
fig.colorbar(sc, ax=ax, label="ramp rate [°C/min] (red: heating)")
ax.set_xlabel("logged temperature [°C]")
ax.set_ylabel("output − 1 g [mg], 10-s means")
ax.set_title(f"IIS328DQ, {loaded.scenario.program.cycles} chamber cycles: drift against temperature")
ax.legend(loc="upper left")

# zoom on a few degrees: heating below, cooling above the true drift
zoom = ax.inset_axes([0.56, 0.07, 0.41, 0.43])
sel = (temp > 20) & (temp < 23)
zoom.scatter(temp[sel], out_mg[sel], c=rate[sel], cmap="coolwarm", vmin=-1, vmax=1, s=5)
band = (die_sorted > 20) & (die_sorted < 23)
zoom.plot(die_sorted[band], drift_sorted[band], color="k", lw=1)
zoom.tick_params(labelsize=7)
ax.indicate_inset_zoom(zoom, edgecolor="0.4")
fig.tight_layout()
print(f"drift {out_mg.min():+.1f} … {out_mg.max():+.1f} mg over {temp.min():.1f} … {temp.max():.1f} °C")
