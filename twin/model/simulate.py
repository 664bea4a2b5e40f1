"""Scenario → dataset: program → thermal chain → device effects → sensor output (the scenario's part).

Every random draw comes from the scenario's seed through independent streams (white noise,
bias instability, thermometer), so the same seed gives identical arrays and another seed
changes the noise only. A three-axis device (``device.axes``) shares the thermal result and the
thermometer stream; each axis gets child streams of the white-noise, bias-instability and
turn-on streams (:meth:`numpy.random.SeedSequence.spawn`), so a one-axis scenario draws exactly
what it drew before three-axis devices existed.
"""

from __future__ import annotations

import datetime as _dt
from collections.abc import Callable
from dataclasses import dataclass, replace

import numpy as np

from sim.program import segment_kind
from sim.sensor import logger_white_sigma_g, sensor_output
from sim.thermal import ThermalResult, read_thermometer, simulate_chain
from twin import __version__
from twin.effects import EffectInputs
from twin.errors import ScenarioError
from twin.model import axes
from twin.model.dataset import LAYOUT, LAYOUT_VERSION, Dataset
from twin.model.results import RunSummary
from twin.model.scenario import LoadedScenario

STAGES = ("program", "thermal chain", "effects", "sensor")


def time_base(loaded: LoadedScenario) -> np.ndarray:
    """Sample times of one run: the logger grid over the program, end included.

    Parameters
    ----------
    loaded : LoadedScenario
        The scenario (program duration, logger rate).

    Returns
    -------
    ndarray
        Sample times from the run's start [s].
    """
    rate = loaded.scenario.test_plan.logger_rate_hz
    n = int(np.floor(loaded.program.duration_s * rate + 1e-9)) + 1
    return np.arange(n) / rate


def simulate_thermal(loaded: LoadedScenario, time_s: np.ndarray | None = None) -> ThermalResult:
    """The thermal chain of one run on the logger time base (deterministic).

    Parameters
    ----------
    loaded : LoadedScenario
        The scenario (program, chamber, thermometer).
    time_s : ndarray, optional
        Sample times [s]; default :func:`time_base`.

    Returns
    -------
    ThermalResult
        Set-point, air, board, die and thermometer-element temperatures [°C].
    """
    t = time_base(loaded) if time_s is None else time_s
    device, board, die = loaded.thermal_device()
    c = loaded.scenario.chamber
    return simulate_chain(t, loaded.program.setpoint_c(t), c.air_tau_s, device, loaded.thermometer(),
                          board_node=board, die_node=die, thermal_step_s=c.thermal_step_s)


def _step_schedule(t_run: np.ndarray, at_s: list[float], values: list[float]) -> np.ndarray:
    """Piecewise-constant schedule; before the first entry the first value holds."""
    idx = np.clip(np.searchsorted(np.asarray(at_s), t_run, side="right") - 1, 0, len(values) - 1)
    return np.asarray(values, float)[idx]


def _power_on(t_run: np.ndarray, power_on_s: list[float]) -> tuple[np.ndarray, np.ndarray]:
    """Power-on flags and time since the latest power-on; each run starts powered on."""
    starts = np.unique(np.r_[0.0, np.asarray(power_on_s, float)])
    starts = starts[starts <= t_run[-1]]
    first = np.searchsorted(t_run, starts, side="left")
    flag = np.zeros(t_run.size, bool)
    flag[first] = True
    last = starts[np.searchsorted(starts, t_run, side="right") - 1]
    return flag, t_run - last


@dataclass
class _Axis:
    """One sensing axis simulated: the acceleration applied to it, its drift and its output."""

    applied: np.ndarray
    contributions: dict
    turn_on_g: np.ndarray
    bias: np.ndarray
    sf: np.ndarray
    true_g: np.ndarray | None = None
    out: object = None


def _drift(composition, inputs: EffectInputs, zero_g_mg: float, turn_on_mg: float, runs: int, n_run: int,
           rng_turn_on: np.random.Generator, path: str = "<scenario>") -> _Axis:
    """The device's effects on one axis (``inputs.applied_g`` applied to it): bias and scale factor."""
    t = inputs.time_s
    contributions = _evaluate(composition, inputs, path)
    zero_g_g = zero_g_mg * 1e-3
    turn_on_g = np.repeat(rng_turn_on.normal(0.0, turn_on_mg * 1e-3, runs), n_run)
    bias = zero_g_g + turn_on_g + sum((np.broadcast_to(c.bias_g, t.shape) for c in contributions.values()),
                                      np.zeros(t.size))
    sf = sum((np.broadcast_to(c.scale_factor, t.shape) for c in contributions.values()), np.zeros(t.size))
    return _Axis(inputs.applied_g, contributions, turn_on_g, bias, sf)


def _evaluate(composition, inputs: EffectInputs, path: str) -> dict:
    """The device's contributions; an effect that raises (a plugin's, say) is named in one line."""
    from twin.effects import Composition

    try:
        return composition.evaluate(inputs, device=True)
    except (Exception, SystemExit) as exc:  # noqa: BLE001 - user code: named, never a traceback
        culprit, err = "", exc
        for effect in composition.effects:  # which one: evaluate each alone
            try:
                Composition([effect]).evaluate(inputs, device=True)
            except (Exception, SystemExit) as one:  # noqa: BLE001
                culprit, err = effect.name, one
                break
        what = f"effect {culprit!r}" if culprit else "the device's effects"
        raise ScenarioError(f"{path}: device.effects: {what} failed while simulating: {type(err).__name__}: "
                            f"{' '.join(str(err).split())[:200]}; expected it to return finite contributions") from None


def _check_finite(ds: Dataset, path: str) -> None:
    """Every array finite: a scenario whose magnitudes overflow is refused, never written as NaN."""
    for name, values in ds.arrays.items():
        if values.dtype.kind == "f" and not np.all(np.isfinite(values)):
            k = int(np.flatnonzero(~np.isfinite(values))[0])
            raise ScenarioError(f"{path}: the simulation gave a non-finite {name} at sample {k} "
                                "(t = {:.6g} s); expected finite values: reduce the scenario's extreme magnitudes"
                                .format(float(ds.arrays["time_s"][k])))


def _output(axis: _Axis, sensor, tp, rng_white: np.random.Generator, rng_bias: np.random.Generator) -> None:
    axis.true_g = axis.applied * (1.0 + axis.sf) + axis.bias
    axis.out = sensor_output(axis.true_g, sensor, tp.logger_rate_hz, rng_white, rng_bias, logger_mode=tp.logger_mode)


def _add(ds: Dataset, path: str, values, axis: str | None, description: str | None = None) -> None:
    """Add a per-axis array under its one-axis name (``axis`` None) or its three-axis name."""
    units, desc = LAYOUT.get(path, ("g", ""))
    desc = desc if description is None else description
    if axis is None:
        ds.add(path, values, units, desc)
    else:
        ds.add(axes.axis_path(path, axis), values, units, axes.axis_description(desc, axis))


def _add_axis(ds: Dataset, a: _Axis, axis: str | None) -> None:
    """The output and the truth of one axis."""
    out, shape = a.out, a.applied.shape
    _add(ds, "output/output_g", out.output_g, axis)
    _add(ds, "output/output_digits", out.digits, axis)
    for name, c in a.contributions.items():
        _add(ds, f"truth/effects/{name}_g", np.broadcast_to(c.output_g(a.applied), shape).astype(float), axis,
             f"contribution of effect {name!r} to the output")
    _add(ds, "truth/drift_g", a.true_g - a.applied - a.turn_on_g, axis)
    _add(ds, "truth/turn_on_bias_g", a.turn_on_g, axis)
    _add(ds, "truth/bias_g", a.bias, axis)
    _add(ds, "truth/scale_factor_error", a.sf, axis)
    _add(ds, "truth/noise_white_g", out.white_g, axis)
    _add(ds, "truth/noise_bias_instability_g", out.bias_instability_g, axis)
    _add(ds, "truth/quantisation_g", out.quantisation_g, axis)
    _add(ds, "truth/saturated", out.saturated, axis)


def simulate(
    loaded: LoadedScenario,
    seed: int | None = None,
    progress: Callable[[str], None] | None = None,
) -> Dataset:
    """Simulate a scenario into a :class:`Dataset` with its ground truth.

    A three-axis device (``device.axes``) shares the thermal result (die, thermometer) across
    its axes; each axis has its own effects, zero-g offset, turn-on bias and noise streams
    (children of the scenario seed's streams, :class:`numpy.random.SeedSequence` spawn).

    Parameters
    ----------
    loaded : LoadedScenario
        The scenario.
    seed : int, optional
        Overrides the scenario's ``seed``.
    progress : callable, optional
        Called with each stage's name as it starts.

    Returns
    -------
    Dataset
        Time [s], temperatures [°C], applied acceleration and output [g], and the truth arrays
        (drift [g], scale-factor error [1], noise [g], per-effect contributions [g]); see
        ``docs/dataset.md``.
    """
    scn = loaded.scenario
    seed = scn.seed if seed is None else int(seed)
    streams = np.random.SeedSequence(seed).spawn(4)
    rng_white, rng_bias, rng_thermo, rng_turn_on = (np.random.default_rng(s) for s in streams)
    tick = progress or (lambda stage: None)
    tp = scn.test_plan
    three = bool(loaded.axes)

    tick(STAGES[0])
    t_run = time_base(loaded)
    n_run, runs = t_run.size, tp.runs
    run_period = t_run[-1] + 1.0 / tp.logger_rate_hz

    tick(STAGES[1])
    th = simulate_thermal(loaded, t_run)
    thermometer = loaded.thermometer()
    tile = lambda a: np.tile(a, runs)  # noqa: E731 - the thermal response is the same every run
    time_s = (t_run[None, :] + run_period * np.arange(runs)[:, None]).ravel()
    run_index = np.repeat(np.arange(runs, dtype=np.int16), n_run)
    try:
        composition = loaded.device_composition()
        shift_c = 0.0 if three else composition.thermometer_shift_c()  # per-axis effects never act on it
    except (Exception, SystemExit) as exc:  # noqa: BLE001 - a plugin effect's own failure, in one line
        raise ScenarioError(f"{loaded.path}: device.effects: building the device's effects failed: "
                            f"{type(exc).__name__}: {' '.join(str(exc).split())[:200]}") from None
    probe = replace(thermometer, offset_c=thermometer.offset_c + shift_c)
    thermo = np.concatenate([read_thermometer(t_run, th.probe_c, probe, rng_thermo) for _ in range(runs)])
    if three:
        gravity = np.tile(axes.gravity_g(tp, t_run), (runs, 1))
        applied = gravity[:, 2]  # a placeholder: each axis gets its own column below
    else:
        applied = tile(_step_schedule(t_run, *tp.orientation_schedule(t_run[-1])))
        if tp.run_applied_g:
            applied = np.repeat([tp.run_applied_g[r % len(tp.run_applied_g)] for r in range(runs)], n_run).astype(float)
    flag, since = _power_on(t_run, tp.power_on_s)

    tick(STAGES[2])
    inputs = EffectInputs(time_s=time_s, die_c=tile(th.die_c), thermometer_c=thermo, applied_g=applied,
                          run_index=run_index, time_since_power_on_s=tile(since))
    sensor_section = scn.device.sensor
    if three:  # per axis: effects, zero-g offset, and child streams of the white, bias and turn-on streams
        children = [s.spawn(len(loaded.axes)) for s in (streams[0], streams[1], streams[3])]
        rngs = [tuple(np.random.default_rng(c[k]) for c in children) for k in range(len(loaded.axes))]
        per_axis = {a: _drift(loaded.device_composition(a), inputs.replace(applied_g=gravity[:, k]),
                              getattr(scn.device.axes, a).zero_g_offset_mg, sensor_section.turn_on_bias_mg, runs,
                              n_run, rngs[k][2], loaded.path) for k, a in enumerate(loaded.axes)}
    else:
        rngs = [(rng_white, rng_bias, rng_turn_on)]
        per_axis = {None: _drift(composition, inputs, sensor_section.zero_g_offset_mg, sensor_section.turn_on_bias_mg,
                                 runs, n_run, rng_turn_on, loaded.path)}

    tick(STAGES[3])
    sensor = loaded.sensor()
    for (w, b, _), a in zip(rngs, per_axis.values()):
        _output(a, sensor, tp, w, b)

    effects = list(dict.fromkeys(n for a in per_axis.values() for n in a.contributions))
    ds = Dataset({}, {}, attrs={
        "scenario_yaml": loaded.text,
        "scenario_path": loaded.path,
        "scenario_name": scn.name,
        "seed": seed,
        "twin_version": __version__,
        "layout_version": LAYOUT_VERSION,
        "created_utc": _dt.datetime.now(_dt.timezone.utc).isoformat(timespec="seconds"),
        "sample_rate_hz": tp.logger_rate_hz,
        "sensor": loaded.part.name if loaded.part is not None else scn.device.sensor.part_spec,
        "full_scale_g": sensor.full_scale_g,
        "sensitivity_mg_per_digit": sensor.sensitivity_mg_per_digit,
        "white_noise_sigma_g": logger_white_sigma_g(sensor, tp.logger_rate_hz, tp.logger_mode),
        "thermal_model": scn.chamber.model,
        "thermometer_attached_to": thermometer.attached_to,
        "effects": effects,
        "runs": runs,
        **({"axes": list(loaded.axes)} if three else {}),
    })
    ds.add("time_s", time_s)
    ds.add("program/setpoint_c", tile(th.setpoint_c))
    ds.add("program/segment", tile(segment_kind(loaded.program, t_run)))
    ds.add("temperature/air_c", tile(th.air_c))
    ds.add("temperature/board_c", tile(th.board_c))
    ds.add("temperature/die_c", inputs.die_c)
    ds.add("temperature/thermometer_true_c", tile(th.probe_c))
    ds.add("temperature/thermometer_c", thermo)
    for axis, a in per_axis.items():
        _add(ds, "test/applied_g", a.applied, axis)
    ds.add("test/run_index", run_index)
    ds.add("test/power_on", tile(flag))
    ds.add("test/time_since_power_on_s", inputs.time_since_power_on_s)
    for axis, a in per_axis.items():
        _add_axis(ds, a, axis)
    _check_finite(ds, loaded.path)
    return ds


def summary(ds: Dataset) -> RunSummary:
    """Machine-readable summary of a simulated dataset (``twin run --json``); over all axes of a
    three-axis dataset (its ``axes`` field lists them).

    Parameters
    ----------
    ds : Dataset
        A simulated dataset.

    Returns
    -------
    RunSummary
        Samples, duration [h], seed, runs, effects, set-point and die ranges [°C], die minus
        thermometer [°C], drift range [mg], white-noise σ [mg], output RMS minus truth [mg] and
        saturated samples.
    """
    t = ds["time_s"]
    die, thermo = ds["temperature/die_c"], ds["temperature/thermometer_c"]
    common = dict(samples=len(ds), duration_h=float(t[-1] - t[0]) / 3600.0 if t.size else 0.0,
                  seed=int(ds.attrs["seed"]), runs=int(ds.attrs["runs"]), effects=list(ds.attrs["effects"]),
                  setpoint_range_c=(float(ds["program/setpoint_c"].min()), float(ds["program/setpoint_c"].max())),
                  die_range_c=(float(die.min()), float(die.max())),
                  die_minus_thermometer_max_abs_c=float(np.max(np.abs(die - thermo))),
                  white_noise_sigma_mg=float(ds.attrs["white_noise_sigma_g"]) * 1e3)
    if axes.is_three_axis(ds):
        return RunSummary(**common, **axes.summary_fields(ds))
    drift = ds["truth/drift_g"]
    return RunSummary(
        **common,
        drift_range_mg=(float(drift.min() * 1e3), float(drift.max() * 1e3)),
        output_rms_minus_truth_mg=float(np.sqrt(np.mean((ds["output/output_g"] - ds["test/applied_g"] - drift) ** 2)) * 1e3),
        saturated_samples=int(np.count_nonzero(ds["truth/saturated"])),
    )
