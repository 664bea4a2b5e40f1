"""Compensation models and optimisers: scikit-learn conformance, eq. (45), batched fitness."""

import numpy as np
import pytest
from sklearn.base import clone
from sklearn.utils.estimator_checks import parametrize_with_checks

from fitting import BPNN, CONVENTIONAL, EXTENSION, GA, PAPER, PSO, PSOGA, EvolvedBPNN, FeatureSet, PolynomialCompensator
from fitting.network import forward, init_weights, mse_and_gradient, n_parameters, population_mse
from fitting.optimizers import EQ45_BOUNDS, EQ45_MINIMUM, eq45

ESTIMATORS = [
    BPNN(hidden_size=4, max_iter=30, random_state=0),
    BPNN(hidden_size=3, solver="adam", max_iter=500, learning_rate=0.05, random_state=0),
    PolynomialCompensator(max_order=3),
    EvolvedBPNN(optimizer="ga", generations=3, population_size=8, hidden_size=3, bp_iter=10, random_state=0),
    EvolvedBPNN(optimizer="psoga", generations=3, population_size=8, hidden_size=3, bp_iter=10, random_state=0),
]


@parametrize_with_checks(ESTIMATORS)
def test_sklearn_estimator_contract(estimator, check):
    check(estimator)


OPTIMIZERS = [GA(random_state=0), GA(encoding="binary", random_state=0), PSO(random_state=0), PSOGA(random_state=0)]


@pytest.mark.parametrize("opt", OPTIMIZERS, ids=["GA", "GA-binary", "PSO", "PSO-GA"])
def test_optimizer_finds_eq45_minimum_in_18_of_20_seeds(opt):
    hits = 0
    for seed in range(20):
        o = clone(opt).set_params(population_size=50, max_iter=300, target=EQ45_MINIMUM + 1e-6, random_state=seed)
        o.fit(eq45, EQ45_BOUNDS)
        hits += abs(o.fun_ - EQ45_MINIMUM) < 1e-6
    assert hits >= 18


@pytest.mark.parametrize("opt", OPTIMIZERS, ids=["GA", "GA-binary", "PSO", "PSO-GA"])
def test_optimizer_conformance(opt):
    o = clone(opt).set_params(max_iter=20, population_size=20, random_state=3)
    params = o.get_params()
    assert clone(o).get_params() == params  # __init__ only stores
    a = o.fit(eq45, EQ45_BOUNDS)
    assert a is o and not hasattr(clone(o), "x_")
    b = clone(o).fit(eq45, EQ45_BOUNDS)
    np.testing.assert_array_equal(a.x_, b.x_)  # reproducible with a seed
    assert a.history_ == b.history_ and len(a.history_) == a.n_iter_ + 1
    assert all(x >= y for x, y in zip(a.history_, a.history_[1:]))  # best so far never worsens
    assert np.all((a.x_ >= -2) & (a.x_ <= 2)) and a.fun_ == pytest.approx(float(eq45(a.x_[None])[0]))
    with pytest.raises(ValueError):
        clone(o).set_params(population_size=1).fit(eq45, EQ45_BOUNDS)
    with pytest.raises(ValueError, match="lo < hi"):
        clone(o).fit(eq45, [(1, 0), (0, 1)])


@pytest.mark.parametrize("activation", ["tanh", "relu", "sigmoid"])
@pytest.mark.parametrize("dtype, rtol", [("float64", 1e-12), ("float32", 1e-5)])
def test_population_evaluation_equals_one_by_one(activation, dtype, rtol):
    import torch

    rng = np.random.default_rng(0)
    dt = getattr(torch, dtype)
    X = torch.as_tensor(rng.normal(size=(1000, 4)), dtype=dt)
    y = torch.as_tensor(rng.normal(size=1000), dtype=dt)
    pop = torch.as_tensor(init_weights(4, 10, rng, size=50) + rng.normal(0, 0.3, (50, 61)))
    batched = population_mse(pop, X, y, 10, activation, chunk=300)  # 300 leaves a ragged last chunk
    single = [((forward(pop[i : i + 1].double(), X.double(), 10, activation)[0] - y.double()) ** 2).mean()
              for i in range(50)]
    # float32: the hidden layer is rounded to 2^-24 relative; float64 agrees to summation order
    np.testing.assert_allclose(batched.numpy(), torch.stack(single).numpy(), rtol=rtol)
    assert n_parameters(4, 10) == pop.shape[1] == 61


def test_block_chunk_fits_the_l2_cache_in_powers_of_two():
    from fitting.network import block_chunk

    # 500 rows (50 networks × 10 hidden) of float32: 2 KB per sample
    assert block_chunk(500, 4, 2 << 20) == 1024  # 2 MB L2 (the Intel Xeon measured): 1024 × 2 KB = 2 MB
    assert block_chunk(500, 4, 512 << 10) == 256  # 512 KB: 256, also the floor
    assert block_chunk(500, 4, 32 << 20) == 16384 and block_chunk(500, 8, 2 << 20) == 512
    assert block_chunk(500, 4, 3 << 20) == 1024  # 1536 samples would fit: the power of two below


def test_population_mse_does_not_depend_on_the_chunk():
    import torch

    rng = np.random.default_rng(1)
    X = torch.as_tensor(rng.normal(size=(5000, 4)))
    y = torch.as_tensor(rng.normal(size=5000))
    pop = torch.as_tensor(init_weights(4, 10, rng, size=20))
    ref = population_mse(pop, X, y, 10, chunk=5000).numpy()
    for chunk in (256, 1024, None):  # None: the cache-sized default
        np.testing.assert_allclose(population_mse(pop, X, y, 10, chunk=chunk).numpy(), ref, rtol=1e-12)


@pytest.mark.parametrize("activation", ["tanh", "relu", "sigmoid"])
def test_analytic_gradient_equals_autograd(activation):
    import torch

    rng = np.random.default_rng(4)
    X = torch.as_tensor(rng.normal(size=(500, 3)))
    y = torch.as_tensor(rng.normal(size=500))
    theta = init_weights(3, 7, rng)[0] + rng.normal(0, 0.3, n_parameters(3, 7))
    mse, grad = mse_and_gradient(theta, X, y, 7, activation)
    t = torch.tensor(theta[None, :], requires_grad=True)
    ref = ((forward(t, X, 7, activation)[0] - y) ** 2).mean()
    ref.backward()
    assert mse == pytest.approx(ref.item(), rel=1e-13)
    np.testing.assert_allclose(grad, t.grad[0].numpy(), rtol=1e-10, atol=1e-14)


def test_bpnn_learns_a_smooth_function():
    rng = np.random.default_rng(1)
    X = rng.uniform(-2, 2, (2000, 2))
    y = np.tanh(X[:, 0]) + 0.3 * X[:, 1] ** 2
    m = BPNN(hidden_size=10, max_iter=300, random_state=0).fit(X, y)
    assert np.mean((m.predict(X) - y) ** 2) < 1e-3
    assert m.n_iter_ >= 10 and m.loss_curve_[-1] < m.loss_curve_[0]
    # fewer iterations than one validation interval: the last iterate is still judged and kept
    short = BPNN(hidden_size=10, max_iter=5, random_state=0).fit(X, y)
    start = BPNN(hidden_size=10, max_iter=0, random_state=0).fit(X, y)
    assert short.n_iter_ == 5 and not np.array_equal(short.coef_, start.coef_)
    assert np.mean((short.predict(X) - y) ** 2) < np.mean((start.predict(X) - y) ** 2)


def test_bpnn_trains_on_one_thread_and_restores_the_thread_count():
    """Back-propagation runs torch on one thread (fitting.threads) and gives the caller's count back,
    also after a refused fit; the same seed still gives the same network."""
    import torch

    rng = np.random.default_rng(2)
    X = rng.uniform(-2, 2, (500, 2))
    y = np.tanh(X[:, 0])
    before = torch.get_num_threads()
    a = BPNN(hidden_size=4, max_iter=20, random_state=0).fit(X, y)
    assert torch.get_num_threads() == before
    with pytest.raises(ValueError):
        BPNN(hidden_size=4, max_iter=20, init_weights=np.zeros(3)).fit(X, y)
    assert torch.get_num_threads() == before
    np.testing.assert_array_equal(BPNN(hidden_size=4, max_iter=20, random_state=0).fit(X, y).coef_, a.coef_)


def test_features_name_and_compose():
    t = np.arange(0, 600, 1.0)
    temp = 20 + 0.01 * t
    X = PAPER.transform(temp, t)
    assert PAPER.names() == ["T", "T^2", "dT", "dT^2"]
    np.testing.assert_allclose(X[:, 2], temp - 20)
    # reference ΔT: (ΔT, ΔT²) spans the same space as (T, T²) — the paper's Model 1 adds nothing
    A = np.column_stack([np.ones_like(t), X[:, :2]])
    B = np.column_stack([np.ones_like(t), X[:, 2:]])
    assert np.linalg.matrix_rank(np.column_stack([A, B])) == 3
    win = FeatureSet(("dT",), delta="window", window_s=35.0).transform(temp, t)
    assert win[100, 0] == pytest.approx(0.35)  # 0.01 °C/s × 35 s, no absolute temperature
    assert EXTENSION.names()[-1] == "dT/dt" and EXTENSION.transform(temp, t)[300, -1] == pytest.approx(0.6)
    assert CONVENTIONAL.names() == ["dT", "dT^2"]
    with pytest.raises(ValueError, match="unknown feature"):
        FeatureSet(("T3",))


def test_polynomial_picks_order_by_validation():
    rng = np.random.default_rng(2)
    x = rng.uniform(-1, 1, (3000, 1))
    y = 1 + 2 * x[:, 0] - 3 * x[:, 0] ** 3 + rng.normal(0, 0.01, 3000)
    m = PolynomialCompensator(max_order=6).fit(x, y)
    assert m.order_ == 3


def test_twin_benchmark_quick_json(quick_benchmark):
    import json

    from schemas import check_schema

    b = json.loads((quick_benchmark / "benchmark_quick.json").read_text())
    check_schema(b, "benchmark")
    assert b["noise_floor_mse"] > 0
    models = {row["model"] for row in b["table1"]}
    assert {"conventional", "model1", "model2_ga", "model3_psoga", "polynomial_T", "extension_bpnn_dTdt",
            "physics_twin"} <= models
    for row in b["table1"]:
        assert len(row["mse"]) == 1 and row["ratio_mean"] > 0.95  # nothing beats the noise floor by much
        assert ("Q_percent" in row) == (row["model"] != "conventional")
    assert set(b["table2"]) == {"model2_ga", "model3_psoga"}
    assert set(b["table2"]["model3_psoga"]["mse_g2_at_iteration"]) == {"14", "28", "42", "56", "70"}
    for name in ("GA", "PSO", "PSO-GA"):
        assert b["optimizers"][name]["reached"] >= 18
    twin = next(row for row in b["table1"] if row["model"] == "physics_twin")
    ext = next(row for row in b["table1"] if row["model"] == "extension_bpnn_dTdt")
    assert twin["ratio_mean"] <= 1.05 and ext["ratio_mean"] <= 1.05  # the extensions reach the floor
    assert (quick_benchmark / "rep" / "report.html").is_file()


def test_benchmark_features_reference_the_training_data_for_every_model():
    """ΔT = T − T0 with T0 the first training temperature, for every model in turn (a timer once
    overwrote T0 after the first model, so later models saw a clock reading as T0)."""
    from dataclasses import replace

    from twin.compensation.benchmark import evaluate_split
    from twin.compensation.registry import COMPENSATORS, Compensator
    from twin.measurement import Measurement

    seen = {}

    class Recorder:
        def __init__(self, name):
            self.name = name

        def fit(self, X, y):
            seen[self.name] = X
            return self

        def predict(self, X):
            return np.zeros(len(X))

    real = {name: entry.build(True, 0)[0] for name, entry in COMPENSATORS.items()}
    recorders = [Compensator(name, name, lambda quick, seed, f=f, name=name: (f, Recorder(name)))
                 for name, f in real.items()]
    t = np.arange(200.0)
    temp = 20.0 + 0.05 * t
    m = Measurement(t, temp, np.ones_like(t), np.ones_like(t), np.zeros(t.size, np.int16), np.zeros(t.size, bool),
                    True, ["<test>"])
    out, _, _ = evaluate_split(None, True, 0, m, m, np.zeros(t.size), compensators=recorders, physics_twin=False)
    assert set(seen) == set(real) and list(out) == [*real, "noise_floor"]
    for name, features in real.items():
        expected = replace(features, t0_c=20.0).transform(temp, t)
        np.testing.assert_array_equal(seen[name], expected, err_msg=name)


def test_benchmark_verdicts_call_sub_threshold_differences_level():
    from twin.compensation.benchmark import TIE_PERCENT, verdict

    mse = {"a": 1.0, "b": 1.0 + 0.5 * TIE_PERCENT / 100, "c": 1.05}
    assert "are level" in verdict("a", "b", mse, "A", "B")
    assert "A beats C" in verdict("a", "c", mse, "A", "C") and "(4.8 % lower)" in verdict("a", "c", mse, "A", "C")
    assert "does NOT beat" in verdict("c", "a", mse, "C", "A")


def test_psoga_composes_its_ga_operators_once(monkeypatch):
    """PSO-GA builds its GA operators once per fit and builds no GA (nor calls a GA's private
    method) inside its steps; GA uses the same operators."""
    import fitting.optimizers as fo

    def no_ga(*args, **kwargs):
        raise AssertionError("PSO-GA built a GA")

    monkeypatch.setattr(fo.GA, "__init__", no_ga)
    ids = []
    o = PSOGA(population_size=10, max_iter=5, random_state=0).fit(eq45, EQ45_BOUNDS,
                                                                   callback=lambda s: ids.append(id(s.operators_)))
    assert len(ids) == 5 and len(set(ids)) == 1 and isinstance(o.operators_, fo.GeneticOperators)
    monkeypatch.undo()
    g = GA(population_size=10, max_iter=3, encoding="binary", random_state=0).fit(eq45, EQ45_BOUNDS)
    assert g.operators_.encoding == "binary" and not hasattr(g, "_offspring")


def test_feature_set_has_only_its_documented_fields():
    from dataclasses import fields

    assert [f.name for f in fields(FeatureSet)] == ["terms", "delta", "t0_c", "window_s"]


def test_benchmark_run_time_errors_exit_2_with_one_line(tmp_path, paper_path):
    """A scenario that loads but cannot be split (it never exceeds 30 °C, so the extrapolation
    split has no test data): one line and exit 2, before any model is trained."""
    import yaml

    from conftest import run_cli

    data = yaml.safe_load(paper_path.read_text())
    data["program"] = {"start_c": -20.0, "cycles": 2, "steps": [
        {"type": "hold", "dwell_s": 600}, {"type": "staircase", "target_c": 20.0, "step_c": 0.4, "step_s": 35},
        {"type": "hold", "dwell_s": 600}, {"type": "staircase", "target_c": -20.0, "step_c": 0.4, "step_s": 35}]}
    data["test_plan"]["logger_rate_hz"] = 0.1
    cold = tmp_path / "cold.yaml"
    cold.write_text(yaml.safe_dump(data))
    r = run_cli("benchmark", str(cold), "--seeds", "1")
    assert r.returncode == 2, r.stderr
    assert r.stderr.startswith("twin: error: ") and "extrapolation split" in r.stderr
    assert len(r.stderr.strip().splitlines()) == 1


def test_rational_tanh_is_within_its_bound_of_torch_tanh():
    import torch

    from fitting.kernels import TANH_MAX_ABS_ERROR, tanh_rational_array

    x = np.concatenate([np.linspace(-20, 20, 2_000_001), [-1e30, -8.0, -7.9053, 0.0, 1e-30, 7.9053, 8.0, 1e30]])
    x32 = x.astype(np.float32)
    got = tanh_rational_array(x32).astype(np.float64)
    ref = torch.tanh(torch.as_tensor(x32, dtype=torch.float64)).numpy()
    err = np.abs(got - ref)
    assert err.max() <= TANH_MAX_ABS_ERROR  # the stated bound: 5e-7 (measured 2.7e-7, ~4 ulp of 1)
    assert err.max() > 1e-8  # an approximation, not a call to tanh: the bound is the one that matters
    np.testing.assert_array_equal(tanh_rational_array(-x32), -tanh_rational_array(x32))  # odd
    assert np.all(np.abs(got) <= 1.0) and got[len(x) - 5] == 0.0
    assert 1 - got[-1] <= TANH_MAX_ABS_ERROR and 1 + got[0] <= TANH_MAX_ABS_ERROR  # saturates


@pytest.mark.parametrize("d, hidden", [(1, 10), (4, 10), (4, 7), (5, 10), (9, 3)])  # 1, 2, 3 groups of 4; odd h
def test_compiled_kernel_equals_the_torch_kernel(d, hidden):
    import torch

    rng = np.random.default_rng(d * 100 + hidden)
    X = torch.as_tensor(rng.normal(size=(3001, d)), dtype=torch.float32)
    y = torch.as_tensor(rng.normal(size=3001), dtype=torch.float32)
    pop = torch.as_tensor(init_weights(d, hidden, rng, size=12) + rng.normal(0, 0.5, (12, n_parameters(d, hidden))),
                          dtype=torch.float32)
    compiled = population_mse(pop, X, y, hidden, chunk=1000).numpy()  # a ragged last chunk
    torch_kernel = population_mse(pop, X, y, hidden, kernel="torch").numpy()
    # float32 sums of 1000 terms and a tanh within 5e-7: 1e-5 relative covers both with room
    np.testing.assert_allclose(compiled, torch_kernel, rtol=1e-5)
    assert not np.array_equal(compiled, torch_kernel)  # the compiled path did run


def test_compiled_kernel_does_not_depend_on_the_thread_count():
    import numba
    import torch

    rng = np.random.default_rng(7)
    X = torch.as_tensor(rng.normal(size=(5000, 4)), dtype=torch.float32)
    y = torch.as_tensor(rng.normal(size=5000), dtype=torch.float32)
    pop = torch.as_tensor(init_weights(4, 10, rng, size=9), dtype=torch.float32)
    before = numba.get_num_threads()
    try:
        numba.set_num_threads(1)
        one = population_mse(pop, X, y, 10).numpy()
    finally:
        numba.set_num_threads(before)
    np.testing.assert_array_equal(population_mse(pop, X, y, 10).numpy(), one)  # each network sums alone
