"""
The comb, deformed at 50 °C
===========================

The paper's capacitive comb (``scenarios/paper_iis328dq.yaml``'s geometry: proof-mass fingers
between fixed electrodes, anchors in the corners) deformed by thermal expansion at 50 °C,
drawn 2000× exaggerated and coloured by the displacement: a few nanometres, which is what the
sensing gaps feel. ``twin render`` draws it off-screen with pyvista, no display needed;
:func:`twin.reporting.render.render_png` is that command as a function, and the picture is
shown here through matplotlib.
"""

import tempfile
from pathlib import Path

import matplotlib.pyplot as plt

import twin
from twin.model.scenario import load_scenario
from twin.reporting.comb import comb_report
from twin.reporting.render import render_png

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

geometry = load_scenario(ROOT / "scenarios" / "paper_iis328dq.yaml").geometry()
report = comb_report(geometry)
for r in report.readings:
    print(f"reading {r.reading:2s} ({r.meaning}): {round(r.slope_mg_per_c, 4) + 0.0:+.4f} mg/°C")

with tempfile.TemporaryDirectory() as tmp:
    png = render_png(geometry, 50.0, Path(tmp) / "comb_50C.png", exaggeration=2000.0, reading="S")
    image = plt.imread(png)

fig, ax = plt.subplots(figsize=(8, 5.6))
ax.imshow(image)
ax.set_axis_off()
fig.tight_layout()
