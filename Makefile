# Two commands do all the set-up on a fresh machine with Python 3.11 and make:
#   make run   - create .venv if missing, install, run the paper scenario into out/
#   make test  - the test suite (what CI runs)
PYTHON ?= python3
VENV   := .venv
PY     := $(VENV)/bin/python
TWIN   := $(VENV)/bin/twin
STAMP  := $(VENV)/.installed
REAL   := ../shared/data/real
TOFU   := $(REAL)/tofupilot_imu_thermal/imu_raw_data.tsv
DOCS_STAMP := $(VENV)/.docs-installed

.PHONY: run test test-long install bench docs clean

$(PY):
	$(PYTHON) -m venv $(VENV)

# torch first, pinned to the CPU wheel this machine has: an unpinned torch pulls GBs of CUDA.
$(STAMP): pyproject.toml | $(PY)
	$(PY) -m pip install --quiet torch==2.13.0
	$(PY) -m pip install --quiet -e '.[test]'
	touch $(STAMP)

install: $(STAMP)

run: $(STAMP)
	mkdir -p out
	$(TWIN) run scenarios/paper_iis328dq.yaml -o out/paper.h5 --json out/paper.json
	$(TWIN) test-design --json out/test_design.json
	$(TWIN) paper --json out/paper_numbers.json
	$(TWIN) comb scenarios/paper_iis328dq.yaml --json out/comb.json
	$(TWIN) render scenarios/paper_iis328dq.yaml --temperature 50 --exaggeration 2000 -o out/comb_50C.png
	$(TWIN) render scenarios/paper_iis328dq.yaml --sweep -20:50:5 --exaggeration 2000 -o out/comb_sweep.gif
	# the loop: a device with a lag the twin lacks -> compare -> every selected effect added -> compare again
	$(TWIN) run scenarios/hidden_thermal_lag.yaml -o out/hidden.h5 -q
	$(TWIN) export out/hidden.h5 -o out/hidden.csv
	rm -rf out/compare
	$(TWIN) compare scenarios/hidden_thermal_lag.yaml out/hidden.csv --report out/compare --json out/compare/base.json
	$(TWIN) compare scenarios/hidden_thermal_lag.yaml out/hidden.csv --report out/compare --json out/compare/after.json \
		$$($(PY) -c "import json; d = json.load(open('out/compare/base.json')); print(' '.join('--with-effect ' + e for e in d['selected'] or [d['candidates'][0]['effect']]))")
	# a real three-axis log to a validated compensation and the file ArduPilot loads (when ../shared is beside us;
	# PX4 needs the vehicle's device id, which a bench log does not record: --device-id)
	if [ -f $(TOFU) ]; then \
		$(TWIN) calibrate $(TOFU) --time-col timestamp --time-unit us --temperature-col imu.temperature \
			--x-col imu.acc.x --y-col imu.acc.y --z-col imu.acc.z --output-unit m/s^2 -o out/tofu_cal.json --report out/tofu_cal && \
		$(TWIN) firmware out/tofu_cal.json --format ardupilot -o out/tofu_tcal.parm; fi
	# the paper's compensation benchmark, short version (make bench runs the full one)
	$(TWIN) benchmark scenarios/paper_iis328dq.yaml --quick --seeds 1 --json out/benchmark_quick.json

test: $(STAMP)
	$(PY) -m pytest -q -m "not long"

# the property-based tests' long profile (20,000 examples each; hours) and the checks marked long: make test runs a fixed budget
test-long: $(STAMP)
	HYPOTHESIS_PROFILE=long $(PY) -m pytest -q tests/test_properties_model.py tests/test_properties_logs.py
	$(PY) -m pytest -q -m long

bench: $(STAMP)
	$(PY) -m pip install --quiet -e '.[test,bench]'
	$(PY) benchmarks/bench_simulate.py --json benchmarks/results/bench_simulate.json
	$(PY) benchmarks/bench_render.py --json benchmarks/results/bench_render.json
	$(PY) benchmarks/bench_effects.py --json benchmarks/results/bench_effects.json
	$(PY) benchmarks/bench_compare.py --json benchmarks/results/bench_compare.json
	$(PY) benchmarks/bench_calibrate.py --json benchmarks/results/bench_calibrate.json
	$(PY) benchmarks/bench_diagnosis.py --seeds 200 --json benchmarks/results/bench_diagnosis.json
	$(PY) benchmarks/bench_fitting.py --json benchmarks/results/bench_fitting.json
	$(PY) benchmarks/bench_fem.py --json benchmarks/results/bench_fem.json
	$(PY) benchmarks/bench_fleet.py --json benchmarks/results/bench_fleet.json
	$(PY) benchmarks/bench_long.py --skip-week --json benchmarks/results/bench_long.json
	$(PY) benchmarks/bench_discovery.py --seeds 50 --workers 2 --json benchmarks/results/bench_discovery.json
	$(PY) benchmarks/bench_one_twin.py --json benchmarks/results/bench_one_twin.json
	$(PY) benchmarks/bench_calibrate_scale.py --runs 3 --json benchmarks/results/bench_calibrate_scale.json
	$(PY) benchmarks/bench_plan.py --seeds 50 --workers 2 --real $(abspath $(REAL)) --json benchmarks/results/bench_plan.json
	$(TWIN) benchmark scenarios/paper_iis328dq.yaml --seeds 3 --json out/benchmark.json --report out/benchmark

# the documentation site into docs/_build/html: warnings are errors; every tutorial and gallery
# example is executed (the tutorials read the real logs from TWIN_REAL_DATA)
$(DOCS_STAMP): pyproject.toml $(STAMP)
	$(PY) -m pip install --quiet -e '.[test,docs]'
	touch $(DOCS_STAMP)

docs: $(DOCS_STAMP)
	rm -rf docs/_build docs/auto_tutorials docs/auto_gallery docs/reference/generated
	TWIN_REAL_DATA=$(abspath $(REAL)) MPLBACKEND=Agg $(PY) -m sphinx -W --keep-going -b html docs docs/_build/html

clean:
	rm -rf out .pytest_cache docs/_build docs/auto_tutorials docs/auto_gallery docs/reference/generated
