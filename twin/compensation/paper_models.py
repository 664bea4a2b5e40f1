"""The paper's compensators and our extension, in the benchmark's order (registered by
:mod:`twin.compensation.registry`).

Budgets: ``quick`` = 20 generations, population 20, every 4th sample in the population search,
100 L-BFGS iterations; full = 70, 50, every sample, 200. Every network is 4-10-1 tanh (inputs by
feature set) seeded with the test's seed.
"""

from __future__ import annotations

from fitting import BPNN, CONVENTIONAL, EXTENSION, PAPER, EvolvedBPNN, FeatureSet, PolynomialCompensator


def _budget(quick: bool, seed: int) -> tuple[dict, dict]:
    """(network keywords, population-search keywords) of one test."""
    bp = 100 if quick else 200
    net = dict(hidden_size=10, activation="tanh", random_state=seed)
    search = dict(generations=20 if quick else 70, population_size=20 if quick else 50, bp_iter=bp,
                  sample_stride=4 if quick else 1)
    return {"max_iter": bp, **net}, {**search, **net}


def conventional(quick: bool, seed: int):
    """The conventional model: a BPNN on (ΔT, ΔT²).

    Parameters
    ----------
    quick : bool
        The short budget (module docstring).
    seed : int
        The test's seed (the network's random state).

    Returns
    -------
    features : FeatureSet
        ΔT [°C], ΔT² [°C²].
    estimator : BPNN
        Unfitted; predicts the drift ``output − applied`` [g].

    References
    ----------
    Qi et al. (2022), Micromachines 13, 2156, Table 1 (the conventional model).
    """
    return CONVENTIONAL, BPNN(**_budget(quick, seed)[0])


def model1(quick: bool, seed: int):
    """Model 1: a BPNN on the paper's features (T, T², ΔT, ΔT²).

    Parameters
    ----------
    quick : bool
        The short budget (module docstring).
    seed : int
        The test's seed (the network's random state).

    Returns
    -------
    features : FeatureSet
        T [°C], T² [°C²], ΔT [°C], ΔT² [°C²].
    estimator : BPNN
        Unfitted; predicts the drift ``output − applied`` [g].

    References
    ----------
    Qi et al. (2022), Micromachines 13, 2156, §2.2.2 and Table 1 (Model 1).
    """
    return PAPER, BPNN(**_budget(quick, seed)[0])


def model2_ga(quick: bool, seed: int):
    """Model 2: a BPNN whose initial weights a GA searches (GA-BPNN), on the paper's features.

    Parameters
    ----------
    quick : bool
        The short budget (module docstring).
    seed : int
        The test's seed (the network's random state).

    Returns
    -------
    features : FeatureSet
        T, T², ΔT, ΔT² [°C, °C²].
    estimator : EvolvedBPNN
        Unfitted; predicts the drift ``output − applied`` [g].

    References
    ----------
    Qi et al. (2022), Micromachines 13, 2156, §2.2.2 and Table 1 (Model 2).
    """
    return PAPER, EvolvedBPNN("ga", **_budget(quick, seed)[1])


def model3_psoga(quick: bool, seed: int):
    """Model 3: a BPNN whose initial weights a PSO-GA searches (PSO-GA-BPNN), on the paper's features.

    Parameters
    ----------
    quick : bool
        The short budget (module docstring).
    seed : int
        The test's seed (the network's random state).

    Returns
    -------
    features : FeatureSet
        T, T², ΔT, ΔT² [°C, °C²].
    estimator : EvolvedBPNN
        Unfitted; predicts the drift ``output − applied`` [g].

    References
    ----------
    Qi et al. (2022), Micromachines 13, 2156, §2.2.2 and Table 1 (Model 3).
    """
    return PAPER, EvolvedBPNN("psoga", **_budget(quick, seed)[1])


def polynomial_t(quick: bool, seed: int):
    """A polynomial in T, order 1..6 chosen by validation (a baseline, not in the paper).

    Parameters
    ----------
    quick : bool
        The short budget (module docstring); unused.
    seed : int
        The test's seed; unused (least squares).

    Returns
    -------
    features : FeatureSet
        T [°C].
    estimator : PolynomialCompensator
        Unfitted; predicts the drift ``output − applied`` [g].
    """
    return FeatureSet(("T",)), PolynomialCompensator(max_order=6)


def extension_bpnn_dtdt(quick: bool, seed: int):
    """Our extension: a BPNN on the paper's features and dT/dt (not in the paper).

    Parameters
    ----------
    quick : bool
        The short budget (module docstring).
    seed : int
        The test's seed (the network's random state).

    Returns
    -------
    features : FeatureSet
        T, T², ΔT, ΔT² [°C, °C²], dT/dt [°C/min].
    estimator : BPNN
        Unfitted; predicts the drift ``output − applied`` [g].
    """
    return EXTENSION, BPNN(**_budget(quick, seed)[0])


#: (name, label, factory) of each built-in compensator, in the benchmark's order
BUILTIN = (
    ("conventional", "conventional BPNN (ΔT, ΔT²)", conventional),
    ("model1", "Model 1 BPNN (T, T², ΔT, ΔT²)", model1),
    ("model2_ga", "Model 2 GA-BPNN", model2_ga),
    ("model3_psoga", "Model 3 PSO-GA-BPNN", model3_psoga),
    ("polynomial_T", "polynomial in T (order by validation)", polynomial_t),
    ("extension_bpnn_dTdt", "our extension: BPNN (paper features + dT/dt)", extension_bpnn_dtdt),
)
