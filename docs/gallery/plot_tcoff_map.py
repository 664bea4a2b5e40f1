"""
The package's TCOff map
=======================

What do the mould compound and the die attach do to the offset drift? The finite-element
package model (``sim/fem``, the ``package_fem`` effect of ``scenarios/package_fem.yaml``: the
x cell 300 µm off the die centre) solved for each mould CTE α1 and die-attach modulus, from an
epoxy's 3.9 GPa down to a silicone-like 0.01 GPa. The materials move TCOff by a few tenths of
a mg/°C only; the mould grips the die on five faces, so even a soft attach does not decouple
it — the asymmetry, not the materials, sets the size (``docs/fem.md``). The full 5 × 5 map is
``twin doe scenarios/study_package_tcoff.yaml``.
"""

from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np

import twin
from sim.fem.comb_on_substrate import package_drift, slope_per_c
from sim.fem.package_stack import solve_stack
from twin.effects import get_effect
from twin.model.package import SWEEP_C, package_effect
from twin.model.scenario import load_scenario

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

loaded = load_scenario(ROOT / "scenarios" / "package_fem.yaml")
base, _ = package_effect(loaded)
mould_cte = [7.0, 11.0, 15.0]  # ppm/K
attach_gpa = [0.01, 0.1, 0.5, 1.5, 3.9]

tcoff = np.empty((len(attach_gpa), len(mould_cte)))
for i, modulus in enumerate(attach_gpa):
    for j, cte in enumerate(mould_cte):
        effect = get_effect("package_fem")({"geometry": loaded.geometry()},
                                           **{**base.values, "mould_cte_ppm_per_k": cte, "attach_modulus_gpa": modulus})
        sol = solve_stack(effect.design())  # the default mesh: 100-µm elements, 50 µm under the die
        drift = package_drift(sol, effect.layout(), effect.geometry(), SWEEP_C, "H", effect.values["reference_c"])
        tcoff[i, j] = slope_per_c(SWEEP_C, drift.offset_mg)

fig, ax = plt.subplots(figsize=(6, 4.2))
im = ax.imshow(tcoff, origin="lower", cmap="viridis", aspect="auto")
for (i, j), v in np.ndenumerate(tcoff):
    ax.text(j, i, f"{v:+.2f}", ha="center", va="center", fontsize=9,
            color="white" if v < tcoff.mean() else "black")
ax.set_xticks(range(len(mould_cte)), [f"{v:g}" for v in mould_cte])
ax.set_yticks(range(len(attach_gpa)), [f"{v:g}" for v in attach_gpa])
ax.set_xlabel("mould CTE α1 [ppm/K]")
ax.set_ylabel("die-attach modulus [GPa]")
ax.set_title(f"TCOff [mg/°C], cell {base.values['cell_offset_um']:g} µm off-centre (datasheet ±0.8 typ)", fontsize=10)
fig.colorbar(im, ax=ax, label="mg/°C")
fig.tight_layout()
print(f"TCOff {tcoff.min():+.2f} … {tcoff.max():+.2f} mg/°C over {tcoff.size} designs")
