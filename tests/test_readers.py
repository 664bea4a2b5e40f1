"""The reader registry: every registered format conforms, one file adds a format, suffixes and
sniffing dispatch, and delimited logs with three output columns read as an ImuLog."""

import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from conftest import ROOT, SHARED, log_corpus, record_results
from logfixtures import FIXTURES, G_MS2, chamber_run, write_canonical
import twin.measurement as tm
from twin.errors import TwinError



def write_parquet(path: Path) -> Path:
    """The canonical chamber run as a Parquet table (its place is logfixtures.FIXTURES, which this module
    may not edit: added here so every registered reader keeps a fixture)."""
    import pyarrow.csv
    import pyarrow.parquet

    pyarrow.parquet.write_table(pyarrow.csv.read_csv(write_canonical(path.with_suffix(".csv"))), path, row_group_size=150)
    return path


FIXTURES.setdefault("parquet", ("chamber.parquet", write_parquet))
TOFU = SHARED / "data" / "real" / "tofupilot_imu_thermal" / "imu_raw_data.tsv"
TOFU_MAP = dict(time="timestamp", temperature="imu.temperature", time_unit="us", output_unit="m/s^2")


def _measurements(result) -> list:
    """A reader's result as single-axis measurements (every axis of every IMU)."""
    if isinstance(result, tm.Measurement):
        return [result]
    logs = [result] if isinstance(result, tm.ImuLog) else result
    return [g.axis(a) for g in logs for a in g.axes]


@pytest.mark.parametrize("name", sorted(tm.readers()))
def test_every_registered_reader_conforms(name, tmp_path):
    reader = tm.readers()[name]
    assert reader.name == name and reader.suffixes and all(s.startswith(".") for s in reader.suffixes)
    assert callable(reader.read) and (reader.sniff is None or callable(reader.sniff))
    assert name in FIXTURES, f"reader {name!r} has no fixture in tests/logfixtures.py FIXTURES"
    filename, write = FIXTURES[name]
    path = write(tmp_path / filename)
    assert path.suffix in reader.suffixes and tm.find_reader(path) is reader
    parts = _measurements(reader.read(path, tm.ReadOptions()))
    assert parts
    for m in parts:
        assert isinstance(m, tm.Measurement) and len(m) > 10
        tm.check(m, str(path))


def test_each_fixture_is_sniffed_by_its_own_reader_only(tmp_path):
    for name, (filename, write) in FIXTURES.items():
        path = write(tmp_path / filename)
        sniffed = {r.name for r in tm.readers().values() if r.sniff is not None and r.sniff(path)}
        assert sniffed == {name}, (filename, sniffed)


PLUGIN = '''
"""A reader for 'kv' logs: one sample a line, ``t=..;temp=..;acc=..`` (s, °C, g)."""
from pathlib import Path

import numpy as np

from twin.measurement import Measurement, check, register_reader


def read(path, options):
    rows = [dict(kv.split("=") for kv in line.split(";")) for line in Path(path).read_text().split()]
    t, temp, acc = (np.array([float(r[k]) for r in rows]) for k in ("t", "temp", "acc"))
    n = t.size
    known = options.applied_g is not None
    m = Measurement(t, temp, acc, np.full(n, options.applied_g if known else np.nan), np.zeros(n, np.int16),
                    np.zeros(n, bool), known, [str(path)])
    check(m, str(path))
    return m


register_reader("kv", [".kv"], read, sniff=lambda p: Path(p).read_bytes().startswith(b"t="))
'''


@pytest.fixture
def kv_files(tmp_path):
    plugin = tmp_path / "kvreader.py"
    plugin.write_text(PLUGIN)
    data = tmp_path / "run1.kv"
    data.write_text("".join(f"t={k};temp={20 + 0.1 * k};acc={1 + 1e-4 * k}\n" for k in range(30)))
    yield plugin, data
    tm.unregister_reader("kv")


def test_one_new_file_adds_a_format_end_to_end(kv_files):
    plugin, data = kv_files
    assert tm.find_reader(data).name == "delimited"  # before the plugin: text, so the catch-all tries it
    added = tm.load_reader_plugin(plugin)
    assert [r.name for r in added] == ["kv"] and "kv" in tm.readers()
    m = tm.load_measurements([data, data], applied_g=1.0)
    assert len(m) == 60 and m.runs == 2 and m.applied_known
    np.testing.assert_allclose(m.output_g[:30], 1 + 1e-4 * np.arange(30))
    copy = data.with_suffix(".log2")  # an unclaimed suffix: found by the plugin's sniffer
    copy.write_bytes(data.read_bytes())
    assert tm.find_reader(copy).name == "kv"


def test_reader_plugin_by_module_name(kv_files, monkeypatch):
    plugin, data = kv_files
    monkeypatch.syspath_prepend(str(plugin.parent))
    monkeypatch.delitem(sys.modules, "kvreader", raising=False)
    assert [r.name for r in tm.load_reader_plugin("kvreader")] == ["kv"]
    assert len(tm.load_measurements([data])) == 30


@pytest.mark.parametrize("source,fragment", [
    ("x = 1\n", "registered no reader"),
    ("raise RuntimeError('boom')\n", "RuntimeError: boom"),
])
def test_bad_reader_plugins_fail_in_one_line(tmp_path, source, fragment):
    plugin = tmp_path / f"bad_{abs(hash(source))}.py"
    plugin.write_text(source)
    with pytest.raises(tm.MeasurementError) as exc:
        tm.load_reader_plugin(plugin)
    assert fragment in str(exc.value) and "\n" not in str(exc.value)


def test_register_reader_validates_its_arguments():
    with pytest.raises(tm.MeasurementError, match="must start with '.'"):
        tm.register_reader("nodot", ["csv"], lambda p, o: None)
    with pytest.raises(tm.MeasurementError, match="callables"):
        tm.register_reader("notcallable", [".q"], "read")
    assert "nodot" not in tm.readers() and "notcallable" not in tm.readers()


def test_a_suffix_claimed_twice_is_decided_by_sniffing(tmp_path):
    first = tm.register_reader("amb_a", [".amb"], lambda p, o: "a", sniff=lambda p: Path(p).read_bytes()[:1] == b"A")
    second = tm.register_reader("amb_b", [".amb"], lambda p, o: "b", sniff=lambda p: Path(p).read_bytes()[:1] == b"B")
    try:
        for content, expected in ((b"B...", second), (b"A...", first), (b"C...", first)):
            (tmp_path / "f.amb").write_bytes(content)
            assert tm.find_reader(tmp_path / "f.amb") is expected
    finally:
        tm.unregister_reader("amb_a")
        tm.unregister_reader("amb_b")


def test_unknown_format_names_the_file_and_the_known_formats(tmp_path):
    f = tmp_path / "blob.xyz"
    f.write_bytes(bytes(range(256)) * 4)
    with pytest.raises(TwinError) as exc:
        tm.load_measurements([f])
    msg = str(exc.value)
    assert str(f) in msg and "\n" not in msg
    assert all(name in msg for name in tm.readers()) and ".ulg" in msg and ".bin" in msg


def test_text_with_an_unclaimed_suffix_still_reads_as_delimited(tmp_path):
    f = write_canonical(tmp_path / "chamber.export")
    assert tm.find_reader(f).name == "delimited"
    assert len(tm.load_measurements([f])) == 400
    with pytest.raises(tm.MeasurementError, match="not found"):
        tm.load_measurements([tmp_path / "missing.export"])


def test_empty_csv_is_a_one_line_error(tmp_path):
    f = tmp_path / "empty.csv"
    f.write_text("")
    with pytest.raises(tm.MeasurementError, match="empty file"):
        tm.load_measurements([f])


# ---- delimited logs with three output columns -----------------------------------------------

def _three_axis_csv(path: Path) -> Path:
    imu = chamber_run()[2]
    t = (imu.time_us - imu.time_us[0]) * 1e-3
    rows = [f"{a:.0f},{b:.5f},{x:.6f},{y:.6f},{z:.6f}" for a, b, (x, y, z) in zip(t, imu.temperature_c, imu.accel_ms2)]
    path.write_text("t_ms,temp,ax,ay,az\n" + "\n".join(rows) + "\n")
    return path


def test_three_output_columns_give_an_imu_log(tmp_path):
    f = _three_axis_csv(tmp_path / "imu.csv")
    base = dict(time="t_ms", temperature="temp", time_unit="ms", output_unit="m/s^2")
    [by_keys] = tm.read_imu_logs(f, tm.ColumnMap(**base, x="ax", y="ay", z="az"))
    [by_list] = tm.read_imu_logs(f, tm.ColumnMap(**base, output_cols=["ax", "ay", "az"]))
    np.testing.assert_array_equal(by_keys.accel_g, by_list.accel_g)
    assert by_keys.accel_g.shape == (400, 3) and by_keys.axes == ("x", "y", "z")
    np.testing.assert_allclose(by_keys.accel_g[:, 2].mean(), -1.0, atol=0.01)
    m = tm.load_measurements([f], tm.ColumnMap(**base, x="ax", y="ay", z="az", axis="y"), applied_g="unknown")
    np.testing.assert_array_equal(m.output_g, by_keys.accel_g[:, 1])
    assert not m.applied_known


def test_three_axis_column_map_from_yaml(tmp_path):
    f = _three_axis_csv(tmp_path / "imu.csv")
    cmap = tmp_path / "map.yaml"
    cmap.write_text("time: t_ms\ntime_unit: ms\ntemperature: temp\noutput_unit: m/s^2\nx: ax\ny: ay\nz: az\n")
    [log] = tm.read_imu_logs(f, tm.ColumnMap.from_yaml(cmap))
    assert len(log) == 400


@pytest.mark.parametrize("keys,fragment", [
    (dict(x="ax", y="ay"), "sets x, y but not z"),
    (dict(output_cols=["ax", "ay"]), "output_cols lists 2"),
    (dict(x="ax", y="ay", z="azz"), "no z output column 'azz'; did you mean 'az'?"),
])
def test_bad_three_axis_maps_fail_in_one_line(tmp_path, keys, fragment):
    f = _three_axis_csv(tmp_path / "imu.csv")
    with pytest.raises(tm.MeasurementError) as exc:
        tm.read_imu_logs(f, tm.ColumnMap(time="t_ms", temperature="temp", time_unit="ms", output_unit="m/s^2", **keys))
    assert fragment in str(exc.value) and "\n" not in str(exc.value)


def test_a_single_axis_file_is_not_an_imu_log(tmp_path):
    with pytest.raises(tm.MeasurementError, match="single-axis"):
        tm.read_imu_logs(write_canonical(tmp_path / "c.csv"))


@pytest.mark.skipif(not TOFU.is_file(), reason="shared real data not present")
def test_real_tofupilot_log_reads_as_one_three_axis_imu():
    [log] = tm.read_imu_logs(TOFU, tm.ColumnMap(**TOFU_MAP, x="imu.acc.x", y="imu.acc.y", z="imu.acc.z"))
    assert len(log) == 8400 and log.accel_g.shape == (8400, 3)
    assert 4200 < log.time_s[-1] < 4300  # µs timestamps: about 71 min
    assert log.temperature_c.min() == pytest.approx(-17.6, abs=0.1)
    assert log.temperature_c.max() == pytest.approx(74.0, abs=0.1)
    z = log.accel_g[:, 2]
    assert -9.8 / G_MS2 < z.min() and z.max() < -9.0 / G_MS2  # m/s² read as g
    assert 0.06 < np.ptp(z) < 0.09  # the z drift, about 73 mg peak to peak
    ok, reason = tm.usable_for_calibration(log)
    assert ok, reason


def test_importing_measurements_loads_no_flight_log_library():
    code = "import sys, twin.measurement; print(sorted(m for m in ('pyulog', 'pymavlink') if m in sys.modules))"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True, cwd=ROOT).stdout
    assert out.strip() == "[]"


# ---- large delimited logs: read in chunks into the final arrays ---------------------------------

CORPUS = log_corpus()  # text files committed, binary ones written per test process
ARRAYS = ("time_s", "temperature_c", "output_g", "applied_g", "run_index", "power_on")


def _outcome(read):
    """A reader's arrays and flags, or its error message."""
    try:
        m = read()
    except tm.MeasurementError as exc:
        return str(exc)
    return [getattr(m, a) for a in ARRAYS] + [m.applied_known, m.bad_rows_skipped, m.notes]


def _same(a, b) -> bool:
    if isinstance(a, str) or isinstance(b, str):
        return a == b
    return all(np.array_equal(x, y, equal_nan=True) and x.dtype == y.dtype for x, y in zip(a[:6], b[:6])) \
        and a[6:] == b[6:]


@pytest.fixture
def chunked_reader(monkeypatch):
    """Every file counts as large, in chunks of 7 rows, from an estimate of 5 rows (so the arrays grow)."""
    from twin.measurement import chunked, delimited

    taken = record_results(monkeypatch, chunked, "measurement_from_chunks")

    def force(on: bool):
        if on:
            monkeypatch.setenv(chunked.LARGE_FILE_ENV, "0")
        else:
            monkeypatch.delenv(chunked.LARGE_FILE_ENV, raising=False)

    monkeypatch.setattr(chunked, "CHUNK_ROWS", 7)
    monkeypatch.setattr(chunked, "estimated_rows", lambda *a: 5)
    assert delimited.chunked is chunked
    return force, taken


def _written(path, text: str):
    path.write_text(text)
    return path


CHUNK_CASES = {
    "canonical": (lambda p: write_canonical(p), {}, {}),
    "banner, semicolons, no header, ms": (
        lambda p: _written(p, "# rig 4\n# 2024\n" + "".join(f"{i * 10};{25 + np.sin(i / 9):.5f};{0.98 + 1e-5 * i:.8f}\n"
                                                          for i in range(60))),
        dict(time=0, temperature=1, output=2, header=False, skip_lines=2, time_unit="ms"), dict(applied_g=1.0)),
    "tabs, kelvin, m/s^2, inverted, scaled": (
        lambda p: _written(p, "t\tT\ta\trun\n" + "".join(f"{i}\t {298.15 + i / 7:.3f}\t{9.80665 + i * 1e-4:.6f}\t"
                                                       f"{i // 25}\n" for i in range(60))),
        dict(time="t", temperature="T", output="a", run="run", temperature_unit="K", output_unit="m/s^2",
             invert_output=True, output_scale=2.0), {}),
    "no time column, fahrenheit, mg, power flags": (
        lambda p: _written(p, "temp_f,acc_mg,on\n" + "".join(f"{77 + i / 3:.2f},{1000 + i:.1f},{int(i % 20 == 0)}\n"
                                                          for i in range(45))),
        dict(time=None, sample_rate_hz=4.0, temperature="temp_f", output="acc_mg", power_on="on",
             temperature_unit="F", output_unit="mg"), dict(applied_g=None)),
}


@pytest.mark.parametrize("case", sorted(CHUNK_CASES))
def test_large_file_path_gives_the_in_memory_arrays_bit_for_bit(case, tmp_path, chunked_reader):
    force, taken = chunked_reader
    write, keys, options = CHUNK_CASES[case]
    path = write(tmp_path / "log.csv")
    read = lambda: tm.read_table(path, tm.ColumnMap(**keys), **options)  # noqa: E731
    force(False)
    in_memory = _outcome(read)
    assert not taken and not isinstance(in_memory, str)
    force(True)
    chunks = _outcome(read)
    assert taken and taken[-1] is not None  # the chunked path read it, in several chunks
    assert _same(chunks, in_memory)


@pytest.mark.parametrize("banner, eol, cut", [("", "\n", True), ("", "\r\n", True), ("# rig 4\n", "\n", True),
                                               ('# rig 4, "bay 2"\n', "\n", False)])
@pytest.mark.parametrize("pad", ["", " "])  # a space after each comma: left to the number parser in the pieces
def test_large_file_pieces_parsed_on_threads_give_the_whole_file(banner, eol, cut, pad, tmp_path, chunked_reader,
                                                                 monkeypatch):
    """Cut into pieces of whole lines (about 7 rows each) and parsed on two threads, a log gives the
    in-memory arrays bit for bit, blank lines at its end included; a quote in the banner (the
    parser's lines may not be ours) sends it to one parser reading on."""
    from twin.measurement import pieces as pc

    force, taken = chunked_reader
    pieces = []

    def spy(path, head, start, parse, piece_bytes, real=pc.parsed_pieces):
        pieces.append(piece_bytes)
        return real(path, head, start, parse, piece_bytes)

    monkeypatch.setattr(pc, "parsed_pieces", spy)
    monkeypatch.setattr(pc, "parse_threads", lambda: 2)  # two threads on any runner
    rows = [f"{i * 0.01:.2f},{20 + np.sin(i / 7):.4f},{1 + i * 1e-6:.7f},1,{i // 80},{int(i % 50 == 0)}"
            for i in range(200)]
    rows = [row.replace(",", "," + pad) for row in rows]
    path = tmp_path / "log.csv"
    path.write_bytes((banner + "time_s,temperature_c,output_g,applied_g,run,power_on\n" + "\n".join(rows)
                      + "\n\n\n").replace("\n", eol).encode())
    read = lambda: tm.read_table(path, tm.ColumnMap(skip_lines=banner.count("\n")))  # noqa: E731
    force(False)
    in_memory = _outcome(read)
    force(True)
    assert _same(_outcome(read), in_memory) and taken[-1] is not None
    assert bool(pieces) == cut
    if cut:
        assert path.stat().st_size / pieces[-1] > 20  # many pieces


@pytest.mark.parametrize("name", sorted(p.name for p in CORPUS.glob("*.csv")))
@pytest.mark.parametrize("skip", [False, True])
def test_large_file_path_gives_the_same_answer_on_every_bad_log(name, skip, chunked_reader):
    force, _ = chunked_reader
    read = lambda: tm.read_table(CORPUS / name, skip_bad_rows=skip)  # noqa: E731
    force(False)
    before = _outcome(read)
    force(True)
    assert _same(_outcome(read), before)


def test_a_broken_row_in_a_large_file_names_its_line_in_one_line(tmp_path, chunked_reader):
    force, taken = chunked_reader
    rows = [f"{i * 0.01:.2f},{20 + i * 1e-3:.4f},{1 + i * 1e-6:.7f},1,0,{int(i == 0)}" for i in range(200)]
    body = "time_s,temperature_c,output_g,applied_g,run,power_on\n"
    force(True)
    for broken, fragment in (("1.50,20.15,1.0001,1,0,0,9", "Expected 6 fields in line 152, saw 7"),
                             ("1.50,20.15,1.0001,1,0", "line(s) 152"), ("1.50,20.15,abc,1,0,0", "line(s) 152"),
                             ("1.50,20.15,,1,0,0", "line(s) 152"), ("1.50,20.15,1.0001,1,0.5,0", "about line 152"),
                             ("1.49,20.15,1.0001,1,0,0", "time is not increasing at row 151")):
        path = tmp_path / "week.csv"
        path.write_text(body + "\n".join(rows[:150] + [broken] + rows[151:]) + "\n")
        with pytest.raises(tm.MeasurementError) as exc:
            tm.read_table(path)
        message = str(exc.value)
        assert fragment in message and "\n" not in message, message
        force(False)
        with pytest.raises(tm.MeasurementError) as small:
            tm.read_table(path)
        force(True)
        assert str(small.value) == message


def test_the_large_file_threshold_is_a_constant_with_an_environment_override(monkeypatch, tmp_path):
    from twin.measurement import chunked

    monkeypatch.delenv(chunked.LARGE_FILE_ENV, raising=False)
    assert chunked.large_file_bytes() == chunked.LARGE_FILE_BYTES == 256 * 2**20
    path = write_canonical(tmp_path / "c.csv")
    assert not chunked.is_large(path)
    monkeypatch.setenv(chunked.LARGE_FILE_ENV, str(path.stat().st_size))
    assert chunked.is_large(path)
    monkeypatch.setenv(chunked.LARGE_FILE_ENV, "not a size")
    assert chunked.large_file_bytes() == chunked.LARGE_FILE_BYTES
