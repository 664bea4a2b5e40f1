"""
The error ledger
================

Every ``twin compare`` of the same data appends one line to a ledger beside its report: the
model, its residual RMS and the noise floor. Here the device has two effects the twin lacks —
its die lags the board thermometer by 190 s and it has a thermal hysteresis loop
(``scenarios/hidden_thermal_lag.yaml`` with a hysteresis added). The first compare names both;
adding them one at a time, the ledger shows the error falling step by step to the noise floor.
The plot is the compare report's own (:class:`twin.reporting.evidence_plots.LedgerDisplay`).
"""

import tempfile
from pathlib import Path

import yaml

import twin
from twin.finding.build import compare_measurement
from twin.finding.ledger import append_ledger
from twin.measurement import from_dataset
from twin.model.scenario import load_scenario, parse_scenario
from twin.model.simulate import simulate
from twin.reporting.evidence_plots import LedgerDisplay

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

scenario = load_scenario(ROOT / "scenarios" / "hidden_thermal_lag.yaml")
data = yaml.safe_load(scenario.text)
data["device"]["effects"]["thermal_hysteresis"] = {"k_mg_per_c": 0.3, "half_width_c": 3.0}
data["test_plan"]["logger_rate_hz"] = 2.0
loaded = parse_scenario(yaml.safe_dump(data, sort_keys=False), scenario.path)
m = from_dataset(simulate(loaded))

with tempfile.TemporaryDirectory() as ledger_dir:
    diagnosis, first = compare_measurement(loaded, m, with_effects=[])
    lines, _ = append_ledger(Path(ledger_dir), diagnosis, first)
    added = []
    for effect in first.selected:  # the effects the first compare named, added one at a time
        added.append(effect)
        diagnosis, result = compare_measurement(loaded, m, with_effects=added)
        lines, _ = append_ledger(Path(ledger_dir), diagnosis, result)

for line in lines:
    print(f"{' + '.join(line['model']):60s} RMS {line['rms_residual_g'] * 1e3:.3f} mg, "
          f"floor {line['noise_floor_g'] * 1e3:.3f} mg")

display = LedgerDisplay.from_ledger(lines).plot()
display.ax_.set_title("The error as the named effects are added (ledger)")
display.figure_.set_size_inches(8, 4.2)
display.figure_.tight_layout()
