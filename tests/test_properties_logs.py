"""Property-based tests of the measurement boundary (issue 14): generated column maps and logs,
valid and broken — delimited text with banners, canonical CSV, 3-axis logs, twin-style HDF5,
Parquet, flight-log-like bytes — read directly and through the CLI in process.

The contract: a result with finite arrays (exit 0), or a MeasurementError / exit 2 with one
``twin: error:`` line; never another exception, never a file written outside the named output.
And the fast text path returns exactly what the careful path returns, errors included.
Budget: the "ci" profile (60 examples each) runs in well under a minute; HYPOTHESIS_PROFILE=long
runs 20,000.
"""

from __future__ import annotations

import json
import math
import tempfile
from pathlib import Path

import numpy as np
import pytest
import yaml

hypothesis = pytest.importorskip("hypothesis")
from hypothesis import HealthCheck, given, settings  # noqa: E402
from hypothesis import strategies as st  # noqa: E402

from conftest import ROOT, run_in_process  # noqa: E402
import twin.measurement as tm  # noqa: E402
from twin.measurement import delimited  # noqa: E402

SCENARIO = ROOT / "scenarios" / "paper_iis328dq.yaml"
FIELDS = ("time", "temperature", "output", "applied", "run", "power_on", "time_unit", "temperature_unit",
          "output_unit", "output_scale", "digit_mg", "skip_lines", "delimiter", "header", "sample_rate_hz",
          "invert_output", "x", "y", "z", "output_cols", "axis")
COLUMNS = ["time_s", "temperature_c", "output_g", "applied_g", "run", "power_on"]


@pytest.fixture(autouse=True, scope="module")
def _command_built_once():
    """typer rebuilds the click command from every signature on each call (≈0.25 s); build it once
    for this module's thousands of in-process calls (the command and its behaviour are the same)."""
    import typer.main

    built = {}
    original = typer.main.get_command

    def get_command(app):
        if id(app) not in built:
            built[id(app)] = original(app)
        return built[id(app)]

    typer.main.get_command = get_command
    yield
    typer.main.get_command = original


def counted(name: str) -> None:
    """With TWIN_PROPERTY_COUNTS=FILE, one line per example run (the long profile's count, even when a
    run is stopped before hypothesis prints its statistics)."""
    import os

    if os.environ.get("TWIN_PROPERTY_COUNTS"):
        with open(os.environ["TWIN_PROPERTY_COUNTS"], "a") as f:
            f.write(name + "\n")


def run_cli(argv) -> tuple[int, str]:
    code, _, err = run_in_process(argv)
    return code, err


def assert_contract(code: int, err: str) -> None:
    """Exit 0, or exit 2 with exactly one ``twin: error:`` line; never a traceback or an internal error."""
    assert "Traceback" not in err, err
    if code != 0:
        assert code == 2, err
        lines = [ln for ln in err.splitlines() if ln.startswith("twin:")]
        assert len(lines) == 1 and lines[0].startswith("twin: error: "), err


def assert_finite(result) -> None:
    parts = [result] if isinstance(result, (tm.Measurement, tm.ImuLog)) else list(result)
    for p in parts:
        if isinstance(p, tm.Measurement):
            arrays = [p.time_s, p.temperature_c, p.output_g] + ([p.applied_g] if p.applied_known else [])
        else:
            arrays = [p.time_s, p.temperature_c, p.accel_g]
        assert all(np.isfinite(a).all() for a in arrays) and len(p) >= 10


def read_or_one_line(read):
    """``read()``'s result, or ``None`` after a one-line MeasurementError (anything else fails the test)."""
    try:
        return read()
    except tm.MeasurementError as exc:
        assert "\n" not in str(exc) and str(exc).strip()
        return None


# ---- strategies ------------------------------------------------------------------------------------

ODD_VALUES = st.one_of(st.none(), st.booleans(), st.integers(-5, 10), st.floats(allow_nan=True, allow_infinity=True),
                       st.sampled_from(["", "x", "C", "K", "F", "f", "g", "mg", "m/s^2", "digits", "ms", "us", "s",
                                        "time_s", "temperature_c", "output_g", "0", "1", "2", ",", ";", "\t", "tab",
                                        "whitespace", "ab[", "maybe", "z"]),
                       st.lists(st.sampled_from(["time_s", "output_g", 0, 1, 2]), max_size=4),
                       st.dictionaries(st.just("k"), st.integers(), max_size=1))
COLUMN_MAPS = st.dictionaries(st.sampled_from(FIELDS + ("bogus",)), ODD_VALUES, max_size=5)

NUMBER_TEXT = st.one_of(
    st.floats(-1e3, 1e3, allow_nan=False).map(lambda v: f"{v:.6g}"),
    st.sampled_from(["nan", "NaN", "inf", "-inf", "", "abc", "1,5", " 3", "1e400", "0x10", "True", "9" * 25, "\"2\"",
                     " \"2\"", " \"1,5\"", "   ", " nan", "2 "]))


@st.composite
def text_logs(draw):
    """A delimited log as bytes and the column map that reads it: mostly plausible, often broken."""
    sep = draw(st.sampled_from([",", ";", "\t", " "]))
    n = draw(st.integers(0, 40))
    header = draw(st.booleans())
    ncol = draw(st.integers(2, 6))
    t0, dt = draw(st.floats(0, 1e4)), draw(st.sampled_from([0.5, 1.0, 10.0]))
    temp0 = draw(st.floats(-30, 60))
    pad = draw(st.sampled_from(["", "", " ", "  "]))  # spaces after each delimiter, as some loggers write
    rows = []
    for i in range(n):
        good = [f"{t0 + i * dt:.6g}", f"{temp0 + 0.3 * i:.4f}", f"{1 + 1e-4 * i:.7f}", "1", "0", "0"][:ncol]
        if draw(st.integers(0, 19)) == 0:  # now and then a broken field or a ragged row
            k = draw(st.integers(0, ncol - 1))
            good[k] = draw(NUMBER_TEXT)
            if draw(st.booleans()):
                good = good[:draw(st.integers(1, ncol + 2))] + ["7"] * draw(st.integers(0, 2))
        rows.append((sep + pad).join(good))
    banner = draw(st.lists(st.sampled_from(["# rig 3", "operator: me", "", "time_s,temp"]), max_size=3))
    lines = banner + ([(sep + pad).join(COLUMNS[:ncol])] if header else []) + rows
    data = ("\n".join(lines) + draw(st.sampled_from(["\n", "", "\r\n"]))).encode()
    if draw(st.integers(0, 9)) == 0:
        at = draw(st.integers(0, max(0, len(data) - 1)))
        data = data[:at] + draw(st.sampled_from([b"\xff", b"\xe9", b"\x00", b"\xc3"])) + data[at:]
    cmap = dict(header=header, skip_lines=len(banner) if draw(st.integers(0, 4)) else draw(st.integers(0, 60)))
    if not header:
        cmap.update(time=0, temperature=1, output=2 if ncol > 2 else 5, applied=None, run=None, power_on=None)
    if draw(st.booleans()):
        cmap["delimiter"] = {"\t": "tab", " ": "whitespace"}.get(sep, sep)
    cmap["temperature_unit"] = draw(st.sampled_from(["C", "C", "C", "K", "F"]))
    return data, cmap


def _twin_hdf5(path: Path, draw) -> None:
    import h5py

    n = draw(st.integers(0, 30))
    with h5py.File(path, "w") as f:
        for key, base in (("time_s", np.arange(n) * 1.0), ("temperature/thermometer_c", 20 + 0.5 * np.arange(n)),
                          ("output/output_g", 1 + 1e-4 * np.arange(n)), ("test/applied_g", np.ones(n)),
                          ("test/run_index", np.zeros(n, np.int16)), ("test/power_on", np.zeros(n, bool))):
            kind = draw(st.sampled_from(["ok"] * 12 + ["2d", "text", "short", "nan", "missing", "group", "inf"]))
            if kind == "missing":
                continue
            if kind == "group":
                f.create_group(key)
                continue
            value = {"2d": np.stack([base, base], axis=1), "text": base.astype("S8"), "short": base[: n // 2],
                     "nan": np.where(np.arange(n) == n // 3, np.nan, base.astype(float)),
                     "inf": np.where(np.arange(n) == 0, np.inf, base.astype(float))}.get(kind, base)
            f[key] = value


# ---- reader-level properties (milliseconds per example) ------------------------------------------------

@given(COLUMN_MAPS)
def test_any_column_map_is_accepted_or_one_line(data):
    counted("test_any_column_map_is_accepted_or_one_line")
    with tempfile.TemporaryDirectory() as d:
        path = Path(d) / "map.yaml"
        path.write_text(yaml.safe_dump(data))
        cmap = read_or_one_line(lambda: tm.ColumnMap.from_yaml(path))
        if cmap is None:
            return
        csv = Path(d) / "log.csv"
        csv.write_text("time_s,temperature_c,output_g\n" + "".join(f"{i},{20 + i / 3:.3f},1.0\n" for i in range(30)))
        result = read_or_one_line(lambda: tm.load_measurements([csv], cmap))
        if result is not None:
            assert_finite(result)


@given(text_logs())
def test_any_text_log_reads_finite_or_fails_in_one_line(log):
    counted("test_any_text_log_reads_finite_or_fails_in_one_line")
    data, keys = log
    with tempfile.TemporaryDirectory() as d:
        path = Path(d) / "log.csv"
        path.write_bytes(data)
        cmap = tm.ColumnMap(**keys)
        for skip in (False, True):
            result = read_or_one_line(lambda: tm.load_measurements([path], cmap, skip_bad_rows=skip))
            if result is not None:
                assert_finite(result)
                assert result.bad_rows_skipped == 0 or skip


@given(text_logs(), st.booleans())
def test_fast_path_equals_careful_path(log, skip):
    counted("test_fast_path_equals_careful_path")
    data, keys = log
    with tempfile.TemporaryDirectory() as d:
        path = Path(d) / "log.csv"
        path.write_bytes(data)
        cmap = tm.ColumnMap(**keys)

        def outcome():
            try:
                m = tm.read_table(path, cmap, skip_bad_rows=skip)
            except tm.MeasurementError as exc:
                return str(exc)
            return [m.time_s, m.temperature_c, m.output_g, m.applied_g, m.run_index, m.power_on, m.bad_rows_skipped]

        fast = outcome()
        original = delimited._fast_values
        delimited._fast_values = lambda *a, **k: None
        try:
            careful = outcome()
        finally:
            delimited._fast_values = original
        if isinstance(fast, str) or isinstance(careful, str):
            assert fast == careful
        else:
            assert all(np.array_equal(a, b, equal_nan=True) for a, b in zip(fast[:-1], careful[:-1]))
            assert fast[-1] == careful[-1]


@given(st.data())
def test_any_twin_style_hdf5_reads_finite_or_fails_in_one_line(data):
    counted("test_any_twin_style_hdf5_reads_finite_or_fails_in_one_line")
    with tempfile.TemporaryDirectory() as d:
        path = Path(d) / "run.h5"
        _twin_hdf5(path, data.draw)
        result = read_or_one_line(lambda: tm.load_measurements([path]))
        if result is not None:
            assert_finite(result)


@given(st.data())
def test_three_axis_logs_and_flight_log_bytes_read_finite_or_fail_in_one_line(data):
    counted("test_three_axis_logs_and_flight_log_bytes_read_finite_or_fail_in_one_line")
    from logfixtures import chamber_run, write_dataflash, write_ulog

    kind = data.draw(st.sampled_from(["csv", "ulog", "dataflash", "parquet"]))
    with tempfile.TemporaryDirectory() as d:
        d = Path(d)
        cmap = None
        if kind in ("csv", "parquet"):
            n = data.draw(st.integers(0, 40))
            t = np.arange(n) * 0.5
            if n > 2 and data.draw(st.booleans()):
                t[data.draw(st.integers(1, n - 1))] = t[0]  # two orientations at one instant
            cols = {"t": t, "temp": 20 + 0.2 * np.arange(n), "ax": np.zeros(n), "ay": np.zeros(n), "az": -np.ones(n)}
            if n and data.draw(st.booleans()):
                cols[data.draw(st.sampled_from(sorted(cols)))][data.draw(st.integers(0, n - 1))] = \
                    data.draw(st.sampled_from([np.nan, np.inf, 1e300]))
            cmap = tm.ColumnMap(time="t", temperature="temp", x="ax", y="ay", z="az")
            if kind == "csv":
                path = d / "imu.csv"
                path.write_text("t,temp,ax,ay,az\n" + "".join(",".join(repr(float(c[i])) for c in cols.values()) + "\n"
                                                             for i in range(n)))
            else:
                import pyarrow as pa
                import pyarrow.parquet as pq

                path = d / "imu.parquet"
                pq.write_table(pa.table(cols), path)
        else:
            path = d / ("log.ulg" if kind == "ulog" else "log.bin")
            (write_ulog if kind == "ulog" else write_dataflash)(path, chamber_run(n=60))
            raw = bytearray(path.read_bytes())
            for _ in range(data.draw(st.integers(0, 3))):
                raw[data.draw(st.integers(0, len(raw) - 1))] = data.draw(st.integers(0, 255))
            path.write_bytes(bytes(raw[: data.draw(st.integers(0, len(raw)))]))
        result = read_or_one_line(lambda: tm.read_imu_logs(path, cmap))
        if result is not None:
            for log in result:
                assert np.isfinite(log.time_s).all() and np.isfinite(log.accel_g).all()
                assert np.isfinite(log.temperature_c).all()


# ---- the CLI in process: exit 0 with finite outputs, or exit 2 in one line; writes only its output ------

def _files(folder: Path) -> set[str]:
    return {str(p.relative_to(folder)) for p in folder.rglob("*")}


# a valid example runs the whole diagnosis (≈0.5 s): a third of the profile's budget (20 in "ci")
@settings(suppress_health_check=list(HealthCheck), max_examples=max(20, settings().max_examples // 3))
@given(text_logs(), st.sampled_from([[], ["--skip-bad-rows"], ["--temperature-unit", "F"], ["--applied-g", "unknown"]]))
def test_twin_compare_on_any_text_log(log, extra):
    counted("test_twin_compare_on_any_text_log")
    data, keys = log
    with tempfile.TemporaryDirectory() as d:
        d = Path(d)
        path, cmap_file, out = d / "m.csv", d / "map.yaml", d / "out" / "r.json"
        path.write_bytes(data)
        cmap_file.write_text(yaml.safe_dump({k: v for k, v in keys.items() if k != "temperature_unit"}))
        before = _files(d)
        code, err = run_cli(["compare", SCENARIO, path, "--columns", cmap_file, "--json", out, *extra])
        assert_contract(code, err)
        assert path.read_bytes() == data
        new = _files(d) - before
        if code == 0:
            result = json.loads(out.read_text())
            assert math.isfinite(result["rms_residual_g"]) and math.isfinite(result["noise_floor_g"])
            assert new <= {"out", "out/r.json", "out/ledger.jsonl"}
        else:
            assert new <= {"out"} and not out.exists()


@settings(suppress_health_check=list(HealthCheck))
@given(st.data())
def test_twin_export_on_any_twin_style_hdf5(data):
    counted("test_twin_export_on_any_twin_style_hdf5")
    with tempfile.TemporaryDirectory() as d:
        d = Path(d)
        path, out = d / "run.h5", d / "m.csv"
        _twin_hdf5(path, data.draw)
        before = path.read_bytes()
        code, err = run_cli(["export", path, "-o", out])
        assert_contract(code, err)
        assert path.read_bytes() == before
        if code == 0:
            table = np.loadtxt(out, delimiter=",", skiprows=1, ndmin=2)
            assert np.isfinite(table).all() and table.shape[1] == 6
            assert _files(d) == {"run.h5", "m.csv"}
        else:
            assert _files(d) == {"run.h5"}


@pytest.fixture(scope="module")
def calibration_doc(tmp_path_factory) -> Path:
    folder = tmp_path_factory.mktemp("calprop")
    rng = np.random.default_rng(2)
    t = np.arange(300.0)
    temp = 20 + 30 * np.sin(t / 100) + rng.normal(0, 0.01, t.size)
    log = folder / "tri.csv"
    log.write_text("t,temp,ax,ay,az\n" + "".join(f"{a},{b:.4f},{rng.normal(0, 1e-3):.6f},{rng.normal(0, 1e-3):.6f},"
                                                 f"{-1 + 1e-4 * b + rng.normal(0, 1e-3):.6f}\n" for a, b in zip(t, temp)))
    cal = folder / "cal.json"
    code, err = run_cli(["calibrate", log, "-o", cal, "--time-col", "t", "--temperature-col", "temp", "--x-col", "ax",
                         "--y-col", "ay", "--z-col", "az"])
    assert code == 0, err
    return cal


@settings(suppress_health_check=list(HealthCheck))
@given(n=st.integers(0, 40), broken=st.sampled_from(["none", "nan", "text", "dup", "ragged", "utf8"]),
       applied=st.sampled_from([None, "0,0,-1", "nan,0,1", "1,2", "a,b,c", "inf,0,0"]))
def test_twin_apply_on_any_three_axis_log(calibration_doc, n, broken, applied):
    counted("test_twin_apply_on_any_three_axis_log")
    with tempfile.TemporaryDirectory() as d:
        d = Path(d)
        rows = [f"{i},{20 + 0.5 * i:.2f},0.001,-0.001,-1.0" for i in range(n)]
        if n > 3:
            k = n // 2
            rows[k] = {"none": rows[k], "nan": f"{k},nan,0,0,-1", "text": f"{k},hot,0,0,-1", "dup": rows[k - 1],
                       "ragged": rows[k] + ",9", "utf8": rows[k]}[broken]
        data = ("temperature_c,ax,ay,az\n".replace("temperature_c", "time_s,temperature_c")
                + "\n".join(rows) + "\n").encode()
        if broken == "utf8":
            data += b"\xff\n"
        log, cmap, out = d / "new.csv", d / "map.yaml", d / "comp.csv"
        log.write_bytes(data)
        cmap.write_text("x: ax\ny: ay\nz: az\n")
        argv = ["apply", calibration_doc, log, "-o", out, "--columns", cmap] + (["--applied-g", applied] if applied else [])
        code, err = run_cli(argv)
        assert_contract(code, err)
        if code == 0:
            table = np.loadtxt(out, delimiter=",", skiprows=1, ndmin=2)
            assert np.isfinite(table).all() and len(table) >= 10
            assert _files(d) == {"new.csv", "map.yaml", "comp.csv"}
        else:
            assert _files(d) == {"new.csv", "map.yaml"}


def _paths(node, prefix=()):
    """Every key or index path of a JSON tree, containers included."""
    yield prefix
    items = node.items() if isinstance(node, dict) else enumerate(node) if isinstance(node, list) else ()
    for k, v in items:
        yield from _paths(v, prefix + (k,))


JSON_VALUES = st.one_of(st.none(), st.booleans(), st.integers(-2**70, 2**70), st.text(max_size=8),
                        st.sampled_from([0.0, -1.0, 1e308, -1e-320, 1e45, 2**32, -2**31, 3.5]),
                        st.lists(st.integers(-3, 3), max_size=4), st.dictionaries(st.text(max_size=3), st.none(),
                                                                                 max_size=2))


@settings(suppress_health_check=list(HealthCheck))
@given(data=st.data())
def test_firmware_and_apply_on_any_edited_calibration_document(calibration_doc, data):
    """A hand-edited document — any value replaced or removed — gives a file the firmware loads, or
    exit 2 in one line with nothing written; never an internal error."""
    counted("test_firmware_and_apply_on_any_edited_calibration_document")
    doc = json.loads(calibration_doc.read_text())
    paths = [p for p in _paths(doc) if p]
    for _ in range(data.draw(st.integers(1, 3))):
        path = data.draw(st.sampled_from(paths))
        parent = doc
        try:
            for k in path[:-1]:
                parent = parent[k]
            if data.draw(st.booleans()) and isinstance(parent, dict):
                parent.pop(path[-1], None)
            else:
                parent[path[-1]] = data.draw(JSON_VALUES)
        except (KeyError, IndexError, TypeError):  # an earlier edit removed or replaced this branch
            continue
    fmt = data.draw(st.sampled_from(["px4", "ardupilot", "c", "json", "apply"]))
    with tempfile.TemporaryDirectory() as d:
        d = Path(d)
        cal = d / "cal.json"
        cal.write_text(json.dumps(doc))
        if fmt == "apply":
            (d / "log.csv").write_text("t,temp,ax,ay,az\n" + "".join(f"{i},{20 + 0.3 * i},0,0,-1\n" for i in range(40)))
            (d / "map.yaml").write_text("time: t\ntemperature: temp\nx: ax\ny: ay\nz: az\n")
            argv, out = ["apply", cal, d / "log.csv", "--columns", d / "map.yaml", "-o", d / "out.csv"], d / "out.csv"
        else:
            out = d / "out.txt"
            argv = ["firmware", cal, "--format", fmt, "-o", out] + (["--device-id", "123"] if fmt == "px4" else [])
        code, err = run_cli(argv)
        assert_contract(code, err)
        assert out.exists() == (code == 0)
