"""The paper's compensators and our extension, registered in the benchmark's order.

Budgets: ``quick`` = 20 generations, population 20, every 4th sample in the population search,
100 L-BFGS iterations; full = 70, 50, every sample, 200. Every network is 4-10-1 tanh (inputs by
feature set) seeded with the test's seed.
"""

from __future__ import annotations

from fitting import BPNN, CONVENTIONAL, EXTENSION, PAPER, EvolvedBPNN, FeatureSet, PolynomialCompensator
from twin.compensation.registry import register_compensator


def _budget(quick: bool, seed: int) -> tuple[dict, dict]:
    """(network keywords, population-search keywords) of one test."""
    bp = 100 if quick else 200
    net = dict(hidden_size=10, activation="tanh", random_state=seed)
    search = dict(generations=20 if quick else 70, population_size=20 if quick else 50, bp_iter=bp,
                  sample_stride=4 if quick else 1)
    return {"max_iter": bp, **net}, {**search, **net}


@register_compensator("conventional", "conventional BPNN (ΔT, ΔT²)")
def conventional(quick: bool, seed: int):
    return CONVENTIONAL, BPNN(**_budget(quick, seed)[0])


@register_compensator("model1", "Model 1 BPNN (T, T², ΔT, ΔT²)")
def model1(quick: bool, seed: int):
    return PAPER, BPNN(**_budget(quick, seed)[0])


@register_compensator("model2_ga", "Model 2 GA-BPNN")
def model2_ga(quick: bool, seed: int):
    return PAPER, EvolvedBPNN("ga", **_budget(quick, seed)[1])


@register_compensator("model3_psoga", "Model 3 PSO-GA-BPNN")
def model3_psoga(quick: bool, seed: int):
    return PAPER, EvolvedBPNN("psoga", **_budget(quick, seed)[1])


@register_compensator("polynomial_T", "polynomial in T (order by validation)")
def polynomial_t(quick: bool, seed: int):
    return FeatureSet(("T",)), PolynomialCompensator(max_order=6)


@register_compensator("extension_bpnn_dTdt", "our extension: BPNN (paper features + dT/dt)")
def extension_bpnn_dtdt(quick: bool, seed: int):
    return EXTENSION, BPNN(**_budget(quick, seed)[0])
