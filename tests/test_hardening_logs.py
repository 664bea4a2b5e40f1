"""Bad measurement input never crashes, hangs or overwrites (issue 14, the log side), and the
chunked fast reader returns exactly what the careful reader returns.

The adversarial corpus (tests/adversarial/logs, listed in its expect.yaml; its binary files written
per test process by conftest.log_corpus) runs through the CLI in process: each file ends in exit 0, or exit 2 with one ``twin: error:`` line naming the file (and
line or key) and what was expected, and writes nothing on failure.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import yaml

from conftest import ROOT, log_corpus, record_results
from conftest import run_in_process as run
from logfixtures import write_canonical
import twin.measurement as tm
from twin.measurement import delimited

CORPUS = log_corpus()  # text files committed, binary ones written per test process
EXPECT = yaml.safe_load((ROOT / "tests" / "adversarial" / "logs" / "expect.yaml").read_text())
SCENARIO = ROOT / "scenarios" / "paper_iis328dq.yaml"
TRI = ["--time-col", "t", "--temperature-col", "temp", "--x-col", "ax", "--y-col", "ay", "--z-col", "az"]




def assert_one_line_error(code: int, err: str, fragment: str | None = None) -> None:
    assert code == 2, err
    assert err.count("\n") == 1 and err.startswith("twin: error: ") and "Traceback" not in err, err
    if fragment is not None:
        assert fragment in err, err


def test_every_corpus_file_is_listed_and_every_listed_file_exists():
    assert {p.name for p in CORPUS.iterdir()} == set(EXPECT)
    committed = ROOT / "tests" / "adversarial" / "logs"
    for path in committed.iterdir():  # binary files are written by the tests, never committed
        assert b"\0" not in path.read_bytes(), path.name


def _argv(name: str, out: Path) -> list:
    extra = EXPECT[name].get("args", [])
    if name.startswith("map_"):
        return ["compare", SCENARIO, CORPUS / "valid.csv", "--columns", CORPUS / name, "--json", out]
    if name.startswith("tri_") or Path(name).suffix in (".ulg", ".bin"):
        return ["calibrate", CORPUS / name, "-o", out, *(TRI if name.startswith("tri_") else []), *extra]
    return ["compare", SCENARIO, CORPUS / name, "--json", out, *extra]


@pytest.mark.parametrize("name", sorted(EXPECT))
def test_corpus_file_gives_exit_0_or_one_line_naming_it(name, tmp_path):
    before = {p.name: p.read_bytes() for p in CORPUS.iterdir()}
    out = tmp_path / "result.json"
    code, _, err = run(_argv(name, out))
    expected = EXPECT[name]["error"]
    if expected is None:
        assert code == 0, err
        assert out.is_file()
    else:
        assert_one_line_error(code, err, expected)
        assert not out.exists()
    left = {p.name for p in tmp_path.iterdir()}  # compare keeps its ledger beside --json; no temporary left
    assert left <= ({"result.json", "ledger.jsonl"} if expected is None else set()), left
    assert {p.name: p.read_bytes() for p in CORPUS.iterdir()} == before  # the inputs are untouched
    if name.endswith(".h5"):
        code, _, err = run(["export", CORPUS / name, "-o", tmp_path / "e.csv"])
        assert_one_line_error(code, err, expected)
        assert not (tmp_path / "e.csv").exists()


def test_fahrenheit_and_kelvin_convert_to_the_same_celsius():
    # (F − 32)·5/9 and K − 273.15 are exact definitions: the converted logs agree to rounding of the
    # two decimals printed (0.005 °C → 0.0028 K-equivalent after 5/9, within 1e-9 of the definition)
    f = tm.read_table(CORPUS / "fahrenheit.csv", tm.ColumnMap(temperature_unit="F"))
    assert np.allclose(f.temperature_c, (20 + 0.5 * np.arange(30)), atol=1e-9)
    k = tm.read_table(CORPUS / "kelvin_labelled.csv", tm.ColumnMap(temperature_unit="k"))
    assert np.allclose(k.temperature_c, 20 + 0.5 * np.arange(30), atol=1e-9)


def test_skip_bad_rows_drops_and_counts_the_non_finite_row():
    m = tm.read_table(CORPUS / "nan_time_skipped.csv", skip_bad_rows=True)
    assert len(m) == 29 and m.bad_rows_skipped == 1
    assert np.isfinite(m.time_s).all()


# ---- outputs never replace an input; -o and --json are two files ---------------------------------

@pytest.fixture(scope="module")
def calibration(tmp_path_factory) -> tuple[Path, Path]:
    """A 3-axis log with a 30 °C sweep and its calibration document (one calibrate run)."""
    folder = tmp_path_factory.mktemp("cal")
    rng = np.random.default_rng(1)
    t = np.arange(300.0)
    temp = 20 + 30 * np.sin(t / 100) + rng.normal(0, 0.01, t.size)
    acc = rng.normal(0, 1e-3, (t.size, 3)) + [0, 0, -1] + np.outer(1e-4 * temp, [0, 0, 1])
    log = folder / "tri.csv"
    log.write_text("t,temp,ax,ay,az\n" + "".join(f"{a:.1f},{b:.4f},{c:.6f},{d:.6f},{e:.6f}\n"
                                                 for a, b, (c, d, e) in zip(t, temp, acc)))
    cal = folder / "cal.json"
    code, _, err = run(["calibrate", log, "-o", cal, *TRI])
    assert code == 0, err
    return log, cal


@pytest.mark.parametrize("command", ["calibrate", "firmware", "apply"])
def test_json_over_an_input_is_refused_and_the_input_kept(command, calibration, tmp_path):
    log, cal = calibration
    argv = {"calibrate": ["calibrate", log, "-o", tmp_path / "c.json", *TRI, "--json", log],
            "firmware": ["firmware", cal, "--format", "px4", "-o", tmp_path / "x.params", "--json", cal],
            "apply": ["apply", cal, log, "-o", tmp_path / "a.csv", "--json", log]}[command]
    before = log.read_bytes(), cal.read_bytes()
    code, _, err = run(argv)
    assert_one_line_error(code, err, "the output would overwrite an input")
    assert (log.read_bytes(), cal.read_bytes()) == before
    assert list(tmp_path.iterdir()) == []


def test_output_and_json_naming_one_file_is_refused(calibration, tmp_path):
    _, cal = calibration
    out = tmp_path / "x.params"
    code, _, err = run(["firmware", cal, "--format", "px4", "-o", out, "--json", out])
    assert_one_line_error(code, err, "--json and -o name the same file")
    assert not out.exists()


def test_an_output_that_is_a_folder_is_refused(calibration, tmp_path):
    log, cal = calibration
    code, _, err = run(["apply", cal, log, "-o", tmp_path])
    assert_one_line_error(code, err, "is a directory")


def test_compare_json_over_its_measurement_is_refused(tmp_path):
    m = tmp_path / "m.csv"
    m.write_bytes((CORPUS / "valid.csv").read_bytes())
    code, _, err = run(["compare", SCENARIO, m, "--json", m])
    assert_one_line_error(code, err, "the output would overwrite an input")
    assert m.read_bytes() == (CORPUS / "valid.csv").read_bytes()


def test_export_over_its_dataset_is_refused(tmp_path):
    h5 = tmp_path / "d.h5"
    from logfixtures import write_twin_hdf5

    write_twin_hdf5(h5)
    before = h5.read_bytes()
    code, _, err = run(["export", h5, "-o", h5])
    assert_one_line_error(code, err, "overwrite an input")
    assert h5.read_bytes() == before


# ---- the fast path returns exactly what the careful path returns ---------------------------------

def _text(content: str):
    def write(path: Path) -> Path:
        path.write_text(content)
        return path
    return write


def _careful(monkeypatch, read):
    with monkeypatch.context() as m:
        m.setattr(delimited, "_fast_values", lambda *a, **k: None)
        return read()


CASES = {
    "canonical": (lambda p: write_canonical(p), {}),
    "banner, semicolons, no header, indices": (
        _text("# rig 4\n# 2024\n" + "".join(f"{i * 10};{25 + np.sin(i / 9):.5f};{0.98 + 1e-5 * i:.8f}\n"
                                             for i in range(60))),
        dict(time=0, temperature=1, output=2, header=False, skip_lines=2, time_unit="ms")),
    "tabs, kelvin, m/s^2, spaces": (
        _text("t\tT\ta\n" + "".join(f"{i}\t {298.15 + i / 7:.3f}\t{9.80665 + i * 1e-4:.6f}\n" for i in range(60))),
        dict(time="t", temperature="T", output="a", temperature_unit="K", output_unit="m/s^2")),
    # spaces after the commas are left to the number parser on the fast path; a quote after a space
    # splits fields differently without skipping them, so there the fast path skips them as the careful one
    "spaces after commas": (
        _text("time_s, temperature_c, output_g\n" + "".join(f"{i},  {25 + i / 7:.3f}, {0.98 + i * 1e-5:.8f}\n"
                                                           for i in range(60))), {}),
    "a quoted number after a space": (
        _text("time_s, temperature_c, output_g\n" + "".join(f"{i}, \"{25 + i / 7:.3f}\", {0.98 + i * 1e-5:.8f}\n"
                                                           for i in range(60))), {}),
}


@pytest.mark.parametrize("case", sorted(CASES))
def test_fast_and_careful_paths_agree_exactly(case, tmp_path, monkeypatch):
    write, keys = CASES[case]
    path = write(tmp_path / "log.csv")
    cmap = tm.ColumnMap(**keys)
    fast = tm.read_table(path, cmap)
    careful = _careful(monkeypatch, lambda: tm.read_table(path, cmap))
    for attr in ("time_s", "temperature_c", "output_g", "applied_g", "run_index", "power_on"):
        assert np.array_equal(getattr(fast, attr), getattr(careful, attr), equal_nan=True), attr


def test_clean_files_take_the_fast_path_and_anything_else_the_careful_one(monkeypatch):
    taken = record_results(monkeypatch, delimited, "_fast_values")
    assert len(tm.read_table(CORPUS / "valid.csv")) == 30 and taken[-1] is not None
    for name in ("text_in_number.csv", "ragged_row.csv", "non_utf8_row.csv"):
        with pytest.raises(tm.MeasurementError):
            tm.read_table(CORPUS / name)
        assert taken[-1] is None, name


def test_a_ragged_row_stays_an_error_on_the_fast_path():
    with pytest.raises(tm.MeasurementError, match="Expected 3 fields in line 7, saw 5"):
        tm.read_table(CORPUS / "ragged_row.csv")


# ---- Parquet ------------------------------------------------------------------------------------

def test_parquet_reads_like_the_same_csv(tmp_path):
    import pyarrow.csv
    import pyarrow.parquet as pq

    csv = write_canonical(tmp_path / "c.csv")
    pq.write_table(pyarrow.csv.read_csv(csv), tmp_path / "c.parquet", row_group_size=64)
    a, b = tm.load_measurements([csv]), tm.load_measurements([tmp_path / "c.parquet"])
    for attr in ("time_s", "temperature_c", "output_g", "applied_g", "run_index", "power_on"):
        assert np.array_equal(getattr(a, attr), getattr(b, attr)), attr


def test_parquet_three_axis_through_a_column_map(tmp_path):
    import pyarrow as pa
    import pyarrow.parquet as pq

    n = 200
    t = np.arange(n) * 1e3  # ms
    table = pa.table({"ts": t, "temp": 20 + 0.1 * np.arange(n), "ax": np.zeros(n), "ay": np.zeros(n),
                      "az": np.full(n, -9.80665), "note": ["x"] * n})
    pq.write_table(table, tmp_path / "imu.parquet")
    cmap = tm.ColumnMap(time="ts", temperature="temp", x="ax", y="ay", z="az", time_unit="ms", output_unit="m/s^2")
    (log,) = tm.read_imu_logs(tmp_path / "imu.parquet", cmap)
    assert np.allclose(log.accel_g[:, 2], -1.0) and log.time_s[-1] == pytest.approx(n - 1)


# ---- plugins, options -----------------------------------------------------------------------------

def test_a_reader_plugin_that_raises_on_import_is_one_line(tmp_path):
    plugin = tmp_path / "broken_reader.py"
    plugin.write_text("raise RuntimeError('driver missing')\n")
    with pytest.raises(tm.MeasurementError) as exc:
        tm.load_reader_plugin(plugin)
    assert "\n" not in str(exc.value) and "driver missing" in str(exc.value)


@pytest.mark.parametrize("keys, fragment", [
    (dict(header="maybe"), "header: got 'maybe', expected true or false"),
    (dict(temperature_unit="F", output_scale=float("inf")), "output_scale: got inf"),
    (dict(skip_lines=True), "skip_lines: got True"),
    (dict(output_cols=["a", "b"]), "output_cols"),
    (dict(delimiter="\n"), "delimiter"),
    (dict(axis="w"), "axis: got 'w'"),
])
def test_column_map_values_of_the_wrong_type_are_refused_before_reading(keys, fragment):
    with pytest.raises(tm.MeasurementError, match=None) as exc:
        tm.read_table(CORPUS / "valid.csv", tm.ColumnMap(**keys))
    assert fragment in str(exc.value) and "\n" not in str(exc.value)


def test_a_ulog_whose_first_message_size_is_corrupt_is_one_line(tmp_path):
    # found by the long property profile: pyulog seeks before the file's start and raises OSError
    from logfixtures import chamber_run, write_ulog

    path = tmp_path / "log.ulg"
    write_ulog(path, chamber_run(n=60))
    raw = bytearray(path.read_bytes())
    raw[16] = 0  # the first message's size, just after the 16-byte file header
    path.write_bytes(bytes(raw))
    with pytest.raises(tm.MeasurementError) as exc:
        tm.read_imu_logs(path)
    assert "\n" not in str(exc.value) and "not a readable ULog file" in str(exc.value)


def test_a_negative_zero_time_reads_the_same_message_on_both_paths(tmp_path, monkeypatch):
    # found by the long property profile: the fast parser kept −0.0, the careful one 0.0 ("-0 s" vs "0 s")
    rows = [f"{i},{0.3 * i:.4f},{1 + 1e-4 * i:.7f}\n" for i in range(15)]
    rows[8] = "-0,2.4000,1.0008000\n"
    path = tmp_path / "log.csv"
    path.write_text("".join(rows))
    cmap = tm.ColumnMap(time=0, temperature=1, output=2, header=False)
    messages = []
    for read in (lambda: tm.read_table(path, cmap), lambda: _careful(monkeypatch, lambda: tm.read_table(path, cmap))):
        with pytest.raises(tm.MeasurementError) as exc:
            read()
        messages.append(str(exc.value))
    assert messages[0] == messages[1] and "(7 s then 0 s)" in messages[0]


@pytest.mark.parametrize("n", [20, 21, 22, 23])
def test_the_unit_checks_decide_exactly_as_the_median_does(n):
    """The kelvin and |output| checks count values past the level before taking a median; the
    decision must be the median's, the middle values straddling the level included."""
    from twin.measurement.core import check

    rng = np.random.default_rng(n)
    decided = set()
    for _ in range(300):
        above = int(rng.integers(n // 2 - 2, n // 2 + 3))  # around the middle, where the shortcut could err
        temp = np.where(np.arange(n) < above, rng.choice([150.5, 170.0, 199.0], n), rng.choice([150.0, 149.0, 25.0], n))
        out = np.where(rng.permutation(n) < above, rng.choice([-4.5, 4.0 + 1e-9, 6.0], n), rng.choice([4.0, -4.0, 1.0], n))
        for values, field, level, expected_error in ((temp, "temperature_c", 150, "kelvin"), (out, "output_g", 4.0, "accelerometer")):
            m = tm.Measurement(np.arange(n, dtype=float), np.full(n, 25.0), np.ones(n), np.ones(n),
                               np.zeros(n, np.int16), np.zeros(n, bool), True, ["x"], 0, [])
            setattr(m, field, values)
            expect = float(np.median(np.abs(values) if field == "output_g" else values)) > level
            try:
                check(m, "x")
                raised = False
            except tm.MeasurementError as exc:
                assert expected_error in str(exc)
                raised = True
            assert raised == expect, (field, values)
            decided.add((field, expect))
    assert len(decided) == 4  # both decisions seen for both checks
