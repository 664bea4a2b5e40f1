"""Conformance over every registered effect, physical invariants, plugins."""

import json
import textwrap

import numpy as np
import pytest

from conftest import ROOT, SCENARIOS, coarse_text, run_cli
from schemas import check_schema
from sim.play import play_operator
from twin.effects import REGISTRY, Composition, Contribution, Effect, EffectInputs, Parameter, get_effect
from twin.effects.check import EffectCheckError, check_effect, conformance_inputs
from twin.errors import ModelError
from twin.model.scenario import parse_scenario
from twin.model.simulate import simulate

REQUIRED = {
    "comb_expansion": "scale_factor", "stiffness_tc": "scale_factor", "scale_factor_tc": "scale_factor",
    "static_bias_tc": "bias_tc", "package_stress": "bias_tc", "package_fem": "bias_tc", "thermal_lag": "thermal_lag",
    "thermal_gradient": "thermal_lag", "thermal_hysteresis": "hysteresis", "stress_relaxation": "hysteresis",
    "aging_drift": "aging", "warmup": "warmup", "probe_offset": "probe", "null": "null",
}
BUILTIN = sorted(n for n, cls in REGISTRY.items() if cls.__module__.startswith("twin.effects."))


def _inputs(n=20000, dt=1.0, seed=0):
    return conformance_inputs(n, dt, seed)


def test_required_effects_are_registered_with_their_families():
    for name, family in REQUIRED.items():
        assert get_effect(name).family == family


def test_every_builtin_effect_is_covered_here():
    # meta-test: a new effect must be added to REQUIRED (and so to the checks below)
    assert set(BUILTIN) == set(REQUIRED)


@pytest.mark.parametrize("name", BUILTIN)
def test_builtin_effect_passes_check_effect(name):
    """Units, bounds, sources; finite outputs = Σ amplitude × basis; causal; zero at the reference."""
    check_effect(get_effect(name))


class _Acausal(Effect):
    name, family, reads = "acausal", "test", ("die_c",)
    parameters = (Parameter("k", "g/degC", 1e-3, (-1.0, 1.0), "test"),)

    def basis(self, inputs):  # looks at the last sample: sees the future
        return {"k": Contribution(bias_g=(inputs.die_c - 25.0) * 0 + inputs.die_c[-1] - 25.0)}


class _NoUnit(_Acausal):
    name = "no_unit"
    parameters = (Parameter("k", "", 1e-3, (-1.0, 1.0), "test"),)


@pytest.mark.parametrize("cls,message", [(_Acausal, "not causal"), (_NoUnit, "needs a unit")])
def test_check_effect_catches_a_broken_effect(cls, message):
    with pytest.raises(EffectCheckError, match=message):
        check_effect(cls)


def test_an_input_the_measurement_lacks_is_named_with_the_effect():
    inputs = _inputs(n=100).replace(time_since_power_on_s=None)
    with pytest.raises(ModelError, match="effect 'warmup' reads time_since_power_on_s, which this measurement"):
        get_effect("warmup")().contribution(inputs)


def test_null_effect_gives_zero():
    c = get_effect("null")().contribution(_inputs())
    assert np.all(c.output_g(_inputs().applied_g) == 0)


def test_thermal_lag_step_response_is_exponential():
    n, dt = 4000, 0.5
    t = np.arange(n) * dt
    step = np.where(t > 0, 10.0, 0.0)
    inputs = EffectInputs(time_s=t, die_c=step, thermometer_c=step, applied_g=np.ones(n),
                          run_index=np.zeros(n, np.int16), time_since_power_on_s=t)
    one = get_effect("thermal_lag")(tau_s=100.0).die_temperature(inputs)
    # first-order hold spreads the step over the first interval: exact up to a dt/2 time shift
    np.testing.assert_allclose(one[1:], 10 * (1 - np.exp(-(t[1:] - dt / 2) / 100.0)), atol=1e-3)
    two = get_effect("thermal_lag")(tau_s=100.0, tau2_s=40.0).die_temperature(inputs)
    ts = t[1:] - dt
    analytic = 10 * (1 - (100 * np.exp(-ts / 100) - 40 * np.exp(-ts / 40)) / 60)
    np.testing.assert_allclose(two[1:], analytic, atol=0.02)  # FOH ramp over dt on each node: O(dt/tau)


def _cycle(rate_c_per_s, dt=1.0):
    """25 -> 55 -> -5 -> 25 degC at a constant rate."""
    legs = [np.arange(25, 55, rate_c_per_s * dt), np.arange(55, -5, -rate_c_per_s * dt), np.arange(-5, 25, rate_c_per_s * dt)]
    temp = np.concatenate(legs)
    t = np.arange(temp.size) * dt
    return EffectInputs(time_s=t, die_c=temp, thermometer_c=temp, applied_g=np.ones(temp.size),
                        run_index=np.zeros(temp.size, np.int16), time_since_power_on_s=t)


def test_slow_ramp_removes_lag_and_leaves_hysteresis():
    lag = get_effect("thermal_lag")(tau_s=120.0)
    hyst = get_effect("thermal_hysteresis")(half_width_c=2.0, k_mg_per_c=0.3)
    lags, loops = [], []
    for rate in (0.1, 0.01, 0.001):  # degC/s
        x = _cycle(rate)
        lags.append(np.max(np.abs(lag.die_temperature(x) - x.thermometer_c)))
        h = hyst.contribution(x).bias_g
        # hysteresis as a function of temperature on the heating leg after the first reversal
        sel = (x.die_c > 10) & (x.die_c < 40) & (np.gradient(x.die_c) > 0) & (x.time_s > x.time_s[-1] / 2)
        loops.append(np.interp([15.0, 20.0, 30.0], x.die_c[sel], h[sel]))
    # steady lag = rate x tau: 12, 1.2, 0.12 degC
    np.testing.assert_allclose(lags, [12.0, 1.2, 0.12], rtol=0.05)
    for other in loops[1:]:
        np.testing.assert_allclose(other, loops[0], atol=1e-6)  # rate independent
    assert np.allclose(loops[0], -2.0 * 0.3e-3)  # on a rising branch: k x (T - r - T)


def test_play_operator_matches_the_recursion():
    rng = np.random.default_rng(4)
    x = np.cumsum(rng.normal(size=3000))
    p, ref = 0.0, []
    for v in x:
        p = min(max(p, v - 1.5), v + 1.5)
        ref.append(p)
    np.testing.assert_array_equal(play_operator(x, 1.5, initial=0.0), ref)


def test_stress_relaxation_relaxes_in_dwells_with_tau():
    n = 40000
    t = np.arange(n, dtype=float)
    temp = np.where(t < 100, 25.0, 45.0)
    x = EffectInputs(time_s=t, die_c=temp, thermometer_c=temp, applied_g=np.ones(n),
                     run_index=np.zeros(n, np.int16), time_since_power_on_s=t)
    eff = get_effect("stress_relaxation")(k1_mg_per_c=0.5, tau_s=3600.0, k2_mg_per_c=0.0)
    b = eff.contribution(x).bias_g * 1e3
    assert b[101] == pytest.approx(0.5 * 20 * np.exp(-0.5 / 3600), rel=1e-3)
    assert b[100 + 3600] == pytest.approx(10 * np.exp(-1), rel=2e-3)


def test_unknown_effect_and_parameter_suggest():
    with pytest.raises(ModelError, match="did you mean 'thermal_lag'"):
        get_effect("thermal_lagg")
    with pytest.raises(ModelError, match="did you mean 'tau_s'"):
        get_effect("warmup")(tau=3)
    with pytest.raises(ModelError, match="outside its bounds"):
        get_effect("warmup")(tau_s=1e9)


def test_device_cannot_carry_the_twins_lag_model():
    from twin.errors import ScenarioError

    with pytest.raises(ScenarioError, match="gets its lag from the thermal chain"):
        parse_scenario("program:\n  steps: [{type: hold, dwell_s: 10}]\ndevice:\n  effects: {thermal_lag: {}}\n")


def test_probe_offset_shifts_the_reading_not_the_output():
    base = "program:\n  steps: [{type: hold, dwell_s: 100}]\nseed: 3\nchamber:\n  thermometer: {noise_c: 0, resolution_c: 0}\n"
    a = simulate(parse_scenario(base + "device:\n  effects: {static_bias_tc: {}}\n"))
    b = simulate(parse_scenario(base + "device:\n  effects: {static_bias_tc: {}, probe_offset: {offset_c: 0.7}}\n"))
    np.testing.assert_allclose(b["temperature/thermometer_c"] - a["temperature/thermometer_c"], 0.7, atol=1e-12)
    np.testing.assert_array_equal(a["output/output_g"], b["output/output_g"])
    # in the twin (not a device) the same effect is a constant −tc·δ bias, which the offset absorbs
    probe = get_effect("probe_offset")(offset_c=0.7)
    twin_bias = Composition([probe]).evaluate(_inputs(n=50))["probe_offset"].bias_g
    np.testing.assert_allclose(twin_bias, -probe.values["tc_mg_per_c"] * 1e-3 * 0.7, rtol=1e-12)


def test_every_effect_on_in_one_device_and_truth_columns(tmp_path):
    effects = {n: {} for n in BUILTIN if get_effect(n).slot == "drift" and n != "null"}
    text = coarse_text(ROOT / "scenarios" / "paper_iis328dq.yaml")
    import yaml

    data = yaml.safe_load(text)
    data["device"]["effects"] = effects
    ds = simulate(parse_scenario(yaml.safe_dump(data)))
    assert set(ds.effect_names) == set(effects)
    total = sum(ds[f"truth/effects/{n}_g"] for n in effects)
    np.testing.assert_allclose(ds["truth/drift_g"], total, atol=1e-15)


@pytest.mark.parametrize("path", [p for p in SCENARIOS if p.stem.startswith("hidden_")], ids=lambda p: p.stem)
def test_hidden_scenarios_hide_an_effect_from_the_twin(path):
    loaded = parse_scenario(coarse_text(path), str(path))
    scn = loaded.scenario
    device, twin = set(scn.device.effects), set(scn.twin.effects)
    if path.stem == "hidden_none":
        assert device <= twin and scn.chamber.thermometer.attached_to == "die" and scn.chamber.thermometer.tau_s == 0
    elif path.stem == "hidden_thermal_lag":
        assert "thermal_lag" not in twin and scn.chamber.thermometer.attached_to != "die"
    else:
        assert len(device - twin) == 1
    ds = simulate(loaded)
    assert set(ds.effect_names) == device


PLUGIN = textwrap.dedent('''
    import numpy as np
    from twin.effects import Contribution, Effect, Parameter, register

    @register
    class HumiditySwelling(Effect):
        """Mould-compound swelling with a slow moisture uptake (a user's effect)."""
        name = "humidity_swelling"
        family = "moisture"
        reads = ("time_s",)
        parameters = (
            Parameter("amplitude_mg", "mg", 0.5, (-10.0, 10.0), "user estimate"),
            Parameter("tau_s", "s", 20000.0, (100.0, 1e6), "uptake time", role="nonlinear", grid=(1e4, 2e4, 4e4)),
        )

        def basis(self, inputs):
            t = inputs.time_s - inputs.time_s[0]
            return {"amplitude_mg": Contribution(bias_g=(1 - np.exp(-t / self.values["tau_s"])) * 1e-3)}
''')


def test_plugin_effect_from_a_scenario_is_simulated_and_listed(tmp_path):
    (tmp_path / "my_effects.py").write_text(PLUGIN)
    scn = tmp_path / "plugin.yaml"
    scn.write_text("program:\n  steps: [{type: hold, dwell_s: 3000}]\n"
                   "test_plan: {logger_rate_hz: 1}\n"
                   "device:\n  effects: {static_bias_tc: {}, humidity_swelling: {amplitude_mg: 2.0}}\n"
                   "twin:\n  plugins: [my_effects.py]\n  effects: [static_bias_tc, humidity_swelling]\n")
    r = run_cli("run", str(scn), "-o", str(tmp_path / "p.h5"), "--json", "-")
    assert r.returncode == 0, r.stderr
    assert "humidity_swelling" in json.loads(r.stdout)["effects"]
    from twin.model.dataset import read_hdf5

    col = read_hdf5(tmp_path / "p.h5")["truth/effects/humidity_swelling_g"]
    assert col[-1] == pytest.approx(2e-3 * (1 - np.exp(-3000 / 20000)), rel=1e-9)  # end point included
    r = run_cli("effects", str(scn), "--json", "-")
    check_schema(json.loads(r.stdout), "effects")
    listed = {e["name"]: e for e in json.loads(r.stdout)["effects"]}
    assert listed["humidity_swelling"]["family"] == "moisture"
    assert listed["humidity_swelling"]["parameters"][0]["unit"] == "mg"


def test_broken_plugin_is_a_clear_error(tmp_path):
    (tmp_path / "bad.py").write_text("raise RuntimeError('oops')\n")
    scn = tmp_path / "s.yaml"
    scn.write_text("program:\n  steps: [{type: hold, dwell_s: 10}]\ntwin:\n  plugins: [bad.py, missing.py]\n")
    r = run_cli("run", str(scn))
    assert r.returncode == 2 and "plugins[0]" in r.stderr and "RuntimeError: oops" in r.stderr
