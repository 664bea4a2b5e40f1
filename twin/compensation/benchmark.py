"""``twin benchmark``: the paper's compensation comparison on data whose truth is known.

Tests 1..N are independent runs of the scenario (seeds). Splits: train on cycles 1–2, test on the
last cycle (the paper's set-up); an extrapolation split (train ≤ 30 °C, test > 30 °C); and a
different-ramp-rate split (train on the scenario, test on the same device with twice the ramp
rate). Every MSE is of the compensated output against the true acceleration, and is also given as
a ratio to the noise floor (the MSE of the sensor noise alone: what a perfect compensator leaves).

The compensators are the registered ones (:mod:`twin.compensation.registry`, in registration
order), then the calibrated physics twin (:mod:`twin.compensation.physics_twin`) as the reference.
The cycle split is :func:`twin.compensation.splits.last_cycle_test`, shared with the DOE studies.
"""

from __future__ import annotations

import time
from dataclasses import replace

import numpy as np
import yaml

from fitting import EvolvedBPNN
from fitting.optimizers import EQ45_BOUNDS, EQ45_MINIMUM, GA, PSO, PSOGA, eq45
from twin.compensation.benchmark_result import (BenchmarkResult, FitTime, MeanStd, OptimizerEntry, OptimizerRun,
                                                SearchConvergence, Table1Row)
from twin.compensation.physics_twin import twin_compensation
from twin.compensation.registry import COMPENSATORS, Compensator
from twin.compensation.splits import last_cycle_test, subset
from twin.errors import TwinError
from twin.measurement import from_dataset
from twin.model.scenario import LoadedScenario, parse_scenario
from twin.model.simulate import simulate

TABLE2_ITERATIONS = (14, 28, 42, 56, 70)
#: the extrapolation split trains at or below this temperature and tests above it [°C]
EXTRAPOLATION_SPLIT_C = 30.0


class BenchmarkError(TwinError):
    """A benchmark that cannot be run on the given scenario."""


def _variant(loaded: LoadedScenario, seed: int, rate_hz: float | None, ramp_factor: float = 1.0) -> LoadedScenario:
    data = yaml.safe_load(loaded.text)
    data["seed"] = int(seed)
    if rate_hz:
        data.setdefault("test_plan", {})["logger_rate_hz"] = rate_hz
    if ramp_factor != 1.0:
        for step in data["program"]["steps"]:
            if step["type"] == "staircase":
                step["step_s"] = step["step_s"] / ramp_factor
            elif step["type"] == "ramp":
                step["ramp_c_per_h"] = step["ramp_c_per_h"] * ramp_factor
    return parse_scenario(yaml.safe_dump(data, sort_keys=False), loaded.path)


def _dataset(loaded: LoadedScenario):
    """The simulated dataset, its blind measurement and the sensor noise (what no compensator removes)."""
    ds = simulate(loaded)
    noise = ds["truth/noise_white_g"] + ds["truth/noise_bias_instability_g"] + ds["truth/quantisation_g"]
    return ds, from_dataset(ds), noise


def evaluate_split(loaded, quick, seed, train_m, test_m, noise_test, record_history=False,
                   compensators: list[Compensator] | None = None, physics_twin: bool = True):
    """MSE of the compensated test output for every compensator (default: every registered one,
    in registration order) and the calibrated physics twin; histories of the population searches;
    fit times.

    Each compensator is trained on ``train_m`` to predict the drift ``output − applied`` [g] (its
    ΔT reference T0 set to the first training temperature); the MSE is of the compensated test
    output against the true acceleration, mean((output − prediction − applied)²) [g²].

    Parameters
    ----------
    loaded : LoadedScenario
        The scenario (the physics twin's effects and geometry).
    quick : bool
        The short budget (:mod:`twin.compensation.paper_models`).
    seed : int
        The test's seed (the networks' and searches' random state).
    train_m, test_m : Measurement
        Training and test samples (time [s], temperature [°C], output and applied [g]).
    noise_test : ndarray
        The sensor noise of the test samples [g].
    record_history : bool
        Also return the population searches' histories.
    compensators : list of Compensator, optional
        Default: every registered one.
    physics_twin : bool
        Also calibrate and score the physics twin (:func:`twin.compensation.physics_twin.twin_compensation`).

    Returns
    -------
    mse : dict of str to float
        Compensator → test MSE [g²], ``physics_twin`` and ``noise_floor`` (the MSE of the noise
        alone) included.
    history : dict of str to dict
        Population search → ``mse_g2_by_iteration`` [g²] (best training MSE after each
        iteration, de-standardised), ``fitness_evaluations``, ``bp_iterations``.
    timings : dict of str to dict
        Compensator → ``fit_s``, the fit time [s].

    References
    ----------
    Qi et al. (2022), Micromachines 13, 2156: Table 1 (test MSE per model), Table 2 (MSE per
    iteration of the population search).
    """
    y_train = train_m.output_g - train_m.applied_g
    truth_test = test_m.applied_g
    out, hist, extra = {}, {}, {}
    t_ref_c = float(train_m.temperature_c[0])  # ΔT's reference is fixed by the training data
    for entry in compensators if compensators is not None else list(COMPENSATORS.values()):
        features, model = entry.build(quick, seed)
        name = entry.name
        features = replace(features, t0_c=t_ref_c)
        Xtr = features.transform(train_m.temperature_c, train_m.time_s)
        Xte = features.transform(test_m.temperature_c, test_m.time_s)
        start = time.perf_counter()
        model.fit(Xtr, y_train)
        fit_s = time.perf_counter() - start
        compensated = test_m.output_g - model.predict(Xte)
        out[name] = float(np.mean((compensated - truth_test) ** 2))
        extra[name] = {"fit_s": fit_s}
        if record_history and isinstance(model, EvolvedBPNN):
            scale = float(np.std(y_train)) ** 2
            hist[name] = {"mse_g2_by_iteration": [h * scale for h in model.history_],
                          "fitness_evaluations": model.n_evaluations_, "bp_iterations": model.network_.n_iter_}
    if physics_twin:
        start = time.perf_counter()
        pred = twin_compensation(loaded, train_m, test_m)
        out["physics_twin"] = float(np.mean((test_m.output_g - pred - truth_test) ** 2))
        extra["physics_twin"] = {"fit_s": time.perf_counter() - start}
    out["noise_floor"] = float(np.mean(noise_test**2))
    return out, hist, extra


def _check_split(name: str, train, test, loaded: LoadedScenario, what: str) -> None:
    if not (train.any() and test.any()):
        raise BenchmarkError(f"{loaded.path}: the {name} split needs {what}; this scenario has "
                             f"{int(train.sum())} training and {int(test.sum())} test samples")


def optimizer_benchmark(seeds: int = 20) -> dict[str, OptimizerEntry]:
    """Iterations and evaluations to abs(z − z*) < 1e-6 on eq. (45) (median and IQR over seeds).

    GA (real-valued, and the paper's binary encoding of eq. (39)), PSO and PSO-GA; population 50,
    at most 300 iterations.

    Parameters
    ----------
    seeds : int
        Random states 0..seeds − 1.

    Returns
    -------
    dict of str to OptimizerEntry
        Optimiser → :class:`OptimizerRun` (``seeds``, ``reached``: seeds that reached z*,
        ``iterations_q25_median_q75`` and ``evaluations_q25_median_q75``: None when no seed reached it); ``paper`` (the paper's
        iteration counts) and ``z_star`` (the minimum, ``EQ45_MINIMUM`` [1]).

    References
    ----------
    Qi et al. (2022), Micromachines 13, 2156, eqs. (39) and (45).
    """
    out = {}
    for name, cls, kw in (("GA", GA, {}), ("GA_binary", GA, {"encoding": "binary"}), ("PSO", PSO, {}), ("PSO-GA", PSOGA, {})):
        its, evals, hits = [], [], 0
        for s in range(seeds):
            o = cls(population_size=50, max_iter=300, target=EQ45_MINIMUM + 1e-6, random_state=s, **kw).fit(eq45, EQ45_BOUNDS)
            ok = abs(o.fun_ - EQ45_MINIMUM) < 1e-6
            hits += ok
            if ok:
                its.append(o.n_iter_)
                evals.append(o.n_evaluations_)
        q = lambda v: (float(np.percentile(v, 25)), float(np.median(v)), float(np.percentile(v, 75))) if v else None  # noqa: E731
        out[name] = OptimizerRun(seeds, hits, q(its), q(evals))
    out["paper"] = {"GA_iterations": 27, "PSO-GA_iterations": 3}
    out["z_star"] = EQ45_MINIMUM
    return out


def run_benchmark(loaded: LoadedScenario, seeds: int = 3, quick: bool = False, progress=None) -> BenchmarkResult:
    """Tests 1..``seeds``, the extrapolation and the ramp-rate split (on Test 1's device); raises
    :class:`BenchmarkError` when the scenario cannot be split that way.

    Parameters
    ----------
    loaded : LoadedScenario
        The scenario; Test k is its seed + k − 1.
    seeds : int
        Independent tests.
    quick : bool
        1 Hz data and the short training budget.
    progress : callable, optional
        ``progress(message)``, called before each stage.

    Returns
    -------
    BenchmarkResult
        ``twin benchmark --json`` (without ``optimizers``): ``table1`` (per compensator the test
        MSEs [g²], their mean and standard deviation, the ratio to the noise floor [1] and, but for
        the conventional model, Q [%] and whether it improves on it), ``table2`` (MSE [g²] at
        iterations 14..70 of each population search), ``noise_floor_mse`` [g²], the
        ``extrapolation_split`` and ``ramp_rate_split`` MSEs [g²], ``verdicts`` and ``timings_s``.

    References
    ----------
    Qi et al. (2022), Micromachines 13, 2156: Tables 1 and 2; Q = |MSE − MSE_conventional| /
    MSE_conventional × 100 %, eq. (47).
    """
    tick = progress or (lambda msg: None)
    rate = 1.0 if quick else None
    tests, table2, timings, extrap, ramp = [], {}, {}, [], []
    for k in range(seeds):
        seed = loaded.scenario.seed + k
        tick(f"test {k + 1}/{seeds}: simulate")
        scn = _variant(loaded, seed, rate)
        ds, m, noise = _dataset(scn)
        train = ~last_cycle_test(scn.program, m.time_s, m.run_index)
        hot = m.temperature_c > EXTRAPOLATION_SPLIT_C
        if k == 0:  # before any training: a scenario that cannot be split fails at once
            _check_split("extrapolation", ~hot, hot, loaded,
                         f"readings both at or below and above {EXTRAPOLATION_SPLIT_C:g} °C")
        tick(f"test {k + 1}/{seeds}: train and test the models")
        res, hist, extra = evaluate_split(scn, quick, seed, subset(m, train), subset(m, ~train), noise[~train],
                                          record_history=True)
        tests.append(res)
        timings[f"test{k + 1}"] = extra
        for name, h in hist.items():
            table2.setdefault(name, []).append(h)
        if k == 0:
            tick("extrapolation split")
            e, _, _ = evaluate_split(scn, quick, seed, subset(m, ~hot), subset(m, hot), noise[hot])
            extrap.append(e)
            tick("ramp-rate split")
            fast = _variant(loaded, seed + 1000, rate, ramp_factor=2.0)
            _, m2, noise2 = _dataset(fast)
            r, _, _ = evaluate_split(scn, quick, seed, m, m2, noise2)
            ramp.append(r)
    return _tables(tests, table2, extrap, ramp, timings, quick)


def _tables(tests, table2, extrap, ramp, timings, quick) -> BenchmarkResult:
    models = [k for k in tests[0] if k != "noise_floor"]
    rows = []
    for name in models:
        mse = [t[name] for t in tests]
        ratio = [t[name] / t["noise_floor"] for t in tests]
        q_percent = improves = None
        if name != "conventional":
            q_percent = tuple(abs(t[name] - t["conventional"]) / t["conventional"] * 100 for t in tests)
            improves = tuple(t[name] < t["conventional"] for t in tests)
        rows.append(Table1Row(name, tuple(mse), float(np.mean(mse)), float(np.std(mse)), tuple(ratio),
                              float(np.mean(ratio)), q_percent, improves))
    t2 = {}
    for name, runs in table2.items():
        per_it = {}
        for it in TABLE2_ITERATIONS:
            vals = [r["mse_g2_by_iteration"][min(it, len(r["mse_g2_by_iteration"]) - 1)] for r in runs]
            per_it[str(it)] = MeanStd(float(np.mean(vals)), float(np.std(vals)))
        t2[name] = SearchConvergence(per_it, tuple(r["fitness_evaluations"] for r in runs),
                                     tuple(r["bp_iterations"] for r in runs),
                                     tuple(len(r["mse_g2_by_iteration"]) - 1 for r in runs))
    mean = {r.model: r.mse_mean for r in rows}
    floor = float(np.mean([t["noise_floor"] for t in tests]))
    verdicts = [
        verdict("model3_psoga", "model2_ga", mean, "PSO-GA-BPNN", "GA-BPNN"),
        verdict("model2_ga", "model1", mean, "GA-BPNN", "the plain BPNN with the same features (Model 1)"),
        verdict("model1", "conventional", mean, "Model 1 (T, T², ΔT, ΔT²)", "the conventional model (ΔT, ΔT²)"),
        verdict("model3_psoga", "polynomial_T", mean, "PSO-GA-BPNN", "a polynomial in T (order by validation)"),
        verdict("extension_bpnn_dTdt", "model3_psoga", mean, "our extension (paper features + dT/dt)", "PSO-GA-BPNN"),
        f"Noise floor {floor:.3e} g²: extension at {mean['extension_bpnn_dTdt'] / floor:.3f}×, physics twin at "
        f"{mean['physics_twin'] / floor:.3f}×, PSO-GA-BPNN at {mean['model3_psoga'] / floor:.3f}× the floor.",
    ]
    return BenchmarkResult(
        quick=quick, tests=len(tests), noise_floor_mse=floor,
        noise_floor_mse_per_test=tuple(t["noise_floor"] for t in tests), table1=tuple(rows), table2=t2,
        extrapolation_split=extrap[0] if extrap else None, ramp_rate_split=ramp[0] if ramp else None,
        verdicts=tuple(verdicts),
        timings_s={test: {name: FitTime(**t) for name, t in per.items()} for test, per in timings.items()},
    )


#: relative MSE difference below which two compensators are called level, not one beating the other
TIE_PERCENT = 0.1


def verdict(a: str, b: str, mean: dict, la: str, lb: str) -> str:
    """One sentence comparing the mean MSEs of compensators ``a`` and ``b`` (labels ``la``, ``lb``):
    level below :data:`TIE_PERCENT`, else which beats which and by how much.

    Parameters
    ----------
    a, b : str
        Compensator keys of ``mean``.
    mean : dict of str to float
        Compensator → mean test MSE [g²].
    la, lb : str
        Their labels in the sentence.

    Returns
    -------
    str
        The sentence; the difference is (MSE_b − MSE_a) / MSE_b [%].
    """
    d = (mean[b] - mean[a]) / mean[b] * 100
    if abs(d) < TIE_PERCENT:
        return (f"{la} and {lb} are level: MSE {mean[a]:.3e} vs {mean[b]:.3e} g² ({abs(d):.2f} % apart, "
                f"under {TIE_PERCENT} %).")
    if d > 0:
        return f"{la} beats {lb}: MSE {mean[a]:.3e} vs {mean[b]:.3e} g² ({d:.1f} % lower)."
    return f"{la} does NOT beat {lb}: MSE {mean[a]:.3e} vs {mean[b]:.3e} g² ({-d:.1f} % higher)."
