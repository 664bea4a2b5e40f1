"""The plan checked by simulation: each rival as the truth, the test simulated and diagnosed blind,
how often the diagnosis names the truth first (docs/plan.md §4).

Each seed draws the truth's parameters from their uncertainty and simulates the test with its own
noise; the diagnosis sees the twin's scenario and the log, never the truth. Rates come with a 95 %
Wilson interval.
"""

from __future__ import annotations

import math
from collections import Counter
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from twin.plan.hypotheses import NONE, Hypothesis
from twin.plan.scenarios import load, with_hypothesis


@dataclass(frozen=True)
class CheckRate:
    """How often the diagnosis named the truth first on the simulated test.

    Attributes
    ----------
    truth : str
        The hypothesis simulated as the truth (``none``: the twin alone).
    seeds : int
    named_first : int
        Seeds on which the diagnosis named ``truth`` first (for ``none``: named nothing).
    rate : float
        named_first / seeds [1].
    ci95 : tuple of float
        95 % Wilson interval of the rate [1].
    predicted : float or None
        The separation's predicted rate [1] (None for ``none``).
    named : dict of str to int
        What the diagnosis named first, over the seeds (``none``: nothing).
    """

    truth: str
    seeds: int
    named_first: int
    rate: float
    ci95: tuple[float, float]
    predicted: float | None
    named: dict[str, int]


def wilson_interval(k: int, n: int, z: float = 1.96) -> tuple[float, float]:
    """95 % Wilson score interval of a binomial rate k/n.

    Parameters
    ----------
    k, n : int
        Successes and trials.
    z : float
        Normal quantile (1.96: 95 %).

    Returns
    -------
    tuple of float

    References
    ----------
    Wilson, E. B. (1927), Probable inference, the law of succession, and statistical inference,
    *J. Am. Stat. Assoc.* 22:209–212.
    """
    if n == 0:
        return (0.0, 1.0)
    p = k / n
    d = 1 + z * z / n
    c = (p + z * z / (2 * n)) / d
    h = z * math.sqrt(p * (1 - p) / n + z * z / (4 * n * n)) / d
    return (max(0.0, c - h), min(1.0, c + h))


def diagnose_once(job: tuple[dict, Hypothesis, int]) -> str:
    """Simulate the test with the hypothesis as truth (drawn at the seed) and diagnose it blind.

    Parameters
    ----------
    job : tuple
        (scenario dict, hypothesis, seed).

    Returns
    -------
    str
        The effect named first, or ``none``.
    """
    from twin.diagnosis.diagnose import diagnose
    from twin.estimation.problem import DiagnosisConfig, Problem
    from twin.measurement import from_dataset
    from twin.model.simulate import simulate

    scenario, hyp, seed = job
    values = hyp.draw(np.random.default_rng(np.random.SeedSequence([seed, 7])))
    truth = load(with_hypothesis(scenario, hyp, values), "<plan check>")
    ds = simulate(truth, seed=seed)
    d = diagnose(Problem(from_dataset(ds), DiagnosisConfig()), truth.twin_composition())
    return d.selected[0].effect if d.selected else NONE


def run_jobs(fn: Callable, jobs: list, workers: int = 1, executor: str = "local", scheduler: str | None = None,
             progress: Callable[[int, int], None] | None = None) -> list:
    """``[fn(j) for j in jobs]`` in order, on ``workers`` local processes or a Dask cluster.

    Parameters
    ----------
    fn : callable
        A picklable function of one job.
    jobs : list
    workers : int
    executor : {"local", "dask"}
    scheduler : str, optional
        A running Dask scheduler's address (default: a local cluster of ``workers``).
    progress : callable, optional
        ``progress(done, total)``.

    Returns
    -------
    list
    """
    tick = progress or (lambda done, total: None)
    out: list = [None] * len(jobs)
    if executor == "dask":
        from dask.distributed import Client, LocalCluster, as_completed

        cluster = None if scheduler else LocalCluster(n_workers=workers, threads_per_worker=1, processes=True)
        with Client(scheduler or cluster) as client:
            futures = {client.submit(fn, j, pure=False): k for k, j in enumerate(jobs)}
            for done, fut in enumerate(as_completed(futures), 1):
                out[futures[fut]] = fut.result()
                tick(done, len(jobs))
        if cluster is not None:
            cluster.close()
        return out
    if workers <= 1:
        for k, j in enumerate(jobs):
            out[k] = fn(j)
            tick(k + 1, len(jobs))
        return out
    from concurrent.futures import ProcessPoolExecutor, as_completed as done_first

    with ProcessPoolExecutor(workers) as ex:
        futures = {ex.submit(fn, j): k for k, j in enumerate(jobs)}
        for done, fut in enumerate(done_first(futures), 1):
            out[futures[fut]] = fut.result()
            tick(done, len(jobs))
    return out


def check_plan(scenario: dict, hyps: list[Hypothesis], seeds: int, predicted: dict[str, float],
               first_seed: int = 1000, runner: Callable[[Callable, list], list] | None = None) -> tuple[CheckRate, ...]:
    """Each hypothesis as the truth on ``seeds`` simulated tests, diagnosed blind.

    Parameters
    ----------
    scenario : dict
        The planned test (twin alone as device).
    hyps : list of Hypothesis
    seeds : int
        Simulated tests per hypothesis.
    predicted : dict of str to float
        The predicted rates, carried into the records.
    first_seed : int
        Seed of the first test (the others follow).
    runner : callable, optional
        ``runner(fn, jobs)`` → results in order (default: :func:`run_jobs` in this process).

    Returns
    -------
    tuple of CheckRate
    """
    jobs = [(scenario, h, first_seed + s) for h in hyps for s in range(seeds)]
    named = (runner or run_jobs)(diagnose_once, jobs)
    out = []
    for k, h in enumerate(hyps):
        mine = named[k * seeds:(k + 1) * seeds]
        hits = sum(n == h.effect for n in mine)
        out.append(CheckRate(h.effect, seeds, hits, hits / seeds if seeds else 0.0, wilson_interval(hits, seeds),
                             predicted.get(h.effect), dict(Counter(mine).most_common())))
    return tuple(out)
