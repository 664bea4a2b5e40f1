"""The adversarial log corpus (tests/test_hardening_logs.py checks it matches expect.yaml).

Text files are committed beside this file (``python make_corpus.py``, run from this folder, rewrites
them); binary ones (HDF5, Parquet, flight logs, byte garbage) are not committed: the tests write them
with :func:`write_binary` into a temporary copy of the corpus (tests/conftest.py ``log_corpus``).
"""
from pathlib import Path

import numpy as np

n = 30
H = "time_s,temperature_c,output_g\n"


def rows(n=n, fmt=lambda i: f"{i},{20 + 0.5 * i:.2f},{1 + 1e-4 * i:.6f}"):
    return "".join(fmt(i) + "\n" for i in range(n))


def _writer(out: Path):
    return lambda name, text: (out / name).write_bytes(text if isinstance(text, bytes) else text.encode())


def write_text(out: Path) -> None:
    """The text files of the corpus, into ``out``."""
    w = _writer(out)
    good = H + rows()
    w("empty.csv", "")
    w("header_only.csv", H)
    w("banner_only.csv", "# chamber log\n# operator: x\n")
    w("non_utf8_header.csv", ("time_s,temp\xe9rature_c,output_g\n" + rows()).encode("latin-1"))
    w("non_utf8_row.csv", good.encode() + b"30,\xff\xfe,1.0\n")
    w("nan_time.csv", good.replace("\n3,", "\nnan,", 1))
    w("inf_temperature.csv", good.replace("\n4,22.00,", "\n4,inf,", 1))
    w("nan_output.csv", good.replace(",1.000500\n", ",NaN\n", 1))
    w("inf_applied.csv", "time_s,temperature_c,output_g,applied_g\n" + rows(fmt=lambda i: f"{i},{20 + 0.5 * i:.2f},1.0,{'-inf' if i == 7 else '1'}"))
    w("ragged_row.csv", good.replace("\n5,22.50,1.000500\n", "\n5,22.50,1.000500,9,9\n", 1))
    w("text_in_number.csv", good.replace("\n6,23.00,", "\n6,hot,", 1))
    w("decreasing_time.csv", good.replace("\n8,", "\n2,", 1))
    w("kelvin_unlabelled.csv", H + rows(fmt=lambda i: f"{i},{293.15 + 0.5 * i:.2f},1.0"))
    w("fahrenheit.csv", H + rows(fmt=lambda i: f"{i},{68 + 0.9 * i:.2f},{1 + 1e-4 * i:.6f}"))
    w("fractional_run.csv", "time_s,temperature_c,output_g,run\n" + rows(fmt=lambda i: f"{i},{20 + 0.5 * i:.2f},1.0,{0.5 if i == 9 else 0}"))
    w("power_on_two.csv", "time_s,temperature_c,output_g,power_on\n" + rows(fmt=lambda i: f"{i},{20 + 0.5 * i:.2f},1.0,{2 if i == 3 else 0}"))
    w("huge_run.csv", "time_s,temperature_c,output_g,run\n" + rows(fmt=lambda i: f"{i},{20 + 0.5 * i:.2f},1.0,{10**9 if i == 3 else 0}"))
    w("nine_rows.csv", H + rows(9))
    w("wrong_columns.csv", "t,T,a\n" + rows())
    w("semicolon_decimal_comma.csv", "time_s;temperature_c;output_g\n" + rows(fmt=lambda i: f"{i};{20 + 0.5 * i:.2f};1,0".replace(".", ",")))
    # column maps
    w("map_header_maybe.yaml", "header: maybe\n")
    w("map_time_unit_number.yaml", "time_unit: 5\n")
    w("map_sample_rate_zero.yaml", "time: null\nsample_rate_hz: 0\n")
    w("map_output_mapping.yaml", "output: {name: output_g}\n")
    w("map_delimiter_word.yaml", "delimiter: comma\n")
    w("map_skip_lines_negative.yaml", "skip_lines: -3\n")
    w("map_unknown_key.yaml", "temprature: temperature_c\n")
    w("map_list.yaml", "- time_s\n- output_g\n")
    w("map_non_utf8.yaml", "output: \xe9\n".encode("latin-1"))
    w("map_malformed.yaml", "output: [output_g\n")
    w("map_temperature_unit_r.yaml", "temperature_unit: R\n")
    w("map_output_scale_nan.yaml", "output_scale: .nan\n")
    # three-axis logs (calibrate)
    T3 = "t,temp,ax,ay,az\n"
    tri = lambda i: f"{i},{20 + 0.1 * i:.3f},0.001,-0.002,{-1 + 1e-4 * i:.6f}"
    w("tri_two_orientations_same_instant.csv", T3 + "".join(tri(i) + "\n" for i in range(150)).replace("\n12,", "\n11,", 1))
    w("tri_missing_z.csv", "t,temp,ax,ay\n" + "".join(f"{i},{20 + 0.1 * i:.3f},0,0\n" for i in range(150)))
    w("tri_nan_temperature.csv", T3 + "".join(tri(i) + "\n" for i in range(150)).replace("\n40,24.000,", "\n40,nan,", 1))
    # companions of valid.csv (same rows) whose point is the command-line option in expect.yaml
    w("valid.csv", good)
    w("banner_skipped_past_end.csv", "# chamber log\n# operator: x\n")
    w("nan_time_skipped.csv", good.replace("\n3,", "\nnan,", 1))
    w("kelvin_labelled.csv", H + rows(fmt=lambda i: f"{i},{293.15 + 0.5 * i:.2f},1.0"))
    w("fahrenheit_as_celsius.csv", H + rows(fmt=lambda i: f"{i},{212 + 0.9 * i:.2f},1.0"))
    for name in ("bad_delimiter.csv", "zero_sample_rate.csv", "infinite_applied_option.csv"):
        w(name, good)


def write_binary(out: Path) -> None:
    """The binary files of the corpus, into ``out``."""
    import h5py
    import pyarrow as pa
    import pyarrow.parquet as pq

    w = _writer(out)
    w("binary_garbage.csv", bytes(range(256)) * 4)
    # twin-style HDF5
    L = {"time_s": np.arange(n) * 1.0, "temperature/thermometer_c": 20 + 0.5 * np.arange(n), "output/output_g": np.ones(n),
         "test/applied_g": np.ones(n), "test/run_index": np.zeros(n, np.int16), "test/power_on": np.zeros(n, bool)}
    def h5(name, **changes):
        with h5py.File(out / name, "w") as f:
            for k, v in {**L, **changes}.items():
                if v is None:
                    continue
                if isinstance(v, str) and v == "group":
                    f.create_group(k)
                else:
                    f[k] = v
    h5("h5_two_dimensional.h5", **{"output/output_g": np.ones((n, 3))})
    h5("h5_text_column.h5", **{"temperature/thermometer_c": np.array([b"20.0"] * n)})
    h5("h5_ragged.h5", **{"output/output_g": np.ones(n - 4)})
    h5("h5_empty.h5", **{k: v[:0] for k, v in L.items()})
    h5("h5_nan_temperature.h5", **{"temperature/thermometer_c": np.where(np.arange(n) == 5, np.nan, 20.0)})
    h5("h5_inf_applied.h5", **{"test/applied_g": np.where(np.arange(n) == 2, np.inf, 1.0)})
    h5("h5_group_column.h5", **{"output/output_g": "group"})
    h5("h5_missing_column.h5", **{"test/power_on": None})
    h5("h5_negative_run.h5", **{"test/run_index": np.full(n, -1, np.int16)})
    h5("h5_time_backwards.h5", **{"time_s": np.arange(n)[::-1] * 1.0})
    (out / "h5_truncated.h5").write_bytes((out / "h5_nan_temperature.h5").read_bytes()[:700])
    w("h5_not_hdf5.h5", "time_s,temperature_c\n1,2\n")
    # parquet
    tab = {"time_s": np.arange(n) * 1.0, "temperature_c": 20 + 0.5 * np.arange(n), "output_g": np.ones(n)}
    pq.write_table(pa.table({**tab, "output_g": pa.array(["1.0"] * n)}), out / "parquet_text_column.parquet")
    pq.write_table(pa.table({**tab, "temperature_c": pa.array([None if i == 3 else 20.0 + i for i in range(n)], pa.float64())}), out / "parquet_null.parquet")
    pq.write_table(pa.table({k: v[:0] for k, v in tab.items()}), out / "parquet_empty.parquet")
    (out / "parquet_truncated.parquet").write_bytes((out / "parquet_null.parquet").read_bytes()[:60])
    pq.write_table(pa.table({"a": np.ones(n)}), out / "parquet_wrong_columns.parquet")
    # flight-log-like
    w("ulog_truncated.ulg", b"ULog\x01\x12\x35")
    w("ulog_wrong_magic.ulg", b"NotAULog" * 40)
    w("dataflash_garbage.bin", bytes([0xA3, 0x95]) + bytes(200))
    w("dataflash_empty.bin", b"")


if __name__ == "__main__":
    write_text(Path("."))
