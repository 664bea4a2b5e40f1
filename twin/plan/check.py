"""The plan checked by simulation: each rival as the truth, the test simulated and diagnosed blind,
how often the diagnosis names the truth first (docs/plan.md §4).

Each seed draws the truth's parameters from their uncertainty and simulates the test with its own
noise; the diagnosis sees the twin's scenario and the log, never the truth. Rates come with a 95 %
Wilson interval (:func:`twin.fleet.population.wilson_ci95`, as the fleet's prevalences).
"""

from __future__ import annotations

from collections import Counter
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from dataclasses import dataclass

import numpy as np

from twin.fleet.population import wilson_ci95
from twin.fleet.runner import dask_client, die_with_parent
from twin.plan.hypotheses import NONE, Hypothesis, named_when_true
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
        Seeds on which the diagnosis named ``truth`` first (for ``none`` and ``bias_random_walk``:
        named nothing).
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
    return named_first(simulate_and_diagnose(job))


def named_first(d) -> str:
    """The effect a diagnosis named first, or ``none``.

    Parameters
    ----------
    d : twin.diagnosis.diagnose.Diagnosis

    Returns
    -------
    str
    """
    return d.selected[0].effect if d.selected else NONE


def simulate_and_diagnose(job: tuple[dict, Hypothesis, int]):
    """The diagnosis of :func:`diagnose_once`, whole.

    Parameters
    ----------
    job : tuple
        (scenario dict, hypothesis, seed).

    Returns
    -------
    twin.diagnosis.diagnose.Diagnosis
    """
    from twin.diagnosis.diagnose import diagnose
    from twin.estimation.problem import DiagnosisConfig, Problem
    from twin.measurement import from_dataset
    from twin.model.simulate import simulate

    scenario, hyp, seed = job
    values = hyp.draw(np.random.default_rng(np.random.SeedSequence([seed, 7])))
    truth = load(with_hypothesis(scenario, hyp, values), "<plan check>")
    ds = simulate(truth, seed=seed)
    return diagnose(Problem(from_dataset(ds), DiagnosisConfig()), truth.twin_composition())


@contextmanager
def job_client(executor: str, scheduler: str | None, workers: int) -> Iterator:
    """The Dask client every phase of a plan shares (None for local processes): the fleet's
    :func:`~twin.fleet.runner.dask_client`, so a named scheduler that does not answer is one line; a
    local cluster started here is closed on exit.

    Parameters
    ----------
    executor : {"local", "dask"}
    scheduler : str, optional
        A running Dask scheduler's address (default: a local cluster of ``workers``).
    workers : int

    Yields
    ------
    distributed.Client or None
    """
    if executor != "dask":
        yield None
        return
    client = dask_client(scheduler, workers)
    try:
        yield client
    finally:
        cluster = None if scheduler else client.cluster
        client.close()
        if cluster is not None:
            cluster.close()


def run_jobs(fn: Callable, jobs: list, workers: int = 1, client=None,
             progress: Callable[[int, int], None] | None = None) -> list:
    """``[fn(j) for j in jobs]`` in order, on a Dask ``client`` or on ``workers`` local processes.

    Parameters
    ----------
    fn : callable
        A picklable function of one job.
    jobs : list
    workers : int
        Local processes (without a client).
    client : distributed.Client, optional
        From :func:`job_client`.
    progress : callable, optional
        ``progress(done, total)``.

    Returns
    -------
    list
    """
    tick = progress or (lambda done, total: None)
    out: list = [None] * len(jobs)
    if client is not None:
        from dask.distributed import as_completed

        futures = {client.submit(fn, j, pure=False): k for k, j in enumerate(jobs)}
        for done, fut in enumerate(as_completed(futures), 1):
            out[futures[fut]] = fut.result()
            tick(done, len(jobs))
        return out
    if workers <= 1:
        for k, j in enumerate(jobs):
            out[k] = fn(j)
            tick(k + 1, len(jobs))
        return out
    from concurrent.futures import ProcessPoolExecutor, as_completed as done_first

    with ProcessPoolExecutor(workers, initializer=die_with_parent) as ex:  # a killed plan ends its workers
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
        hits = sum(n == named_when_true(h.effect) for n in mine)
        out.append(CheckRate(h.effect, seeds, hits, hits / seeds if seeds else 0.0, wilson_ci95(hits, seeds) or (0.0, 1.0),
                             predicted.get(h.effect), dict(Counter(mine).most_common())))
    return tuple(out)
