"""Population optimisers sharing one template: GA (real-valued and the paper's binary encoding),
PSO (standard inertia-weight update) and the PSO-GA hybrid of the paper.

The base class owns bounds, the random generator, the budget, stopping and the history; each
algorithm writes only its search step (architecture principle 7). Objectives are *batched*:
``f(X)`` takes the whole population (P, d) and returns (P,) — for networks, one tensor operation.

scikit-learn contract: ``__init__`` only stores; validation in :meth:`fit`; randomness only from
``random_state``; fitted attributes end in ``_``: ``x_``, ``fun_``, ``history_`` (best value per
iteration), ``n_iter_``, ``n_evaluations_``.

References
----------
Holland (1975) / Goldberg (1989) for the GA; the paper's eq. (39) binary encoding. Shi & Eberhart
(1998) inertia-weight PSO: v ← w v + c1 r1 (p − x) + c2 r2 (g − x), x ← x + v (the paper's
eq. 43 is garbled: docs/physics.md §3 row 22).
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
from sklearn.base import BaseEstimator

Objective = Callable[[np.ndarray], np.ndarray]


class PopulationOptimizer(BaseEstimator):
    """Template: initialise a population in the box, step until the budget or the target.

    Parameters
    ----------
    population_size, max_iter : int
        Members of the population; iteration budget.
    target : float, optional
        Stop when the best value is ≤ ``target`` [unit of the objective].
    tol_iter : int, optional
        Stop after this many iterations without improvement.
    random_state : int or None
        Seed.
    """

    def __init__(self, population_size=50, max_iter=100, target=None, tol_iter=None, random_state=None):
        self.population_size = population_size
        self.max_iter = max_iter
        self.target = target  # stop when the best value is ≤ target
        self.tol_iter = tol_iter  # stop after this many iterations without improvement
        self.random_state = random_state

    # -- subclasses implement these
    def _initialize(self, rng, lo, hi, f) -> None:
        self.pop_ = lo + rng.random((self.population_size, lo.size)) * (hi - lo)
        self.pop_fit_ = self._evaluate(f, self.pop_)

    def _step(self, rng, lo, hi, f) -> None:  # pragma: no cover - abstract
        raise NotImplementedError

    # -- shared machinery
    def _evaluate(self, f: Objective, X: np.ndarray) -> np.ndarray:
        self.n_evaluations_ += X.shape[0]
        values = np.asarray(f(X), float).ravel()
        if values.shape != (X.shape[0],):
            raise ValueError(f"the objective must return one value per row: got shape {values.shape} for {X.shape[0]} rows")
        return np.where(np.isfinite(values), values, np.inf)

    def _record(self) -> None:
        k = int(np.argmin(self.pop_fit_))
        if self.pop_fit_[k] < self.fun_:
            self.fun_, self.x_ = float(self.pop_fit_[k]), self.pop_[k].copy()
        self.history_.append(self.fun_)

    def fit(self, objective: Objective, bounds, x0: np.ndarray | None = None, callback=None):
        """Minimise a batched ``objective`` over ``bounds``.

        Parameters
        ----------
        objective : callable
            ``f(X)``: (P, d) → (P,) values [any unit]; non-finite values count as +inf.
        bounds : sequence or ndarray
            [(lo, hi), ...] or (lo, hi) arrays [unit of x].
        x0 : ndarray, optional
            (k, d) points seeding part of the initial population.
        callback : callable, optional
            ``callback(self)``, called after each iteration.

        Returns
        -------
        self : PopulationOptimizer
            Fitted: ``x_``, ``fun_``, ``history_``, ``n_iter_``, ``n_evaluations_``.
        """
        if not (isinstance(self.population_size, (int, np.integer)) and self.population_size >= 2):
            raise ValueError(f"population_size must be an integer >= 2, got {self.population_size!r}")
        if not (isinstance(self.max_iter, (int, np.integer)) and self.max_iter >= 0):
            raise ValueError(f"max_iter must be a non-negative integer, got {self.max_iter!r}")
        b = np.asarray(bounds, float)
        lo, hi = (b[:, 0], b[:, 1]) if b.ndim == 2 and b.shape[1] == 2 else (b[0], b[1])
        if np.any(hi <= lo):
            raise ValueError("every bound needs lo < hi")
        rng = np.random.default_rng(self.random_state)
        self.n_evaluations_, self.n_iter_, self.last_restart_ = 0, 0, 0
        self.history_, self.fun_, self.x_ = [], np.inf, None
        self._initialize(rng, lo, hi, objective)
        if x0 is not None:
            seeds = np.clip(np.atleast_2d(np.asarray(x0, float)), lo, hi)[: self.population_size]
            self.pop_[: len(seeds)] = seeds
            self.pop_fit_[: len(seeds)] = self._evaluate(objective, seeds)
        self._after_init(rng, lo, hi)
        self._record()
        stall = 0
        for _ in range(int(self.max_iter)):
            if self.target is not None and self.fun_ <= self.target:
                break
            before = self.fun_
            self._step(rng, lo, hi, objective)
            self.n_iter_ += 1
            self._record()
            if callback is not None:
                callback(self)
            stall = stall + 1 if self.fun_ >= before else 0
            if self.tol_iter is not None and stall >= self.tol_iter:
                break
        return self

    def _after_init(self, rng, lo, hi) -> None:
        """Hook for state derived from the initial population (PSO velocities, bests)."""


def _with_immigrants(rng, population: np.ndarray, share: float, lo, hi) -> np.ndarray:
    """Replace a share of the population by fresh random points: random immigrants keep a GA's
    search global (Grefenstette 1992)."""
    k = int(round(share * population.shape[0]))
    if k:
        population[rng.choice(population.shape[0], k, replace=False)] = lo + rng.random((k, lo.size)) * (hi - lo)
    return population


class GeneticOperators:
    """One GA generation's variation: tournament selection, crossover and mutation.

    Built once per fit and shared by :class:`GA` and :class:`PSOGA` (composition, not a GA built
    inside every PSO-GA step). ``encoding="real"``: blend (BLX-α) crossover and Gaussian mutation
    whose scale shrinks with ``progress`` (0 at the start of the run, 1 at the budget).
    ``encoding="binary"``: the paper's eq. (39) — each variable as ``n_bits`` Gray-coded bits on
    its interval, single-point crossover, bit-flip mutation (GA: Holland 1975 / Goldberg 1989).

    Parameters
    ----------
    crossover_rate, mutation_rate : float
        Probability of crossover per child; of mutation per variable (binary: ``mutation_rate / n_bits``
        per bit) [1].
    mutation_scale : float
        Gaussian mutation σ as a share of the box width at the start, shrinking as (1 − progress)² [1].
    encoding : {"real", "binary"}
    n_bits : int
        Bits per variable (binary encoding).
    """

    def __init__(self, crossover_rate=0.9, mutation_rate=0.1, mutation_scale=0.1, encoding="real", n_bits=24):
        if encoding not in ("real", "binary"):
            raise ValueError(f"encoding must be 'real' or 'binary', got {encoding!r}")
        self.crossover_rate = crossover_rate
        self.mutation_rate = mutation_rate
        self.mutation_scale = mutation_scale
        self.encoding = encoding
        self.n_bits = n_bits

    @staticmethod
    def tournament(rng, fitness: np.ndarray, k: int = 2) -> np.ndarray:
        """Indices of the winners of ``len(fitness)`` tournaments of ``k`` (lowest value wins).

        Parameters
        ----------
        rng : numpy.random.Generator
        fitness : ndarray
            Objective value of each member.
        k : int
            Tournament size.

        Returns
        -------
        ndarray of int
        """
        n = fitness.shape[0]
        idx = rng.integers(0, n, (n, k))
        return idx[np.arange(n), np.argmin(fitness[idx], axis=1)]

    def offspring(self, rng, population: np.ndarray, fitness: np.ndarray, lo, hi, progress: float) -> np.ndarray:
        """Children of ``population`` (one per member), inside the box [lo, hi].

        Parameters
        ----------
        rng : numpy.random.Generator
        population, fitness : ndarray
            Members (P, d) and their objective values (P,).
        lo, hi : ndarray
            The box [unit of x].
        progress : float
            Share of the budget used, 0 to 1 [1].

        Returns
        -------
        ndarray
            Children (P, d).
        """
        n = population.shape[0]
        parents = population[self.tournament(rng, fitness)]
        mates = parents[rng.permutation(n)]
        if self.encoding == "binary":
            return self._binary(rng, parents, mates, lo, hi)
        alpha = 0.3
        u = rng.uniform(-alpha, 1 + alpha, parents.shape)
        child = np.where(rng.random((n, 1)) < self.crossover_rate, parents + u * (mates - parents), parents)
        scale = self.mutation_scale * (hi - lo) * (1 - progress) ** 2 + 1e-9 * (hi - lo)
        mutate = rng.random(child.shape) < self.mutation_rate
        return np.clip(child + mutate * rng.normal(0, 1, child.shape) * scale, lo, hi)

    def _binary(self, rng, parents, mates, lo, hi):
        n = parents.shape[0]
        levels = 2**self.n_bits - 1

        def encode(x):  # eq. (39): x = lo + (hi − lo) · integer / (2^n − 1), integer Gray-coded
            ints = np.rint((x - lo) / (hi - lo) * levels).astype(np.int64)
            gray = ints ^ (ints >> 1)  # neighbouring values differ by one bit: no Hamming cliffs
            return ((gray[..., None] >> np.arange(self.n_bits)) & 1).astype(np.int8)

        def decode(bits):
            gray = (bits.astype(np.int64) << np.arange(self.n_bits)).sum(axis=-1)
            ints, shift = gray.copy(), 1
            while shift < self.n_bits:
                ints ^= ints >> shift
                shift *= 2
            return lo + (hi - lo) * ints / levels
        a, b = encode(parents).reshape(n, -1), encode(mates).reshape(n, -1)
        cut = rng.integers(1, a.shape[1], n)
        mask = np.arange(a.shape[1])[None, :] >= cut[:, None]
        cross = rng.random((n, 1)) < self.crossover_rate
        child = np.where(cross & mask, b, a)
        flip = rng.random(child.shape) < self.mutation_rate / self.n_bits
        child = np.where(flip, 1 - child, child)
        return decode(child.reshape(n, lo.size, self.n_bits))


class GA(PopulationOptimizer):
    """Genetic algorithm: tournament selection, crossover, mutation, random immigrants, elitism.

    Variation by :class:`GeneticOperators`; ``encoding`` ``"real"`` or ``"binary"`` (the paper's eq. 39).

    Parameters
    ----------
    population_size, max_iter, target, tol_iter, random_state
        As in :class:`PopulationOptimizer`.
    crossover_rate, mutation_rate, mutation_scale, encoding, n_bits
        As in :class:`GeneticOperators`.
    elite : int
        Best members carried over unchanged each generation.
    immigrants : float
        Share of each generation replaced by random points (Grefenstette 1992) [1].
    """

    def __init__(self, population_size=50, max_iter=100, crossover_rate=0.9, mutation_rate=0.1,
                 mutation_scale=0.1, elite=2, immigrants=0.1, encoding="real", n_bits=24, target=None,
                 tol_iter=None, random_state=None):
        super().__init__(population_size, max_iter, target, tol_iter, random_state)
        self.immigrants = immigrants
        self.crossover_rate = crossover_rate
        self.mutation_rate = mutation_rate
        self.mutation_scale = mutation_scale
        self.elite = elite
        self.encoding = encoding
        self.n_bits = n_bits

    def _after_init(self, rng, lo, hi) -> None:
        self.operators_ = GeneticOperators(self.crossover_rate, self.mutation_rate, self.mutation_scale,
                                           self.encoding, self.n_bits)

    def _step(self, rng, lo, hi, f):
        progress = self.n_iter_ / max(1, self.max_iter)
        child = self.operators_.offspring(rng, self.pop_, self.pop_fit_, lo, hi, progress)
        child = _with_immigrants(rng, child, self.immigrants, lo, hi)
        fit = self._evaluate(f, child)
        elite = np.argsort(self.pop_fit_)[: self.elite]
        worst = np.argsort(fit)[::-1][: self.elite]
        child[worst], fit[worst] = self.pop_[elite], self.pop_fit_[elite]
        self.pop_, self.pop_fit_ = child, fit


class PSO(PopulationOptimizer):
    """Particle swarm, inertia weight decreasing linearly from ``w_start`` to ``w_end``.

    Inertia-weight update of Shi & Eberhart (1998) (module docstring); ``neighbours`` > 0 uses a ring (lbest)
    topology (Kennedy & Mendes 2002), 0 the global best.

    Parameters
    ----------
    population_size, max_iter, target, tol_iter, random_state
        As in :class:`PopulationOptimizer`.
    w_start, w_end : float
        Inertia weight at the start and at the end of the budget [1].
    c1, c2 : float
        Cognitive and social acceleration coefficients [1].
    max_velocity : float
        Velocity limit as a share of the box width [1].
    neighbours : int
        Ring neighbours on each side; 0: global best.
    restart_after : int or None
        Iterations without a new best before the swarm is scattered again (best particle kept).
    """

    def __init__(self, population_size=50, max_iter=100, w_start=0.9, w_end=0.4, c1=1.5, c2=1.5,
                 max_velocity=0.2, neighbours=2, restart_after=40, target=None, tol_iter=None, random_state=None):
        super().__init__(population_size, max_iter, target, tol_iter, random_state)
        self.neighbours = neighbours
        self.restart_after = restart_after
        self.w_start = w_start
        self.w_end = w_end
        self.c1 = c1
        self.c2 = c2
        self.max_velocity = max_velocity

    def _after_init(self, rng, lo, hi):
        self.velocity_ = (rng.random(self.pop_.shape) - 0.5) * (hi - lo) * 0.1
        self.pbest_, self.pbest_fit_ = self.pop_.copy(), self.pop_fit_.copy()

    def _move(self, rng, lo, hi):
        progress = self.n_iter_ / max(1, self.max_iter)
        w = self.w_start + (self.w_end - self.w_start) * progress
        if self.neighbours:  # ring (lbest) topology: each particle follows its neighbourhood's best
            ring = (np.arange(self.population_size)[:, None] + np.arange(-self.neighbours, self.neighbours + 1)) \
                % self.population_size
            g = self.pbest_[ring[np.arange(self.population_size), np.argmin(self.pbest_fit_[ring], axis=1)]]
        else:  # gbest
            g = self.pbest_[np.argmin(self.pbest_fit_)]
        r1, r2 = rng.random(self.pop_.shape), rng.random(self.pop_.shape)
        v = w * self.velocity_ + self.c1 * r1 * (self.pbest_ - self.pop_) + self.c2 * r2 * (g - self.pop_)
        vmax = self.max_velocity * (hi - lo)
        self.velocity_ = np.clip(v, -vmax, vmax)
        self.pop_ = np.clip(self.pop_ + self.velocity_, lo, hi)

    def _update_bests(self):
        better = self.pop_fit_ < self.pbest_fit_
        self.pbest_[better], self.pbest_fit_[better] = self.pop_[better], self.pop_fit_[better]

    def _record(self) -> None:
        """Best so far, personal bests included (the swarm may have moved away from them)."""
        super()._record()
        if hasattr(self, "pbest_fit_"):
            k = int(np.argmin(self.pbest_fit_))
            if self.pbest_fit_[k] < self.fun_:
                self.fun_, self.x_ = float(self.pbest_fit_[k]), self.pbest_[k].copy()
                self.history_[-1] = self.fun_

    def _maybe_restart(self, rng, lo, hi, f):
        """After ``restart_after`` iterations without a new best, scatter the swarm again
        (keeping the best particle): a trapped swarm explores afresh."""
        if self.restart_after is None:
            return
        waited = self.n_iter_ - getattr(self, "last_restart_", 0)
        if waited >= self.restart_after and self.history_[-1] >= self.history_[-1 - self.restart_after]:
            self.last_restart_ = self.n_iter_
            keep = int(np.argmin(self.pbest_fit_))
            fresh = lo + rng.random(self.pop_.shape) * (hi - lo)
            fresh[keep] = self.pbest_[keep]
            self.pop_ = fresh
            self.pop_fit_ = self._evaluate(f, self.pop_)
            self.velocity_ = (rng.random(self.pop_.shape) - 0.5) * (hi - lo) * 0.1
            mask = np.arange(self.population_size) != keep
            self.pbest_[mask], self.pbest_fit_[mask] = self.pop_[mask], self.pop_fit_[mask]

    def _step(self, rng, lo, hi, f):
        self._maybe_restart(rng, lo, hi, f)
        self._move(rng, lo, hi)
        self.pop_fit_ = self._evaluate(f, self.pop_)
        self._update_bests()


class PSOGA(PSO):
    """The paper's hybrid PSO-GA: GA variation, then PSO moves.

    GA crossover and mutation (the same :class:`GeneticOperators` as :class:`GA`, built once per fit), then PSO
    moves the offspring towards the personal and global bests; one iteration = one GA generation + one PSO step
    (two population evaluations).

    Parameters
    ----------
    population_size, max_iter, target, tol_iter, random_state
        As in :class:`PopulationOptimizer`.
    crossover_rate, mutation_rate, mutation_scale, immigrants
        As in :class:`GA` (real encoding).
    w_start, w_end, c1, c2, max_velocity, neighbours, restart_after
        As in :class:`PSO`.
    """

    def __init__(self, population_size=50, max_iter=100, crossover_rate=0.9, mutation_rate=0.1,
                 mutation_scale=0.1, immigrants=0.1, w_start=0.9, w_end=0.4, c1=1.5, c2=1.5, max_velocity=0.2,
                 neighbours=2, restart_after=40, target=None, tol_iter=None, random_state=None):
        super().__init__(population_size, max_iter, w_start, w_end, c1, c2, max_velocity, neighbours, restart_after,
                         target, tol_iter, random_state)
        self.immigrants = immigrants
        self.crossover_rate = crossover_rate
        self.mutation_rate = mutation_rate
        self.mutation_scale = mutation_scale

    def _after_init(self, rng, lo, hi):
        super()._after_init(rng, lo, hi)
        self.operators_ = GeneticOperators(self.crossover_rate, self.mutation_rate, self.mutation_scale)

    def _step(self, rng, lo, hi, f):
        progress = self.n_iter_ / max(1, self.max_iter)
        child = self.operators_.offspring(rng, self.pop_, self.pop_fit_, lo, hi, progress)
        child = _with_immigrants(rng, child, self.immigrants, lo, hi)
        child_fit = self._evaluate(f, child)
        keep = child_fit < self.pop_fit_  # offspring replace their parent position when better
        self.pop_ = np.where(keep[:, None], child, self.pop_)
        self.pop_fit_ = np.where(keep, child_fit, self.pop_fit_)
        self._update_bests()
        self._move(rng, lo, hi)
        self.pop_fit_ = self._evaluate(f, self.pop_)
        self._update_bests()


def eq45(X: np.ndarray) -> np.ndarray:
    """The paper's test function, eq. (45), batched: z = −y sin(2πx) − x cos(2πy).

    Parameters
    ----------
    X : ndarray
        Points (P, 2) or (2,): columns x, y [1].

    Returns
    -------
    ndarray
        z (P,) [1].

    References
    ----------
    Qi et al. (2022), Micromachines 13(6), 835, eq. (45); minimum ``EQ45_MINIMUM`` (docs/physics.md §2.6).
    """
    X = np.atleast_2d(X)
    x, y = X[:, 0], X[:, 1]
    return -y * np.sin(2 * np.pi * x) - x * np.cos(2 * np.pi * y)


EQ45_BOUNDS = [(-2.0, 2.0), (-2.0, 2.0)]
EQ45_MINIMUM = -3.7563359221354  # at (1.7626785533557, -2); docs/physics.md §2.6
