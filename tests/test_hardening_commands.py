"""Bad input never crashes, hangs or overwrites (issue 14): the newer commands.

``twin fleet`` / ``fleet-simulate`` spec files, ``twin firmware`` / ``apply`` calibration
documents, ``--plugin`` effects that misbehave, ``--json`` / ``--report`` targets checked before
the work, and Ctrl-C. Each case: exit 2 (130 for Ctrl-C), one line, no file left, no input changed.
Everything is refused before any unit, run or solve, so each case takes well under a second.
"""

from __future__ import annotations

import contextlib
import hashlib
import json
import os
import shutil
from pathlib import Path

import numpy as np
import pytest
from conftest import ROOT
from conftest import run_in_process as run_main

MODEL = ROOT / "tests" / "adversarial" / "model"
CAL = ROOT / "tests" / "adversarial" / "calibration" / "cal_one_imu.json"
LOG_ROWS = "time_s,temperature_c,output_g,applied_g,run,power_on\n" + "".join(
    f"{10.0 * i},{-20 + i},1.0,1.0,0,{int(i == 0)}\n" for i in range(30))




def snapshot(folder: Path) -> dict[str, str]:
    return {str(p.relative_to(folder)): hashlib.sha256(p.read_bytes()).hexdigest() if p.is_file() else "dir"
            for p in sorted(folder.rglob("*"))}


def refused(folder: Path, args: list[str], fragment: str, code: int = 2) -> str:
    """Run ``args`` in ``folder`` (paths relative to it): exit ``code``, one line holding ``fragment``,
    nothing written, nothing changed."""
    before = snapshot(folder)
    with contextlib.chdir(folder):
        got, out, err = run_main(args)
    lines = err.splitlines()
    assert got == code, (got, err)
    assert len(lines) == 1 and lines[0].startswith("twin: "), err
    assert fragment in lines[0], lines[0]
    assert "Traceback" not in out + err
    assert snapshot(folder) == before, "a file was written or changed"
    return lines[0]


@pytest.fixture
def fleet_dir(tmp_path) -> Path:
    """ok_tiny.yaml, two unit logs under logs/, and a fleet scenario over the same base."""
    shutil.copy(MODEL / "ok_tiny.yaml", tmp_path / "ok_tiny.yaml")
    (tmp_path / "logs").mkdir()
    for unit in ("u1", "u2"):
        (tmp_path / "logs" / f"{unit}.csv").write_text(LOG_ROWS)
    return tmp_path


def fleet_spec(folder: Path, text: str) -> str:
    (folder / "f.yaml").write_text(text)
    return "f.yaml"


# ------------------------------------------------------------------ twin fleet: the spec's values


@pytest.mark.parametrize("body, fragment", [
    ('units: {"../../evil": logs/u1.csv}', "unit id '../../evil'"),  # wrote outside -o before
    ("units: {null: logs/u1.csv}", "unit id None"),
    ("units: {a: logs}", "is a folder"),
    ("units: logs/*.csv\nscenario: [a, b]", "scenario: expected the path"),  # TypeError before
    ("units: logs/*.csv\nscenario: logs/u1.csv", "u1.csv"),  # every unit failed the same way, exit 0
    ("units: logs/*.csv\noutlier_threshold: .nan", "outlier_threshold"),
    ("units: logs/*.csv\noutlier_threshold: true", "outlier_threshold"),
    ("units: logs/*.csv\noptions: {average_s: -5}", "average_s"),
    ("units: logs/*.csv\noptions: {applied_g: .nan}", "applied_g"),
    ("units: logs/*.csv\noptions: {with_effects: [nope_effect]}", "nope_effect"),
    ("units: logs/*.csv\noptions: {with_effects: [1, 2]}", "with_effects"),
    ("units: logs/*.csv\ncolumns: {header: maybe}", "header: got 'maybe'"),
    ("units: logs/*.csv\ncommand: calibrate\noptions: {imu: abc}", "options.imu"),
])
def test_fleet_spec_values_are_refused_before_any_unit(fleet_dir, body, fragment):
    spec = fleet_spec(fleet_dir, ("scenario: ok_tiny.yaml\n" if "scenario" not in body else "") + body + "\n")
    refused(fleet_dir, ["fleet", spec, "-o", "out"], fragment)


def test_fleet_spec_not_utf8(fleet_dir):
    (fleet_dir / "f.yaml").write_bytes(b"units: \xff\xfe\n")
    refused(fleet_dir, ["fleet", "f.yaml", "-o", "out"], "not UTF-8")


@pytest.mark.parametrize("json_target, fragment", [
    ("f.yaml", "overwrite an input"), ("logs/u1.csv", "overwrite an input"), ("ok_tiny.yaml", "overwrite an input"),
    ("out/units.jsonl", "two outputs name one file"), ("ok_tiny.yaml/x.json", "not a folder"), ("logs", "directory"),
])
def test_fleet_json_is_checked_before_the_units_run(fleet_dir, json_target, fragment):
    """--json used to be written after every unit: over the spec, a log or the scenario (exit 0)."""
    spec = fleet_spec(fleet_dir, "scenario: ok_tiny.yaml\nunits: logs/*.csv\n")
    refused(fleet_dir, ["fleet", spec, "-o", "out", "--json", json_target], fragment)


def test_a_foreign_folder_gets_no_lock_file(fleet_dir):
    spec = fleet_spec(fleet_dir, "scenario: ok_tiny.yaml\nunits: logs/*.csv\n")
    (fleet_dir / "out").mkdir()
    (fleet_dir / "out" / "units.jsonl").write_text("hello\n")
    refused(fleet_dir, ["fleet", spec, "-o", "out"], "not a unit record")


# ------------------------------------------------------------------ twin fleet-simulate


@pytest.mark.parametrize("extra, fragment", [
    ("seed: abc", "seed"), ("seed: -5", "seed"), ("seed: 3.7", "seed"), ("seed: .nan", "seed"),
    ("seed: 100000000000000000000000", "seed"), ("vary: [1, 2]", "vary: expected a mapping"),
    ("effects: [a, b]", "effects: expected a mapping"),
    ("vary: {device.effects.static_bias_tc.tc1_mg_per_c: {normal: [0, -1]}}", "standard deviation"),
    ("vary: {device.effects.static_bias_tc.tc1_mg_per_c: {uniform: [0, .inf]}}", "finite"),
    ("effects: {thermal_lag: {prevalence: 1, set: [1]}}", "set: expected a mapping"),
    ("effects: {thermal_lag: {prevalence: 1, draw: abc}}", "draw: expected a mapping"),
    ("logger_rate_hz: fast", "logger_rate_hz"), ("id_prefix: ../../evil", "id_prefix"),
    ("id_prefix: [a]", "id_prefix"), ("name: [1, 2]", "name: expected text"),
    # a value only some units draw: found up front, not by that unit after the others were written
    ("vary: {chamber.air_tau_s: {choice: [60, 60, 60, 60, 60, 60, 60, 60, 60, -5]}}", "got -5"),
    ("effects: {thermal_lag: {prevalence: 0.0, draw: {chamber.lumped.die_tau_s: {uniform: [-10, 100]}}}}", "got -10"),
])
def test_fleet_scenario_values(fleet_dir, extra, fragment):
    (fleet_dir / "s.yaml").write_text(f"base: ok_tiny.yaml\nunits: 2\n{extra}\n")
    refused(fleet_dir, ["fleet-simulate", "s.yaml", "-o", "out"], fragment)


def test_fleet_scenario_not_utf8(fleet_dir):
    (fleet_dir / "s.yaml").write_bytes(b"base: \xff\n")
    refused(fleet_dir, ["fleet-simulate", "s.yaml", "-o", "out"], "not UTF-8")


@pytest.mark.parametrize("args, fragment", [
    (["--json", "s.yaml"], "overwrite an input"),  # the spec was replaced by the JSON, exit 0
    (["--json", "logs"], "directory"), (["--json", "ok_tiny.yaml/x.json"], "not a folder"),
    (["--json", "out/fleet.yaml"], "two outputs"),
])
def test_fleet_simulate_outputs_are_checked_before_any_unit(fleet_dir, args, fragment):
    (fleet_dir / "s.yaml").write_text("base: ok_tiny.yaml\nunits: 2\n")
    refused(fleet_dir, ["fleet-simulate", "s.yaml", "-o", "out", *args], fragment)


def test_fleet_simulate_never_writes_over_its_spec(fleet_dir):
    """-o the spec's own folder with the spec named fleet.yaml: it would be replaced by the written spec."""
    (fleet_dir / "fleet.yaml").write_text("base: ok_tiny.yaml\nunits: 2\n")
    refused(fleet_dir, ["fleet-simulate", "fleet.yaml", "-o", "."], "overwrite an input")


# ------------------------------------------------------------------ calibration documents


def _edited(tmp_path: Path, edit) -> Path:
    doc = json.loads(CAL.read_text())
    doc = edit(doc) or doc
    path = tmp_path / "c.json"
    path.write_text(json.dumps(doc))
    return path


def _set(path: tuple, value):
    def edit(doc):
        node = doc
        for k in path[:-1]:
            node = node[k]
        node[path[-1]] = value
    return edit


CORRUPT = {
    "imus_string": (_set(("imus",), "x"), "imus: got str"),
    "imu_string": (_set(("imus",), ["x"]), "imus: got list"),
    "no_methods": (lambda d: d["imus"][0].pop("methods") and None, "methods"),
    "instance_text": (_set(("imus", 0, "instance"), "zero"), "instance"),
    "span_nan": (_set(("imus", 0, "temperature_span_c"), [float("nan"), 50.0]), "temperature_span_c"),
    "span_reversed": (_set(("imus", 0, "temperature_span_c"), [50.0, 5.0]), "temperature_span_c"),
    "device_id_text": (_set(("imus", 0, "device_id"), "abc"), "device_id"),
    "samples_nan": (_set(("imus", 0, "samples"), float("nan")), "samples"),
    "level_nan": (_set(("imus", 0, "methods", "px4", "level_g"), [float("nan")] * 3), "methods.px4"),
    "coefficient_inf": (_set(("imus", 0, "methods", "px4", "firmware", "coefficients", "x", "values", 1),
                             float("inf")), "methods.px4"),
    "coefficient_text": (_set(("imus", 0, "methods", "ardupilot", "firmware", "coefficients", "y", "values", 0),
                              "abc"), "methods.ardupilot"),
    "twin_tau_nan": (_set(("imus", 0, "methods", "twin", "tau_die_s"), [float("nan")] * 3), "methods.twin"),
}


@pytest.mark.parametrize("case", sorted(CORRUPT))
@pytest.mark.parametrize("command", ["px4", "c", "apply"])
def test_corrupt_calibration_documents(tmp_path, case, command):
    """Each used to crash (TypeError/KeyError, exit 1) or write a firmware file of NaN (exit 0)."""
    edit, fragment = CORRUPT[case]
    cal = _edited(tmp_path, edit)
    (tmp_path / "log.csv").write_text(LOG_ROWS)
    args = (["apply", "c.json", "log.csv", "-o", "o.csv"] if command == "apply"
            else ["firmware", "c.json", "--format", command, "-o", "o.txt"])
    refused(tmp_path, args, fragment)
    assert cal.exists()


def _firmware(method: str, *keys):
    return ("imus", 0, "methods", method, "firmware", *keys)


def _append_term(method: str):
    def edit(doc):
        for axis in "xyz":
            doc["imus"][0]["methods"][method]["firmware"]["coefficients"][axis]["values"].append(1e-9)
    return edit


# values the firmware cannot hold, at the exporter that would write them (PX4 TC_An_*, ArduPilot INS_TCALn_*)
UNHOLDABLE = {
    ("px4", "1e45"): (_set(_firmware("px4", "coefficients", "x", "values", 1), 1e45),
                      "TC_A0_X1_0 = 1e+45 is beyond float32"),
    ("px4", "tmin_above_tmax"): (_set(_firmware("px4", "temperature_c", "tmin"), 99.0),
                                 "TC_A0_TMIN = 99 °C is not below TC_A0_TMAX"),
    ("px4", "degree4"): (_append_term("px4"), "axis x holds 5 coefficients; PX4 applies X0..X3"),
    ("px4", "slot300"): (_set(_firmware("px4", "method_parameters", "instance"), 300),
                         "method_parameters.instance: got 300, expected 0 for IMU instance 0"),
    ("ardupilot", "1e45"): (_set(_firmware("ardupilot", "coefficients", "x", "values", 1), 1e45),
                            "INS_TCAL1_ACC2_X = 1e+51 is beyond float32"),
    ("ardupilot", "tmin_above_tmax"): (_set(_firmware("ardupilot", "temperature_c", "tmin"), 99.0),
                                       "INS_TCAL1_TMIN = 99 °C is not below INS_TCAL1_TMAX"),
    ("ardupilot", "degree4"): (_append_term("ardupilot"), "axis x holds 4 coefficients; ArduPilot applies exactly"),
    ("ardupilot", "slot300"): (_set(_firmware("ardupilot", "method_parameters", "instance"), 300),
                               "method_parameters.instance: got 300, expected 1 for IMU instance 0"),
    ("px4", "imu300"): (_set(("imus", 0, "instance"), 300), "imus[0].instance: got 300, expected an IMU instance 0..3"),
    ("ardupilot", "imu-1"): (_set(("imus", 0, "instance"), -1), "imus[0].instance: got -1"),
    # an edit the firmware could hold but that is not the calibration: caught on load
    ("px4", "coefficient_true"): (_set(_firmware("px4", "coefficients", "x", "values", 1), True),
                                  "coefficients.x.values[1]: got True, expected a number"),
    ("px4", "tmin_text"): (_set(_firmware("px4", "temperature_c", "tmin"), "5"),
                           "temperature_c.tmin: got '5', expected a number"),
    ("px4", "slot3"): (_set(_firmware("px4", "method_parameters", "instance"), 3),
                       "method_parameters.instance: got 3, expected 0 for IMU instance 0"),
    ("px4", "tau_scalar"): (_set(("imus", 0, "methods", "twin", "tau_die_s"), -5.0),
                            "tau_die_s / tau_rate_s must be lists"),
    ("px4", "tref_500"): (_set(_firmware("px4", "temperature_c", "tref"), 500.0),
                          "fails the plausibility checks as loaded: px4 x: correction up to"),
}


@pytest.mark.parametrize("fmt, case", sorted(UNHOLDABLE))
def test_values_the_firmware_cannot_hold_are_refused_and_nothing_is_written(tmp_path, fmt, case):
    edit, fragment = UNHOLDABLE[fmt, case]
    _edited(tmp_path, edit)
    refused(tmp_path, ["firmware", "c.json", "--format", fmt, "-o", "o.txt"], fragment)


def test_the_trimmed_document_still_exports(tmp_path):
    shutil.copy(CAL, tmp_path / "c.json")
    with contextlib.chdir(tmp_path):
        for fmt in ("px4", "ardupilot", "json", "c"):
            code, _, err = run_main(["firmware", "c.json", "--format", fmt, "-o", f"o.{fmt}"])
            assert code == 0, err


def test_calibrate_report_is_checked_before_the_calibration_is_written(tmp_path):
    (tmp_path / "log.csv").write_text(LOG_ROWS)
    refused(tmp_path, ["calibrate", "log.csv", "-o", "c.json", "--report", "c.json"], "--report names a file")


# ------------------------------------------------------------------ plugins that misbehave


PLUGIN = '''
import numpy as np
from twin.effects import Contribution, Effect, Parameter, register


@register
class Edited(Effect):
    name = "adv_edited_{tag}"
    family = "discovered"
    reads = ("die_c",)
    parameters = (Parameter("c1_mg", "mg", 0.1, (-1.0, 1.0), source="test", role="amplitude"),)

    def basis(self, inputs):
        col = np.asarray(inputs.die_c, float)
        return {body}
'''


@pytest.mark.parametrize("tag, body, fragment", [
    ("nan", '{"c1_mg": Contribution(bias_g=col * float("nan"))}', "finite numbers"),
    ("short", '{"c1_mg": Contribution(bias_g=col[:3])}', "shape (3,)"),
    ("text", '{"c1_mg": Contribution(bias_g="abc")}', "finite numbers"),
    ("none", "None", "basis returned NoneType"),
    ("huge", '{"c1_mg": Contribution(bias_g=1e300 * col)}', "finite numbers"),  # overflow warnings, exit 0
    ("raises", '{"c1_mg": Contribution(bias_g=col)} if int("x") else {}', "basis failed: ValueError"),
])
def test_a_plugin_effect_that_returns_garbage_is_named(tmp_path, tag, body, fragment):
    """compare --plugin: an edited discovered effect used to end in an internal error (exit 1)."""
    from twin.effects import REGISTRY

    shutil.copy(MODEL / "ok_tiny.yaml", tmp_path / "ok_tiny.yaml")
    (tmp_path / "log.csv").write_text(LOG_ROWS)
    (tmp_path / "p.py").write_text(PLUGIN.format(tag=tag, body=body))
    try:
        line = refused(tmp_path, ["compare", "ok_tiny.yaml", "log.csv", "--plugin", "p.py"], fragment)
        assert f"adv_edited_{tag}" in line
    finally:
        REGISTRY.pop(f"adv_edited_{tag}", None)


@pytest.mark.parametrize("make, spec, fragment", [
    (lambda d: (d / "p.txt").write_text("x = 1\n"), "p.txt", "not a .py file"),
    (lambda d: (d / "pdir").mkdir(), "pdir", "a folder"),
    (lambda d: (d / "pdir.py").mkdir(), "pdir.py", "is a folder"),
])
def test_a_plugin_path_that_is_no_python_file(tmp_path, make, spec, fragment):
    shutil.copy(MODEL / "ok_tiny.yaml", tmp_path / "ok_tiny.yaml")
    (tmp_path / "log.csv").write_text(LOG_ROWS)
    make(tmp_path)
    refused(tmp_path, ["compare", "ok_tiny.yaml", "log.csv", "--plugin", spec], fragment)


def test_compare_average_s_infinite(tmp_path):
    shutil.copy(MODEL / "ok_tiny.yaml", tmp_path / "ok_tiny.yaml")
    (tmp_path / "log.csv").write_text(LOG_ROWS)
    refused(tmp_path, ["compare", "ok_tiny.yaml", "log.csv", "--average-s", "inf"], "--average-s")


# ------------------------------------------------------------------ outputs, usage, Ctrl-C


@pytest.mark.skipif(not Path("/proc/self").is_dir(), reason="needs /proc")
@pytest.mark.parametrize("args", [
    ["render", "ok_tiny.yaml", "--fem", "-o", "o.png", "--json", "/proc/x.json"],  # left o.png before
    ["package", "ok_tiny.yaml", "--json", "/proc/x.json"],
    ["parts", "--json", "/proc/x.json"],
])
def test_an_unwritable_json_target_is_found_before_the_work(tmp_path, args):
    shutil.copy(MODEL / "ok_tiny.yaml", tmp_path / "ok_tiny.yaml")
    refused(tmp_path, args, "cannot write in /proc")


def test_parts_json_over_the_part_file(tmp_path):
    shutil.copy(ROOT / "twin" / "parts" / "iis328dq.yaml", tmp_path / "p.yaml")
    refused(tmp_path, ["parts", "p.yaml", "--json", "p.yaml"], "overwrite an input")


def test_mp4_without_a_writer_is_one_line(tmp_path, monkeypatch):
    """No imageio-ffmpeg: an internal ValueError (exit 1) after the frames were drawn, before."""
    import importlib.util

    real = importlib.util.find_spec
    monkeypatch.setattr(importlib.util, "find_spec", lambda name, *a: None if name in ("imageio_ffmpeg", "av")
                        else real(name, *a))
    shutil.copy(MODEL / "ok_tiny.yaml", tmp_path / "ok_tiny.yaml")
    refused(tmp_path, ["render", "ok_tiny.yaml", "--sweep", "0:10:5", "-o", "o.mp4"], "imageio-ffmpeg")


def test_bare_twin_names_what_is_missing(tmp_path):
    with contextlib.chdir(tmp_path):
        code, _, err = run_main([])
    assert code == 2 and err == "twin: error: missing command (see 'twin --help')\n", err


def test_ctrl_c_turned_into_another_error_is_still_an_interruption(tmp_path, monkeypatch):
    """A SIGINT during an extension's import surfaces as ImportError: exit 130 and one line, not exit 1."""
    import signal

    import twin.cli.field

    def interrupted_import(*a, **k):
        handler = signal.getsignal(signal.SIGINT)
        try:
            handler(signal.SIGINT, None)
        except KeyboardInterrupt:
            raise ImportError("initialization failed") from None

    monkeypatch.setattr(twin.cli.field, "parse_axes", interrupted_import)
    # a terminal's Ctrl-C: a process started in the background of a script inherits SIGINT ignored
    previous = signal.signal(signal.SIGINT, signal.default_int_handler)
    try:
        (tmp_path / "log.csv").write_text(LOG_ROWS)
        refused(tmp_path, ["calibrate", "log.csv", "-o", "c.json"], "twin: interrupted", code=130)
    finally:
        signal.signal(signal.SIGINT, previous)


def test_ctrl_c_inside_a_plugin_is_one_line(tmp_path):
    shutil.copy(MODEL / "ok_tiny.yaml", tmp_path / "ok_tiny.yaml")
    (tmp_path / "log.csv").write_text(LOG_ROWS)
    (tmp_path / "p.py").write_text("raise KeyboardInterrupt\n")
    with contextlib.chdir(tmp_path):
        code, _, err = run_main(["compare", "ok_tiny.yaml", "log.csv", "--plugin", "p.py"])
    assert code == 130 and err.strip() == "twin: interrupted", err


def test_calibrate_prints_one_document_on_standard_output(tmp_path):
    (tmp_path / "log.csv").write_text(LOG_ROWS)
    refused(tmp_path, ["calibrate", "log.csv", "-o", "-", "--json", "-"], "both name standard output")


@pytest.mark.parametrize("scale, unit", [(1000.0, "mg"), (9.80665, "m/s^2")])
def test_a_three_axis_log_in_another_unit_declared_as_g_is_refused(tmp_path, scale, unit):
    """A level board reads ~0 on two axes: the median over all values passed a log in mg as g."""
    rows = "".join(f"{i},{-10 + i * 0.2},{0.01 * scale},{-0.02 * scale},{-1.0 * scale}\n" for i in range(300))
    (tmp_path / "log.csv").write_text("time_s,temperature_c,x,y,z\n" + rows)
    refused(tmp_path, ["calibrate", "log.csv", "--time-col", "time_s", "--temperature-col", "temperature_c",
                       "--x-col", "x", "--y-col", "y", "--z-col", "z", "--output-unit", "g", "-o", "c.json"],
            f"acceleration median |a| {scale:.3g} g is implausible")


def test_a_method_of_another_firmware_is_refused_for_px4(tmp_path):
    shutil.copy(CAL, tmp_path / "c.json")
    refused(tmp_path, ["firmware", "c.json", "--format", "px4", "--method", "ardupilot", "-o", "o.params"],
            "method 'ardupilot' is a ArduPilotAccelCal; --format px4 writes the px4 method only")


@pytest.mark.skipif(not hasattr(os, "mkfifo"), reason="needs FIFOs")
def test_an_output_that_is_a_device_fifo_or_symlink_loop_is_refused_never_replaced(tmp_path):
    (tmp_path / "log.csv").write_text(LOG_ROWS)
    os.mkfifo(tmp_path / "fifo")
    (tmp_path / "loop1").symlink_to("loop2")
    (tmp_path / "loop2").symlink_to("loop1")
    args = ["compare", "ok_tiny.yaml", "log.csv"]
    shutil.copy(MODEL / "ok_tiny.yaml", tmp_path / "ok_tiny.yaml")
    refused(tmp_path, [*args, "--json", "fifo"], "fifo: is a FIFO; expected a regular file or a new path")
    refused(tmp_path, [*args, "--json", "loop1"], "loop1: cannot be resolved")
    with contextlib.chdir(tmp_path):
        code, _, err = run_main([*args, "--json", "/dev/null"])
    assert code == 2 and "/dev/null: is a character device" in err
    assert Path("/dev/null").is_char_device()


@pytest.mark.parametrize("text, fragment", [
    ("[" * 100_000 + "]" * 100_000, "nested too deep to read"),
    ('{"schema": ' + "9" * 5000 + "}", "holds a value JSON readers refuse"),
    ('{"schema": ', "is not JSON"),
])
def test_a_calibration_document_json_cannot_read_is_one_line(tmp_path, text, fragment):
    (tmp_path / "c.json").write_text(text)
    (tmp_path / "log.csv").write_text(LOG_ROWS)
    refused(tmp_path, ["firmware", "c.json", "--format", "px4", "-o", "o.params"], fragment)
    refused(tmp_path, ["apply", "c.json", "log.csv", "-o", "o.csv"], fragment)


def test_a_ulog_whose_format_contains_itself_is_one_line(tmp_path):
    """pyulog expands nested formats recursively: a format holding itself recursed without end."""
    import struct

    from logfixtures import ULOG_MAGIC, _ulog_msg

    header = ULOG_MAGIC + bytes([1]) + struct.pack("<Q", 0) + _ulog_msg("B", bytes(40))
    body = (_ulog_msg("F", b"sensor_accel:sensor_accel loop;uint64_t timestamp;")
            + _ulog_msg("A", struct.pack("<BH", 0, 1) + b"sensor_accel")
            + _ulog_msg("D", struct.pack("<H", 1) + bytes(64)))
    (tmp_path / "recursive.ulg").write_bytes(header + body)
    refused(tmp_path, ["calibrate", "recursive.ulg", "-o", "c.json"], "recursive.ulg: not a readable ULog file")


def test_a_parquet_log_with_a_repeated_column_name_is_one_line(tmp_path):
    pa = pytest.importorskip("pyarrow")
    pq = pytest.importorskip("pyarrow.parquet")
    n = 400
    cols = [np.arange(n, dtype=float), np.linspace(0, 40, n), np.full(n, 0.01), np.full(n, 0.02), np.full(n, -1.0),
            np.full(n, -1.0)]
    pq.write_table(pa.table(cols, names=["t", "temp", "x", "y", "z", "z"]), tmp_path / "dup.parquet")
    refused(tmp_path, ["calibrate", "dup.parquet", "--time-col", "t", "--temperature-col", "temp", "--x-col", "x",
                       "--y-col", "y", "--z-col", "z", "-o", "c.json"], "column 'z' appears 2 times in the schema")


@pytest.mark.parametrize("case, fragment", [
    ("bool_time", "time_s has shape (30,) and type bool"),
    ("fractional_run", "test/run_index outside 0..")])
def test_hdf5_logs_with_boolean_times_or_fractional_runs_are_one_line(tmp_path, case, fragment):
    h5py = pytest.importorskip("h5py")
    n = 30
    with h5py.File(tmp_path / "log.h5", "w") as f:
        f["time_s"] = np.arange(n) % 2 == 0 if case == "bool_time" else np.arange(n, dtype=float) * 10
        f["temperature/thermometer_c"] = np.linspace(-20, 10, n)
        f["output/output_g"] = np.ones(n)
        f["test/applied_g"] = np.ones(n)
        f["test/run_index"] = np.full(n, 0.5) if case == "fractional_run" else np.zeros(n)
        f["test/power_on"] = np.zeros(n, bool)
    shutil.copy(MODEL / "ok_tiny.yaml", tmp_path / "ok_tiny.yaml")
    refused(tmp_path, ["compare", "ok_tiny.yaml", "log.h5", "--json", "o.json"], fragment)


def test_a_repeated_key_is_refused_with_its_line_not_dropped(fleet_dir):
    """YAML and JSON loaders keep the last of a repeated key in silence: a fleet lost a unit that way."""
    spec = fleet_spec(fleet_dir, "scenario: ok_tiny.yaml\nunits:\n  u1: logs/u1.csv\n  u1: logs/u2.csv\n")
    refused(fleet_dir, ["fleet", spec, "-o", "out"], "f.yaml:4: key 'u1' appears twice in one mapping (first at line 3)")
    text = (fleet_dir / "ok_tiny.yaml").read_text()
    (fleet_dir / "twice.yaml").write_text("seed: 1\n" + text if text.startswith("seed:") else text + "\nname: a\nname: b\n")
    refused(fleet_dir, ["run", "twice.yaml", "-o", "o.h5"], "appears twice in one mapping")
    doc = CAL.read_text()
    (fleet_dir / "cal.json").write_text(doc.replace('"samples":', '"samples": 1, "samples":', 1))
    refused(fleet_dir, ["firmware", "cal.json", "--format", "px4", "-o", "o.params"], "key 'samples' appears twice")


def test_json_never_names_a_file_the_report_or_ledger_writes(tmp_path):
    (tmp_path / "s.yaml").write_text((MODEL / "ok_tiny.yaml").read_text())
    (tmp_path / "log.csv").write_text(LOG_ROWS)
    refused(tmp_path, ["compare", "s.yaml", "log.csv", "--report", "rep", "--json", "rep/report.html"],
            "--json names a file the report writes (report.html)")
    refused(tmp_path, ["compare", "s.yaml", "log.csv", "--json", "ledger.jsonl"], "the ledger writes")


def test_warnings_on_the_way_to_an_error_are_not_printed_before_its_line(capsys):
    import warnings

    import typer

    from twin.cli.common import guard
    from twin.errors import TwinError

    with pytest.raises(typer.Exit):
        with guard():
            np.array([1.0]) / np.array([0.0])  # NumPy's "divide by zero encountered" RuntimeWarning
            warnings.warn("a library's own warning", UserWarning)
            raise TwinError("the reason")
    err = capsys.readouterr().err
    assert err == "twin: error: the reason\n", err
    with pytest.warns(UserWarning, match="kept"), guard():  # after success they are shown as before
        warnings.warn("kept", UserWarning)


def test_fleet_outputs_never_replace_its_scenario_and_a_folder_ledger_or_odd_name_stops_it_first(fleet_dir):
    (fleet_dir / "out").mkdir()
    shutil.copy(fleet_dir / "ok_tiny.yaml", fleet_dir / "out" / "table.csv")  # a scenario named like the table
    refused(fleet_dir, ["fleet", "logs/*.csv", "-o", "out", "--scenario", "out/table.csv"], "overwrite an input")
    (fleet_dir / "out2" / "units.jsonl").mkdir(parents=True)
    refused(fleet_dir, ["fleet", "logs/*.csv", "-o", "out2", "--scenario", "ok_tiny.yaml"], "is a directory")
    os.rename(fleet_dir / "logs" / "u2.csv", os.path.join(os.fsencode(fleet_dir / "logs"), b"\xffu2.csv"))
    refused(fleet_dir, ["fleet", "logs/*.csv", "-o", "out3", "--scenario", "ok_tiny.yaml"], "is not valid UTF-8")


def test_fleet_simulate_draws_every_unit_before_writing_any(fleet_dir):
    """A normal draw whose tail goes below a bound used to fail at the second unit, leaving the first
    unit's log, truth.json and fleet.yaml, and named '<fleet unit unit0001>'."""
    (fleet_dir / "fs.yaml").write_text("base: ok_tiny.yaml\nunits: 40\nseed: 3\n"
                                       "vary:\n  chamber.lumped.die_tau_s: {normal: [5.0, 5.0]}\n")
    line = refused(fleet_dir, ["fleet-simulate", "fs.yaml", "-o", "sim"], "fs.yaml: unit unit0001 as drawn: "
                   "chamber.lumped.die_tau_s")
    assert "<fleet unit" not in line


def test_render_fem_refuses_what_twin_package_refuses(tmp_path):
    text = (ROOT / "scenarios" / "package_fem.yaml").read_text()
    assert "cell_offset_um: 300.0" in text
    (tmp_path / "off.yaml").write_text(text.replace("cell_offset_um: 300.0",
                                                    "cell_offset_um: 600.0\n      spring_half_span_um: 900.0"))
    for args in (["package", "off.yaml"], ["render", "off.yaml", "--fem", "-o", "o.png"]):
        refused(tmp_path, args, "must lie on the die")


def test_ctrl_c_swallowed_inside_the_renderer_still_leaves_no_file(tmp_path):
    """VTK and the GIF encoder run in C and can swallow the KeyboardInterrupt of a SIGINT: the
    writer records the signal and honours it before the rename."""
    import signal

    from twin.reporting.fem_render import write_atomically

    def renderer(tmp):
        tmp.write_bytes(b"GIF89a")
        try:
            os.kill(os.getpid(), signal.SIGINT)
            import time

            time.sleep(0.05)
        except KeyboardInterrupt:
            pass  # swallowed, as a C renderer may

    outer = signal.signal(signal.SIGINT, signal.default_int_handler)  # Ctrl-C live, as on a terminal
    try:
        with pytest.raises(KeyboardInterrupt):
            write_atomically(tmp_path / "sweep.gif", renderer)
        assert list(tmp_path.iterdir()) == []
        assert signal.getsignal(signal.SIGINT) is signal.default_int_handler  # restored
    finally:
        signal.signal(signal.SIGINT, outer)


def test_a_ulog_with_ten_thousand_empty_messages_is_refused_at_once(tmp_path, monkeypatch):
    """Unknown zero-length messages in the definitions section made pyulog resynchronise byte by
    byte, rereading kilobytes per byte: calibrate sat in the parser for minutes. The work is
    counted, not timed: pyulog's parser is never entered, and the reader's own walk reads the file
    once, only up to the first bad message's 3-byte header."""
    import builtins
    import struct

    import pyulog

    import twin.measurement.ulog as ulog_reader
    from logfixtures import chamber_run, write_ulog

    data = write_ulog(tmp_path / "ok.ulg", chamber_run(n=60)).read_bytes()
    cut = 16 + 3 + struct.unpack("<H", data[16:18])[0]  # after the flag-bits message
    (tmp_path / "empty.ulg").write_bytes(data[:cut] + struct.pack("<HB", 0, ord("D")) * 10_000 + data[cut:])
    (tmp_path / "ok.ulg").unlink()
    parsed, read = [], []
    parser = pyulog.ULog

    def parse(*args, **kwargs):
        parsed.append(args)
        return parser(*args, **kwargs)

    class Counted:
        """A file whose reads are tallied."""

        def __init__(self, f):
            self.f = f

        def __enter__(self):
            return self

        def __exit__(self, *exc):
            self.f.close()

        def read(self, n=-1):
            chunk = self.f.read(n)
            read.append(len(chunk))
            return chunk

        def __getattr__(self, name):
            return getattr(self.f, name)

    monkeypatch.setattr(pyulog, "ULog", parse)
    monkeypatch.setattr(ulog_reader, "open", lambda *a, **k: Counted(builtins.open(*a, **k)), raising=False)
    refused(tmp_path, ["calibrate", "empty.ulg", "-o", "c.json"], f"corrupt at byte {cut} (message type 'D' of 0 bytes")
    assert not parsed  # the byte-by-byte resynchronisation lives in pyulog's parser
    assert 0 < sum(read) <= cut + 3  # read once, and not past the bad message's 3-byte header


def test_an_hdf5_soft_link_loop_and_a_temperature_of_1e36_are_one_line(tmp_path):
    import h5py

    with h5py.File(tmp_path / "loop.h5", "w") as f:
        f["a"] = h5py.SoftLink("/b")
        f["b"] = h5py.SoftLink("/a")
    (tmp_path / "s.yaml").write_text((MODEL / "ok_tiny.yaml").read_text())
    refused(tmp_path, ["calibrate", "loop.h5", "-o", "c.json"], "loop.h5")
    refused(tmp_path, ["compare", "s.yaml", "loop.h5", "--json", "r.json"], "loop.h5")
    temps = np.linspace(0.0, 40.0, 400)
    temps[200] = 1e36  # once a LinAlgError inside the fit
    (tmp_path / "hot.csv").write_text("time_s,temperature_c,x,y,z\n" + "".join(
        f"{i},{float(t)!r},0.01,0.02,-1.0\n" for i, t in enumerate(temps)))
    refused(tmp_path, ["calibrate", "hot.csv", "--time-col", "time_s", "--temperature-col", "temperature_c",
                       "--x-col", "x", "--y-col", "y", "--z-col", "z", "-o", "c.json"], "is not an IMU's in °C")
