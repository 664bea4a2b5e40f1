"""Fitting benchmark, side by side in one run on the same data (cycles 1–2 of the paper scenario,
390k samples at 10 Hz, a 4-10-1 tanh network, population 50). Writes JSON.

1. Population fitness evaluations per second: ours (``population_mse``: the compiled kernel of
   ``fitting.kernels`` — float32, one pass per network, a rational tanh — and beside it the torch
   kernel, one GEMM for the hidden layers of the whole population, chunked) against pygad
   (``fitness_batch_size`` = population) and evotorch (a vectorised ``Problem``, its GeneticAlgorithm), both handed the
   batched torch fitness a user would write (float32, every network at once by broadcasting).
   Target (issue 15): ≥ 10× the best peer. evotorch is also timed with our kernel as its fitness,
   to show how much of the ratio is the kernel. Where the time goes is measured too: one evaluation is
   31.4 MFLOP + 3.9 M activations; the activation's share is timed separately, and the vendor's
   tanh beside its sigmoid (the torch kernel runs tanh networks as sigmoid networks with rescaled
   weights).
2. PSO-GA-BPNN end to end (50 iterations = 50 GA generations + 50 PSO steps, then L-BFGS) against
   scikit-learn's MLPRegressor(10, tanh, lbfgs): wall time (target, issue 15: ≤ 2× at equal test
   MSE) and test MSE on cycle 3, with the search's fitness on all training samples (the paper's
   form) and on every 8th (``sample_stride=8``; L-BFGS still on all of them);
   our extension features (paper + dT/dt) against the noise-only MSE (target ≤ 1.05×).

Needs the ``bench`` extra (pygad, evotorch): pip install -e '.[bench]'.
Usage: python benchmarks/bench_fitting.py [--json out/bench_fitting.json] [--quick]
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(Path(__file__).resolve().parent))

from _common import write_json  # noqa: E402

import torch  # noqa: E402

from fitting import EXTENSION, PAPER, EvolvedBPNN  # noqa: E402
from fitting.network import forward, init_weights, n_parameters, population_mse  # noqa: E402
from twin.measurement import from_dataset  # noqa: E402
from twin.model.scenario import load_scenario  # noqa: E402
from twin.model.simulate import simulate  # noqa: E402

POP, HIDDEN = 50, 10
# The search stage's fitness on every 8th training sample (10 Hz → 1.25 Hz): a 60 °C/h ramp moves
# the features by 0.013 °C in 0.8 s, so the ranking holds (measured: stride_rank_correlation).
SEARCH_STRIDE = 8


def data(quick: bool):
    loaded = load_scenario(ROOT / "scenarios/paper_iis328dq.yaml")
    ds = simulate(loaded)
    m = from_dataset(ds)
    cycle = np.array([s.cycle for s in loaded.program.segments])[loaded.program.segment_index(m.time_s)]
    noise = ds["truth/noise_white_g"] + ds["truth/noise_bias_instability_g"] + ds["truth/quantisation_g"]
    train, test = cycle < 2, cycle == 2
    if quick:
        train &= np.arange(len(m)) % 10 == 0
    return m, train, test, noise


def best_rate(fn, evals_per_call, repeat=5):
    fn()
    t = min(_timed(fn) for _ in range(repeat))
    return evals_per_call / t


def _timed(fn):
    t0 = time.perf_counter()
    fn()
    return time.perf_counter() - t0


def fitness_benchmark(Xs: np.ndarray, ys: np.ndarray) -> dict:
    rng = np.random.default_rng(0)
    d = Xs.shape[1]
    npar = n_parameters(d, HIDDEN)
    pop = init_weights(d, HIDDEN, rng, size=POP)
    X32, y32 = torch.as_tensor(Xs, dtype=torch.float32), torch.as_tensor(ys, dtype=torch.float32)
    ours = best_rate(lambda: population_mse(torch.as_tensor(pop, dtype=torch.float32), X32, y32, HIDDEN), POP)
    ours_torch = best_rate(lambda: population_mse(torch.as_tensor(pop, dtype=torch.float32), X32, y32, HIDDEN,
                                                  kernel="torch"), POP)

    counted = [0]  # the peers' rates use the evaluations they actually made

    def user_fitness(solutions):
        """The batched torch fitness a user would write: every network at once via broadcasting."""
        counted[0] += len(solutions)
        with torch.no_grad():
            out = forward(torch.tensor(np.asarray(solutions), dtype=torch.float32), X32, HIDDEN)
            return ((out - y32) ** 2).mean(dim=1)

    import pygad

    generations = 3
    ga = pygad.GA(num_generations=generations, num_parents_mating=POP // 2, sol_per_pop=POP, num_genes=npar,
                  fitness_func=lambda ga_inst, sols, idx: (-user_fitness(sols)).numpy(), fitness_batch_size=POP,
                  init_range_low=-1, init_range_high=1, random_seed=0, suppress_warnings=True, save_solutions=False)
    counted[0] = 0
    t_pygad = _timed(ga.run)
    pygad_rate = counted[0] / t_pygad

    from evotorch import Problem
    from evotorch.algorithms import GeneticAlgorithm
    from evotorch.operators import GaussianMutation, SimulatedBinaryCrossOver

    def evotorch_rate(fitness, generations: int) -> float:
        class Fit(Problem):
            def __init__(self):
                # _evaluate_batch makes it vectorised: the whole population in one call
                super().__init__("min", solution_length=npar, initial_bounds=(-1.0, 1.0), dtype=torch.float32)

            def _evaluate_batch(self, batch):
                batch.set_evals(fitness(batch.values))

        prob = Fit()
        searcher = GeneticAlgorithm(prob, popsize=POP, operators=[
            SimulatedBinaryCrossOver(prob, tournament_size=4, eta=8), GaussianMutation(prob, stdev=0.1)])
        searcher.step()
        counted[0] = 0
        t = _timed(lambda: [searcher.step() for _ in range(generations)])
        return counted[0] / t

    def our_kernel(solutions):
        counted[0] += len(solutions)
        return population_mse(torch.tensor(np.asarray(solutions)), X32, y32, HIDDEN).to(torch.float32)

    evo_rate = evotorch_rate(user_fitness, generations)
    # the same library handed our kernel: how much of the ratio is the kernel, how much the loop
    evo_ours_rate = evotorch_rate(our_kernel, 10 * generations)

    # where the torch kernel's time goes: the activation alone on the hidden pre-activations, chunk by
    # chunk as it runs it (sigmoid: it evaluates tanh networks as sigmoid networks), and the vendor's tanh
    pre = torch.randn(POP * HIDDEN, 4096, dtype=torch.float32)
    buf = torch.empty_like(pre)
    per_chunk = Xs.shape[0] / 4096
    t_sigmoid = min(_timed(lambda: torch.sigmoid(pre, out=buf)) for _ in range(20)) * per_chunk
    t_tanh = min(_timed(lambda: torch.tanh(pre, out=buf)) for _ in range(20)) * per_chunk
    t_eval = POP / ours_torch
    flop = (2 * d * HIDDEN + 2 * HIDDEN + 3) * Xs.shape[0]
    best_peer = max(pygad_rate, evo_rate)
    return {
        "samples": int(Xs.shape[0]),
        "ours_evals_per_s": ours,
        "ours_torch_kernel_evals_per_s": ours_torch,
        "compiled_over_torch_kernel": ours / ours_torch,
        "numba_threads": _numba_threads(),
        "pygad_batched_torch_evals_per_s": pygad_rate,
        "evotorch_vectorized_evals_per_s": evo_rate,
        "evotorch_with_our_kernel_evals_per_s": evo_ours_rate,
        "ratio_ours_over_best_peer": ours / best_peer,
        "target_ratio": 10.0,
        "meets_target": ours / best_peer >= 10.0,
        "gflop_per_s": flop * ours / 1e9,
        "activation_share_of_torch_kernel_eval": t_sigmoid / t_eval,
        "sigmoid_per_s_millions": POP * Xs.shape[0] * HIDDEN / t_sigmoid / 1e6,
        "tanh_per_s_millions": POP * Xs.shape[0] * HIDDEN / t_tanh / 1e6,
    }


def _numba_threads() -> int | None:
    try:
        import numba
    except ImportError:
        return None
    return int(numba.get_num_threads())


def stride_rank_correlation(X: np.ndarray, y: np.ndarray, networks: int = 200) -> float:
    """Spearman correlation of the training MSE of random networks on all samples and on every
    ``SEARCH_STRIDE``-th one: 1 when the strided fitness ranks a population as the full one does."""
    from scipy.stats import spearmanr

    Xs = torch.as_tensor((X - X.mean(0)) / X.std(0), dtype=torch.float32)
    ys = torch.as_tensor((y - y.mean()) / y.std(), dtype=torch.float32)
    pop = torch.as_tensor(init_weights(X.shape[1], HIDDEN, np.random.default_rng(1), size=networks),
                          dtype=torch.float32)
    full = population_mse(pop, Xs, ys, HIDDEN).numpy()
    strided = population_mse(pop, Xs[::SEARCH_STRIDE], ys[::SEARCH_STRIDE], HIDDEN).numpy()
    return float(spearmanr(full, strided).statistic)


def end_to_end(m, train, test, noise, quick: bool) -> dict:
    from sklearn.neural_network import MLPRegressor

    t0 = float(m.temperature_c[train][0])
    y = m.output_g - m.applied_g
    out = {}
    for label, features in (("paper_features", PAPER), ("extension_features", EXTENSION)):
        fs = features.__class__(features.terms, features.delta, t0, features.window_s)
        Xtr = fs.transform(m.temperature_c, m.time_s)
        Xte = Xtr[test]
        Xtr = Xtr[train]
        runs = {}
        for stride in (1, SEARCH_STRIDE):
            model = EvolvedBPNN("psoga", generations=10 if quick else 50, population_size=POP, hidden_size=HIDDEN,
                                bp_iter=100, sample_stride=stride, random_state=0)
            ts = time.perf_counter()
            model.fit(Xtr, y[train])
            runs[stride] = (time.perf_counter() - ts, model)
        mu, sd = Xtr.mean(0), Xtr.std(0)
        ys_mu, ys_sd = y[train].mean(), y[train].std()
        sk = MLPRegressor(hidden_layer_sizes=(HIDDEN,), activation="tanh", solver="lbfgs", max_iter=200, random_state=0)
        ts = time.perf_counter()
        sk.fit((Xtr - mu) / sd, (y[train] - ys_mu) / ys_sd)
        t_sk = time.perf_counter() - ts
        pred = sk.predict((Xte - mu) / sd) * ys_sd + ys_mu
        mse_sk = float(np.mean((m.output_g[test] - pred - m.applied_g[test]) ** 2))
        floor = float(np.mean(noise[test] ** 2))
        out[label] = {"mlpregressor_s": t_sk, "mlpregressor_test_mse": mse_sk, "noise_only_mse": floor,
                      "mlpregressor_over_noise": mse_sk / floor}
        for stride, (t_ours, model) in runs.items():
            mse_ours = float(np.mean((m.output_g[test] - model.predict(Xte) - m.applied_g[test]) ** 2))
            key = "psoga_bpnn" if stride == 1 else f"psoga_bpnn_search_stride_{stride}"
            out[label].update({f"{key}_s": t_ours, f"{key}_wall_ratio": t_ours / t_sk, f"{key}_test_mse": mse_ours,
                               f"{key}_over_noise": mse_ours / floor,
                               f"{key}_test_mse_over_mlpregressor": mse_ours / mse_sk,
                               f"{key}_fitness_evaluations": model.n_evaluations_})
        out[label]["search_stride_fitness_rank_correlation"] = stride_rank_correlation(Xtr, y[train])
    paper = out["paper_features"]
    fast = f"psoga_bpnn_search_stride_{SEARCH_STRIDE}"
    out["target_wall_ratio"] = 2.0
    out["meets_wall_target_full_search"] = paper["psoga_bpnn_wall_ratio"] <= 2.0
    # "at equal test MSE": not more than 1 % above MLPRegressor's test MSE
    out["meets_wall_target_strided_search"] = (paper[f"{fast}_wall_ratio"] <= 2.0
                                               and paper[f"{fast}_test_mse_over_mlpregressor"] <= 1.01)
    out["extension_meets_noise_target"] = out["extension_features"]["psoga_bpnn_over_noise"] <= 1.05
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--json", default="out/bench_fitting.json")
    ap.add_argument("--quick", action="store_true")
    args = ap.parse_args()
    m, train, test, noise = data(args.quick)
    X = PAPER.transform(m.temperature_c, m.time_s)[train]
    y = (m.output_g - m.applied_g)[train]
    Xs = (X - X.mean(0)) / X.std(0)
    ys = (y - y.mean()) / y.std()
    result = {"threads": torch.get_num_threads(), "fitness": fitness_benchmark(Xs, ys),
              "end_to_end": end_to_end(m, train, test, noise, args.quick)}
    write_json(args.json, result)


if __name__ == "__main__":
    main()
