"""Writes the adversarial corpus of this folder (the files are kept; rerun after editing a case).

Each file's header names the command and the contract checked by tests/test_hardening_model.py.
"""
import copy
from pathlib import Path

import yaml

D = Path(__file__).resolve().parent
BASE = {
  "name": "tiny", "seed": 7,
  "program": {"start_c": -20.0, "cycles": 1, "steps": [
      {"type": "hold", "dwell_s": 600}, {"type": "ramp", "target_c": 30.0, "ramp_c_per_h": 600},
      {"type": "hold", "dwell_s": 600}]},
  "chamber": {"model": "lumped", "air_tau_s": 60.0, "thermometer": {"attached_to": "board", "tau_s": 2.0}},
  "device": {"sensor": {"part": "IIS328DQ", "full_scale_g": 2, "odr_hz": 50},
             "effects": {"static_bias_tc": {"tc1_mg_per_c": 0.8}, "scale_factor_tc": {"tc1_ppm_per_c": 100.0}}},
  "test_plan": {"logger_rate_hz": 0.1, "orientations": [{"at_s": 0, "applied_g": 1.0}]},
}
def put(d, path, v):
    ks = path.split("."); node = d
    for k in ks[:-1]:
        node = node[int(k)] if isinstance(node, list) else node.setdefault(k, {})
    if v is None: node.pop(ks[-1], None)
    elif isinstance(node, list): node[int(ks[-1])] = v
    else: node[ks[-1]] = v
def write(name, data, cmd, expect, why, raw=None):
    head = f"# {why}\n# cmd: {cmd}\n# expect: {expect}\n"
    body = raw if raw is not None else yaml.safe_dump(data, sort_keys=False)
    (D / name).write_text(head + body)
def scen(name, changes, expect, why, cmd="run FILE -o OUT.h5 -q"):
    d = copy.deepcopy(BASE)
    for k, v in changes.items(): put(d, k, v)
    write(name, d, cmd, expect, why)
inf, nan = float("inf"), float("nan")
# --- non-finite numbers, every kind of field
scen("nan_dwell.yaml", {"program.steps.0.dwell_s": nan}, "2 dwell_s", ".nan dwell")
scen("inf_dwell.yaml", {"program.steps.0.dwell_s": inf}, "2 dwell_s", ".inf dwell")
scen("inf_ramp_rate.yaml", {"program.steps.1.ramp_c_per_h": inf}, "2 ramp_c_per_h", ".inf ramp")
scen("minus_inf_target.yaml", {"program.steps.1.target_c": -inf}, "2 target_c", "-.inf target")
scen("nan_start.yaml", {"program.start_c": nan}, "2 start_c", ".nan start temperature")
scen("inf_staircase_step.yaml", {"program.steps.1": {"type": "staircase", "target_c": 30, "step_c": inf, "step_s": 35}},
     "2 step_c", ".inf staircase step")
scen("nan_hold_target.yaml", {"program.steps.0.target_c": nan}, "2 target_c", ".nan hold target")
scen("nan_noise_density.yaml", {"device.sensor.noise_density_ug_per_sqrt_hz": nan}, "2 noise_density", "NaN noise")
scen("inf_zero_g_offset.yaml", {"device.sensor.zero_g_offset_mg": inf}, "2 zero_g_offset_mg", "inf offset")
scen("nan_applied_g.yaml", {"test_plan.orientations.0.applied_g": nan}, "2 applied_g", "NaN applied g")
scen("inf_air_tau.yaml", {"chamber.air_tau_s": inf}, "2 air_tau_s", "the chamber would never move")
scen("nan_thermometer_offset.yaml", {"chamber.thermometer.offset_c": nan}, "2 offset_c", "NaN thermometer offset")
scen("nan_effect_parameter.yaml", {"device.effects.static_bias_tc.tc1_mg_per_c": nan}, "2 tc1_mg_per_c", "NaN effect parameter")
scen("nan_layer_density.yaml", {"chamber.model": "conduction_1d", "chamber.thermometer.attached_to": "board",
     "chamber.conduction_1d.layers": [{"name": "board", "thickness_mm": 1.6, "conductivity_w_per_mk": 0.3,
     "density_kg_per_m3": nan, "specific_heat_j_per_kgk": 1100}, {"name": "die", "thickness_mm": 0.3,
     "conductivity_w_per_mk": 148, "density_kg_per_m3": 2330, "specific_heat_j_per_kgk": 705}]},
     "2 density_kg_per_m3", "NaN density")
scen("nan_gravity.yaml", {"device.effects": None, "device.axes": {a: {} for a in "xyz"},
     "test_plan.orientations": [{"at_s": 0, "gravity_g": [nan, 0, 1]}]}, "2 gravity_g", "NaN gravity vector")
# --- zero duration, sizes that would allocate TiB, hangs
scen("zero_duration_ramp.yaml", {"program.steps": [{"type": "ramp", "target_c": -20, "ramp_c_per_h": 10}]},
     "2 lasts 0 s", "a program of zero duration (IndexError before)")
scen("zero_duration_staircase.yaml", {"program.steps": [{"type": "staircase", "target_c": -20, "step_c": 1, "step_s": 5}]},
     "2 lasts 0 s", "zero duration")
scen("dwell_1e12.yaml", {"program.steps.0.dwell_s": 1e12}, "2 dwell_s", "1e12 s dwell")
scen("staircase_step_1e-12.yaml", {"program.steps.1": {"type": "staircase", "target_c": 30, "step_c": 1e-12, "step_s": 35}},
     "2 GB of memory", "1e-12 °C steps: 1.75e15 s of program")
scen("runs_1e8.yaml", {"test_plan.runs": 10**8}, "2 runs", "1e8 runs")
scen("runs_samples_limit.yaml", {"test_plan.runs": 90000, "test_plan.logger_rate_hz": 1.0}, "2 GB of memory",
     "runs within their bound, but samples over the memory limit")
scen("cycles_1e9.yaml", {"program.cycles": 10**9}, "2 cycles", "hung before")
scen("cycles_1e30.yaml", {"program.cycles": 1e30}, "2 cycles", "hung before")
scen("tumble_block_1e-9.yaml", {"test_plan": {"logger_rate_hz": 0.1, "tumble": {"block_s": 1e-9, "applied_g": [1, -1]}}},
     "2 blocks", "a schedule of 1e12 blocks")
scen("logger_rate_1e9.yaml", {"test_plan.logger_rate_hz": 1e9}, "2 logger_rate_hz", "logger above the ODR")
# --- physical ranges, model validity
scen("start_minus_300.yaml", {"program.start_c": -300}, "2 start_c", "below absolute zero (was simulated, exit 0)")
scen("target_500.yaml", {"program.steps.1.target_c": 500}, "2 target_c", "above the chamber range")
scen("seed_2_70.yaml", {"seed": 2**70}, "2 seed", "seed 2**70 (TypeError writing HDF5)")
scen("negative_seed.yaml", {"seed": -1}, "2 seed", "negative seed")
scen("huge_heat_capacity.yaml", {"chamber.lumped.board_heat_capacity_j_per_k": 1e308}, "2 board_heat_capacity", "1e308 J/K")
scen("huge_thermometer_offset.yaml", {"chamber.thermometer.offset_c": 1e300}, "2 offset_c", "1e300 °C offset")
scen("huge_applied_g.yaml", {"test_plan.orientations.0.applied_g": 1e300}, "2 applied_g", "1e300 g")
scen("effect_out_of_bounds.yaml", {"device.effects.static_bias_tc.tc1_mg_per_c": 1e300}, "2 tc1_mg_per_c", "effect bound")
scen("two_orientations_same_instant.yaml", {"test_plan.orientations": [{"at_s": 0, "applied_g": 1.0}, {"at_s": 100, "applied_g": -1.0},
     {"at_s": 100, "applied_g": 0.0}]}, "2 same instant", "one silently won before")
scen("orientations_unsorted.yaml", {"test_plan.orientations": [{"at_s": 100, "applied_g": 1.0}, {"at_s": 0, "applied_g": -1.0}]},
     "2 increasing", "unsorted orientations")
scen("unknown_key.yaml", {"program.steps.1.ramp_c_per_hr": 10}, "2 ramp_c_per_hr", "misspelt key")
scen("string_for_number.yaml", {"program.steps.0.dwell_s": "an hour"}, "2 dwell_s", "a string for a number")
scen("bool_for_list.yaml", {"program.steps": True}, "2 steps", "a boolean for the steps")
scen("empty_steps.yaml", {"program.steps": []}, "2 steps", "no steps")
# --- valid edge cases: must succeed with finite output
scen("ok_tiny.yaml", {}, "0", "the valid base of this corpus")
scen("ok_range_edges.yaml", {"program.start_c": -150.0, "program.steps.1.target_c": 300.0, "program.steps.1.ramp_c_per_h": 1e9,
     "chamber.air_tau_s": 1e-9, "chamber.lumped.die_tau_s": 1e9, "seed": 2**63 - 1}, "0",
     "every value at the edge of its range: finite output")
scen("ok_negative_zero_sigma.yaml", {"device.sensor.turn_on_bias_mg": -0.0, "chamber.thermometer.noise_c": -0.0,
     "device.sensor.bias_instability_mg": -0.0}, "0", "-0.0 as a σ (numpy refused 'scale < 0'; found by hypothesis)")
scen("ok_three_axis.yaml", {"device.effects": None, "device.axes": {a: {} for a in "xyz"},
     "test_plan.orientations": [{"at_s": 0, "gravity_g": [0, 0, 1]}]}, "0", "a three-axis device")
# --- YAML bombs
write("yaml_self_alias.yaml", None, "run FILE -o OUT.h5 -q", "2 alias", "an anchor that refers to itself",
      raw="program: &a\n  steps: *a\n")
write("yaml_deep_nesting.yaml", None, "run FILE -o OUT.h5 -q", "2 nested deeper", "2,000-deep nesting",
      raw="program: " + "[" * 2000 + "]" * 2000 + "\n")
laughs = ['a0: &a0 ["lol","lol","lol","lol","lol","lol","lol","lol","lol"]']
for i in range(1, 10):
    laughs.append(f"a{i}: &a{i} [" + ",".join([f"*a{i-1}"] * 9) + "]")
write("yaml_billion_laughs.yaml", None, "run FILE -o OUT.h5 -q", "2 aliases are expanded", "a billion laughs",
      raw="\n".join(laughs) + "\nprogram: *a9\n")
write("yaml_not_a_mapping.yaml", None, "run FILE -o OUT.h5 -q", "2 mapping", "a list, not a mapping", raw="- 1\n- 2\n")
write("yaml_malformed.yaml", None, "run FILE -o OUT.h5 -q", "2 malformed YAML", "a tab and an open bracket",
      raw="program: [\n\tsteps: {\n")
(D / "yaml_not_utf8.yaml").write_bytes(b"# not UTF-8\n# cmd: run FILE -o OUT.h5 -q\n# expect: 2 UTF-8\nprogram: \xff\xfe\n")
# --- plugins
(D / "plugin_raises.py").write_text('"""A plugin that raises while it is imported."""\n\nraise RuntimeError("boom while importing")\n')
(D / "plugin_exits.py").write_text('"""A plugin that calls sys.exit while it is imported."""\n\nimport sys\n\nsys.exit(3)\n')
(D / "plugin_basis_raises.py").write_text('''"""A plugin effect whose basis raises at run time, and one that calls sys.exit there."""

import sys

from twin.effects.base import Contribution, Effect, Parameter
from twin.effects.registry import register


@register
class AdvBasisRaises(Effect):
    name = "adv_basis_raises"
    family = "adv_test"
    description = "raises in its basis (adversarial corpus)"
    reads = ("die_c",)
    parameters = (Parameter("k_mg", "mg", 0.0, (-1.0, 1.0), "test"),)

    def basis(self, inputs):
        raise ZeroDivisionError("basis blew up")


@register
class AdvBasisExits(Effect):
    name = "adv_basis_exits"
    family = "adv_test"
    description = "calls sys.exit in its basis (adversarial corpus)"
    reads = ("die_c",)
    parameters = (Parameter("k_mg", "mg", 0.0, (-1.0, 1.0), "test"),)

    def basis(self, inputs):
        sys.exit(4)
''')
scen("plugin_raises_on_import.yaml", {"twin": {"plugins": ["plugin_raises.py"]}}, "2 RuntimeError", "plugin raises on import")
scen("plugin_system_exit.yaml", {"twin": {"plugins": ["plugin_exits.py"]}}, "2 SystemExit", "plugin calls sys.exit on import")
scen("plugin_missing.yaml", {"twin": {"plugins": ["no_such_plugin.py"]}}, "2 not found", "plugin file missing")
scen("plugin_basis_raises.yaml", {"twin": {"plugins": ["plugin_basis_raises.py"]}, "device.effects.adv_basis_raises": {}},
     "2 adv_basis_raises", "an effect that raises at run time, named")
scen("plugin_basis_exits.yaml", {"twin": {"plugins": ["plugin_basis_raises.py"]}, "device.effects.adv_basis_exits": {}},
     "2 adv_basis_exits", "an effect that calls sys.exit at run time, named")
# --- outputs
scen("out_is_input.yaml", {}, "2 overwrite an input", "twin run s.yaml -o s.yaml", cmd="run FILE -o FILE -q")
scen("out_is_directory.yaml", {}, "2 directory", "-o a directory", cmd="run FILE -o DIR -q")
scen("out_parent_is_file.yaml", {}, "2 not a folder", "-o below a file", cmd="run FILE -o FILE/x.h5 -q")
scen("json_parent_is_file.yaml", {}, "2 not a folder", "--json below a file: refused before the dataset is written",
     cmd="run FILE -o OUT.h5 -q --json FILE/x.json")
scen("json_is_input.yaml", {}, "2 overwrite an input", "--json over the input", cmd="run FILE -o OUT.h5 -q --json FILE")
# --- render and comb
scen("render_temperature_2000.yaml", {}, "2 silicon model", "outside the silicon model's range",
     cmd="render FILE --temperature 2000 -o OUT.png")
scen("render_temperature_nan.yaml", {}, "2 silicon model", "NaN temperature", cmd="render FILE --temperature nan -o OUT.png")
scen("render_sweep_tiny_step.yaml", {}, "2 frames", "hung before", cmd="render FILE --sweep -20:50:1e-6 -o OUT.gif")
scen("render_sweep_nan.yaml", {}, "2 finite", "NaN in a sweep", cmd="render FILE --sweep nan:50:5 -o OUT.gif")
scen("render_out_is_input.yaml", {}, "2 .png", "render over its input", cmd="render FILE --temperature 20 -o FILE")
scen("comb_t_high_5000.yaml", {}, "2 silicon model", "outside the silicon model's range",
     cmd="comb FILE --t-high-c 5000")
scen("comb_inf_acceleration.yaml", {}, "2 acceleration", "inf acceleration", cmd="comb FILE --acceleration-g inf")
# --- studies
(D / "base_invalid.yaml").write_text("# a base scenario with a bad key (used by study_invalid_base.yaml)\n# cmd: run FILE -o OUT.h5 -q\n"
                                     "# expect: 2 air_tau_s\n" + yaml.safe_dump({**copy.deepcopy(BASE), "chamber": {"air_tau_s": -1}}, sort_keys=False))
def study(name, data, expect, why, cmd="doe FILE -o OUT"):
    s = {"base": "ok_tiny.yaml", "seed": 1, "factors": {"device.sensor.zero_g_offset_mg": {"levels": [0.0, 5.0]}},
         "responses": ["chamber_hours"], "max_runs": 10}
    s.update(data)
    write(name, s, cmd, expect, why)
study("study_ok.yaml", {}, "0", "a valid tiny study")
study("study_duplicate_responses.yaml", {"responses": ["chamber_hours", "drift_pp_mg", "chamber_hours"]}, "2 listed twice",
      "failed after all runs and left table.csv before")
study("study_factorial_1e18.yaml", {"factors": {f"device.geometry.{k}": {"levels": list(range(1, 11))}
      for k in ["b_um", "e_um", "h_um", "g_um", "u_um", "m_um", "n_um", "j_um", "i_um"]} |
      {f"device.effects.static_bias_tc.tc{i}_mg_per_c": {"range": [0, 1]} for i in (1,)} |
      {f"chamber.lumped.{k}": {"levels": list(range(1, 11))} for k in ["board_tau_s", "die_tau_s", "die_to_board_capacity_ratio",
       "board_heat_capacity_j_per_k"]} | {f"chamber.thermometer.{k}": {"levels": list(range(1, 11))} for k in
      ["tau_s", "noise_c", "resolution_c", "sample_rate_hz"]},
      "design": {"type": "full_factorial", "levels": 10}}, "2 max_runs", "1e18 points were built before the max_runs check")
study("study_invalid_base.yaml", {"base": "base_invalid.yaml"}, "2 base_invalid.yaml", "every run failed, exit 0 before")
study("study_missing_base.yaml", {"base": "nowhere.yaml"}, "2 not found", "no base")
study("study_nan_range.yaml", {"factors": {"device.sensor.zero_g_offset_mg": {"range": [0, float("nan")]}}}, "2 finite", "NaN range")
study("study_plugin_raises.yaml", {"plugins": ["plugin_raises.py"]}, "2 RuntimeError", "a response plugin raising on import")
study("study_every_run_fails.yaml", {"factors": {"program.steps.0.dwell_s": {"levels": [5e7, 6e7]},
      "test_plan.logger_rate_hz": {"levels": [1.0]}}}, "2 all 2 runs failed",
      "each level valid alone, every combination over the sample limit: not a success")
study("study_level_out_of_bounds.yaml", {"factors": {"device.sensor.zero_g_offset_mg": {"levels": [1e6, 2e6]}}},
      "2 gives an invalid scenario", "levels outside the bounds: refused up front, not run and recorded as failed")
study("study_json_over_ledger.yaml", {}, "2 overwrite", "--json over the study's own runs.jsonl (written last, before)",
      cmd="doe FILE -o OUT --json OUT/runs.jsonl")
# --- the FE package model: twin package, render --fem, FEM factors of a study
PKG = copy.deepcopy(BASE)
PKG["device"]["effects"] = {"package_fem": {"mould_cte_ppm_per_k": 11.0, "attach_modulus_gpa": 3.9,
                                            "die_thickness_um": 400.0, "cell_offset_um": 300.0}}
write("base_package_fem.yaml", PKG, "package FILE --json OUT.json", "0", "the FE package model's valid base")
for name, key, levels in (("study_fem_zero_modulus.yaml", "attach_modulus_gpa", [0.0, 3.9]),
                          ("study_fem_negative_thickness.yaml", "die_thickness_um", [-400.0, 400.0])):
    study(name, {"base": "base_package_fem.yaml", "plugins": ["twin.studies.package_response"],
                 "responses": ["package_tcoff_mg_per_c"], "factors": {f"device.effects.package_fem.{key}": {"levels": levels}}},
          f"2 {key}", "a FEM factor level outside its bounds: refused before any run (exit 0 with failed runs before)")
scen("package_json_over_input.yaml", {}, "2 overwrite an input", "twin package s.yaml --json s.yaml", cmd="package FILE --json FILE")
scen("render_fem_json_same_as_out.yaml", {}, "2 two outputs", "-o and --json one file: the JSON replaced the PNG, exit 0",
     cmd="render FILE --fem -o OUT.png --json OUT.png")
scen("render_fem_negative_thickness.yaml", {"device.effects": {"package_fem": {"die_thickness_um": -1.0}}}, "2 die_thickness_um",
     "negative die thickness", cmd="render FILE --fem -o OUT.png")
study("study_unknown_response.yaml", {"responses": ["chamber_hour"]}, "2 chamber_hours", "did you mean")
study("study_huge_max_runs.yaml", {"max_runs": 10**30}, "2 max_runs", "max_runs 1e30")
study("study_out_is_file.yaml", {}, "2 folder", "-o a file", cmd="doe FILE -o FILE")
study("study_dead_scheduler.yaml", {}, "2 scheduler", "30 s then a traceback before",
      cmd="doe FILE -o OUT --executor dask --scheduler tcp://127.0.0.1:9")
print(len(list(D.iterdir())))
