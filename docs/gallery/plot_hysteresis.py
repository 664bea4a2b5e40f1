"""
The heating/cooling loop
========================

A device with a rate-independent thermal hysteresis (``scenarios/hidden_hysteresis.yaml``: a
play operator of half-width 3 °C) compared blind with a twin that lacks it. The compare
report's hysteresis view plots the residual's 10-s means against temperature, heating and
cooling apart: a loop whose area is the same at both ramp rates (left). With the named effect
added to the twin the loop closes (right).
"""

from pathlib import Path

import matplotlib.pyplot as plt
import yaml

import twin
from twin.finding.build import compare_measurement
from twin.measurement import from_dataset
from twin.model.scenario import load_scenario, parse_scenario
from twin.model.simulate import simulate
from twin.reporting.diagnosis_plots import HysteresisDisplay

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

scenario = load_scenario(ROOT / "scenarios" / "hidden_hysteresis.yaml")
data = yaml.safe_load(scenario.text)
data["test_plan"]["logger_rate_hz"] = 2.0  # 2 Hz draws the same loop, five times faster
loaded = parse_scenario(yaml.safe_dump(data, sort_keys=False), scenario.path)
m = from_dataset(simulate(loaded))

before, result = compare_measurement(loaded, m, with_effects=[])
named = list(result.selected)
after, result_after = compare_measurement(loaded, m, with_effects=named)
print(f"named: {', '.join(named)} ({result.confidence}); RMS {result.rms_residual_g * 1e3:.2f} → "
      f"{result_after.rms_residual_g * 1e3:.2f} mg, noise floor {result_after.noise_floor_g * 1e3:.2f} mg")

fig, axes = plt.subplots(1, 2, figsize=(10.5, 4.2), sharey=True)
HysteresisDisplay.from_diagnosis(before).plot(ax=axes[0])
HysteresisDisplay.from_diagnosis(after).plot(ax=axes[1])
axes[0].set_xlabel("temperature [°C] — twin: bias and scale-factor tempcos")
axes[1].set_xlabel(f"temperature [°C] — twin + {' + '.join(named)}")
fig.tight_layout()
