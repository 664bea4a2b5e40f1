"""Dataset layout, reproducibility, atomic writes and the run CLI."""

import json

import h5py
import numpy as np
import pytest

from conftest import ROOT, coarse_text, run_cli
from twin.model.dataset import LAYOUT, read_hdf5, write_hdf5
from twin.model.scenario import parse_scenario
from twin.model.simulate import simulate

NOISE = {"truth/noise_white_g", "truth/noise_bias_instability_g", "truth/quantisation_g", "output/output_g",
         "output/output_digits", "temperature/thermometer_c", "truth/saturated"}


@pytest.fixture(scope="module")
def paper_coarse():
    return parse_scenario(coarse_text(ROOT / "scenarios" / "paper_iis328dq.yaml", rate_hz=1.0, max_cycles=3))


def test_same_seed_identical_other_seed_noise_only(paper_coarse):
    a, b, c = simulate(paper_coarse), simulate(paper_coarse), simulate(paper_coarse, seed=7)
    for key in a.arrays:
        np.testing.assert_array_equal(a[key], b[key])
        if key not in NOISE:
            np.testing.assert_array_equal(a[key], c[key], err_msg=key)
    for key in ("truth/noise_white_g", "truth/noise_bias_instability_g", "temperature/thermometer_c"):
        assert not np.array_equal(a[key], c[key]), key


def test_output_decomposes_into_truth(paper_coarse):
    ds = simulate(paper_coarse)
    recon = (ds["test/applied_g"] + ds["truth/drift_g"] + ds["truth/turn_on_bias_g"] + ds["truth/noise_white_g"]
             + ds["truth/noise_bias_instability_g"] + ds["truth/quantisation_g"])
    np.testing.assert_allclose(ds["output/output_g"], recon, atol=1e-12)
    effects = sum(ds[f"truth/effects/{n}_g"] for n in ds.effect_names)
    np.testing.assert_allclose(ds["truth/drift_g"], effects, atol=1e-15)
    np.testing.assert_allclose(ds["output/output_g"], ds["output/output_digits"] * 0.98e-3, atol=1e-12)
    # minimal drift law: 0.8 mg/degC x (die - 25) + 100 ppm/degC x 1 g x (die - 25) + 0.002 (die-25)^2
    dT = ds["temperature/die_c"] - 25
    np.testing.assert_allclose(ds["truth/drift_g"], (0.8 * dT + 0.002 * dT**2) * 1e-3 + 100e-6 * dT, atol=1e-12)


def test_hdf5_layout_units_and_attributes(paper_coarse, tmp_path):
    ds = simulate(paper_coarse)
    path = write_hdf5(ds, tmp_path / "d.h5")
    with h5py.File(path) as f:
        for key in LAYOUT:
            assert key in f, key
            assert f[key].attrs["units"], key
            assert f[key].shape == (len(ds),)
        assert f["truth/effects/static_bias_tc_g"].attrs["units"] == "g"
        assert f["time_s"].compression == "lzf" and f["time_s"].chunks is not None
        assert "program:" in f.attrs["scenario_yaml"]
        assert f.attrs["seed"] == paper_coarse.scenario.seed
        assert f.attrs["twin_version"]
    back = read_hdf5(path)
    for key in ds.arrays:
        np.testing.assert_array_equal(back[key], ds[key])


def test_interrupted_write_leaves_no_file_and_keeps_the_old_one(paper_coarse, tmp_path, monkeypatch):
    ds = simulate(paper_coarse)
    path = tmp_path / "d.h5"
    path.write_bytes(b"previous")
    real = h5py.Group.create_dataset
    calls = {"n": 0}

    def failing(self, *args, **kwargs):
        calls["n"] += 1
        if calls["n"] == 5:
            raise KeyboardInterrupt
        return real(self, *args, **kwargs)

    monkeypatch.setattr(h5py.Group, "create_dataset", failing)
    with pytest.raises(KeyboardInterrupt):
        write_hdf5(ds, path)
    assert path.read_bytes() == b"previous"
    assert list(tmp_path.iterdir()) == [path]  # no temporary left behind


def test_cli_run_writes_dataset_and_json(tmp_path):
    scn = tmp_path / "s.yaml"
    scn.write_text(coarse_text(ROOT / "scenarios" / "paper_iis328dq.yaml"))
    r = run_cli("run", str(scn), "-o", str(tmp_path / "o.h5"), "--seed", "3", "--json", "-")
    assert r.returncode == 0, r.stderr
    result = json.loads(r.stdout)
    assert result["seed"] == 3 and result["samples"] == len(read_hdf5(tmp_path / "o.h5"))
    assert result["die_range_c"][0] == pytest.approx(-20, abs=0.5)


@pytest.mark.parametrize("args,fragment", [
    (["run", "no/such.yaml"], "scenario file not found"),
    (["run", "scenarios/paper_iis328dq.yaml", "--seed", "-1"], "--seed"),
])
def test_cli_bad_input_exits_2_without_traceback(args, fragment):
    r = run_cli(*args)
    assert r.returncode == 2
    assert fragment in r.stderr and "Traceback" not in r.stderr


def test_cli_bad_scenario_is_one_line(tmp_path):
    bad = tmp_path / "bad.yaml"
    bad.write_text("program:\n  steps:\n    - {type: hold, dwell_s: -5}\n")
    r = run_cli("run", str(bad), "-o", str(tmp_path / "x.h5"))
    assert r.returncode == 2
    assert r.stderr.strip().count("\n") == 0 and "bad.yaml:3" in r.stderr
    assert not (tmp_path / "x.h5").exists()


def test_cli_test_design_json():
    r = run_cli("test-design", "--json", "-")
    assert r.returncode == 0
    items = {i["name"]: i["value"] for i in json.loads(r.stdout)["items"]}
    assert items["eq34_control_interval"] == pytest.approx(0.4375)


@pytest.mark.parametrize("args", [["run", "{s}", "-o", "{s}"], ["run", "{s}", "--json", "{s}"]])
def test_an_output_over_the_input_is_refused_and_the_input_kept(tmp_path, args):
    s = tmp_path / "s.yaml"
    text = (ROOT / "scenarios" / "hidden_none.yaml").read_text()
    s.write_text(text)
    r = run_cli(*[a.format(s=s) for a in args])
    assert r.returncode == 2 and "would overwrite an input" in r.stderr and r.stderr.count("\n") == 1
    assert s.read_text() == text


def test_infinite_or_nan_numbers_in_a_scenario_are_refused_at_their_key(tmp_path):
    for value in (".inf", ".nan", "-.inf"):
        s = tmp_path / "s.yaml"
        s.write_text(f"program:\n  start_c: 25\n  steps: [{{type: hold, dwell_s: {value}}}]\n")
        r = run_cli("run", str(s), "-o", str(tmp_path / "x.h5"))
        assert r.returncode == 2 and "s.yaml:3: program.steps[0].dwell_s" in r.stderr and "finite" in r.stderr
        assert "Traceback" not in r.stderr and not (tmp_path / "x.h5").exists()
