"""The result of ``twin benchmark``: typed, and written to JSON field for field.

:func:`twin.compensation.benchmark.run_benchmark` builds a :class:`BenchmarkResult`; the CLI adds
the optimisers' runs on eq. (45). The JSON and its schema (``twin schema --result benchmark``)
derive from these types through :mod:`twin.results`.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Union

from twin.results import to_json


@dataclass(frozen=True)
class Table1Row:
    """One compensator's row of the paper's Table 1, over Tests 1..N.

    Attributes
    ----------
    model : str
        The compensator (``physics_twin`` for the calibrated twin).
    mse : tuple of float
        Test MSE of the compensated output per test [g²].
    mse_mean, mse_std : float
        Their mean and standard deviation [g²].
    ratio_to_noise_floor : tuple of float
        Each test's MSE over its noise-only MSE [1].
    ratio_mean : float
        Their mean [1].
    Q_percent : tuple of float, optional
        Per test, |MSE − MSE_conventional| / MSE_conventional [%] (eq. (47)); absent for the
        conventional model.
    improves_on_conventional : tuple of bool, optional
        Per test, whether the MSE is below the conventional model's; absent for that model.
    """

    model: str
    mse: tuple[float, ...]
    mse_mean: float
    mse_std: float
    ratio_to_noise_floor: tuple[float, ...]
    ratio_mean: float
    Q_percent: tuple[float, ...] | None = None
    improves_on_conventional: tuple[bool, ...] | None = None


@dataclass(frozen=True)
class MeanStd:
    """Mean and standard deviation over the tests of an MSE.

    Attributes
    ----------
    mean, std : float
        [g²].
    """

    mean: float
    std: float


@dataclass(frozen=True)
class SearchConvergence:
    """One population search's row of the paper's Table 2.

    Attributes
    ----------
    mse_g2_at_iteration : dict of str to MeanStd
        Iteration (``"14"`` … ``"70"``) → the best training MSE after it, over the tests [g²].
    fitness_evaluations : tuple of int
        Fitness evaluations per test [1].
    bp_iterations : tuple of int
        Back-propagation iterations of the final network per test [1].
    iterations_run : tuple of int
        Search iterations run per test [1].
    """

    mse_g2_at_iteration: dict[str, MeanStd]
    fitness_evaluations: tuple[int, ...]
    bp_iterations: tuple[int, ...]
    iterations_run: tuple[int, ...]


@dataclass(frozen=True)
class FitTime:
    """The time one compensator took to fit.

    Attributes
    ----------
    fit_s : float
        [s].
    """

    fit_s: float


@dataclass(frozen=True)
class OptimizerRun:
    """One optimiser on eq. (45): how often and how fast it reached the minimum.

    Attributes
    ----------
    seeds : int
        Random states tried.
    reached : int
        Of them, those that reached |z − z*| < 1e-6.
    iterations_q25_median_q75, evaluations_q25_median_q75 : tuple of float or None
        Quartiles and median of the iterations and fitness evaluations [1] of the seeds that
        reached it (None when none did).
    """

    seeds: int
    reached: int
    iterations_q25_median_q75: tuple[float, float, float] | None
    evaluations_q25_median_q75: tuple[float, float, float] | None


#: an entry of ``optimizers``: an optimiser's run (``GA``, ``GA_binary``, ``PSO``, ``PSO-GA``), the
#: paper's iteration counts (``paper``: ``GA_iterations``, ``PSO-GA_iterations``) or ``z_star`` [1]
OptimizerEntry = Union[OptimizerRun, dict[str, int], float]


@dataclass(frozen=True)
class BenchmarkResult:
    """What ``twin benchmark --json`` writes.

    Attributes
    ----------
    quick : bool
        The short budget (1 Hz data).
    tests : int
        Independent tests (seeds).
    noise_floor_mse : float
        Mean MSE of the sensor noise alone over the tests [g²].
    noise_floor_mse_per_test : tuple of float
        [g²].
    table1 : tuple of Table1Row
        The paper's Table 1, one row per compensator.
    table2 : dict of str to SearchConvergence
        The paper's Table 2, per population search.
    extrapolation_split, ramp_rate_split : dict of str to float or None
        Compensator (and ``noise_floor``) → test MSE on Test 1's split [g²].
    verdicts : tuple of str
        One sentence per comparison.
    timings_s : dict of str to dict of str to FitTime
        Test (``test1`` …) → compensator → its fit time.
    optimizers : dict of str to OptimizerEntry, optional
        The optimisers on eq. (45) (:func:`twin.compensation.benchmark.optimizer_benchmark`).
    """

    quick: bool
    tests: int
    noise_floor_mse: float
    noise_floor_mse_per_test: tuple[float, ...]
    table1: tuple[Table1Row, ...]
    table2: dict[str, SearchConvergence]
    extrapolation_split: dict[str, float] | None
    ramp_rate_split: dict[str, float] | None
    verdicts: tuple[str, ...]
    timings_s: dict[str, dict[str, FitTime]]
    optimizers: dict[str, OptimizerEntry] | None = None

    def to_json(self) -> dict:
        """The JSON document (:func:`twin.results.to_json`).

        Returns
        -------
        dict
        """
        return to_json(self)
