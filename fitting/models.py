"""Compensation models of the paper and baselines, all scikit-learn regressors.

* :class:`PolynomialCompensator` — least-squares polynomial in the features, order chosen on a
  validation split (what autopilot thermal calibration does);
* :class:`EvolvedBPNN` — the paper's GA-BPNN (``optimizer="ga"``) and PSO-GA-BPNN
  (``optimizer="psoga"``): a population of networks is searched for ``generations`` iterations
  (fitness = training MSE of every member, one batched tensor operation), then the winner seeds
  back-propagation (L-BFGS). ``history_`` holds the best training MSE per iteration (Table 2).
"""

from __future__ import annotations

import numpy as np
from sklearn.base import BaseEstimator, RegressorMixin
from sklearn.utils.validation import check_is_fitted, validate_data

from fitting.network import BPNN, init_weights, n_parameters, population_mse
from fitting.optimizers import GA, PSOGA
from fitting.splits import interleaved_validation_mask


class PolynomialCompensator(RegressorMixin, BaseEstimator):
    """Polynomial (no cross terms) in each feature, order 1..``max_order`` chosen by validation MSE.

    Least squares on standardised features; the validation split is interleaved blocks (time series).

    Parameters
    ----------
    max_order : int
        Highest polynomial order tried.
    validation_fraction : float
        Share of the samples held out to choose the order [1].

    Attributes
    ----------
    order_ : int
        Chosen order.
    coef_ : ndarray
        Coefficients, intercept first [unit of y].
    validation_mse_ : dict of int to float
        Validation MSE per order [unit of y squared].
    x_mean_, x_scale_ : ndarray
        Standardisation of the features [unit of each feature].
    """

    def __init__(self, max_order=5, validation_fraction=0.2):
        self.max_order = max_order
        self.validation_fraction = validation_fraction

    def _design(self, X, order):
        Xs = (X - self.x_mean_) / self.x_scale_
        return np.column_stack([np.ones(len(X))] + [Xs**k for k in range(1, order + 1)])

    def fit(self, X, y):
        """Choose the order on the validation split, then fit it on all samples.

        Parameters
        ----------
        X : array_like, shape (n, k)
            Features (e.g. :meth:`fitting.features.FeatureSet.transform`) [unit of each feature].
        y : array_like, shape (n,)
            Target, e.g. the drift to compensate [g].

        Returns
        -------
        PolynomialCompensator
            ``self``, fitted.
        """
        X, y = validate_data(self, X, y, y_numeric=True, dtype=np.float64)
        y = np.asarray(y, float).ravel()
        if not (isinstance(self.max_order, (int, np.integer)) and self.max_order >= 1):
            raise ValueError(f"max_order must be a positive integer, got {self.max_order!r}")
        self.x_mean_, self.x_scale_ = X.mean(axis=0), X.std(axis=0)
        self.x_scale_[self.x_scale_ == 0] = 1.0
        val = interleaved_validation_mask(len(y), self.validation_fraction) if len(y) >= 20 else np.zeros(len(y), bool)
        self.validation_mse_ = {}
        for order in range(1, int(self.max_order) + 1):
            A = self._design(X, order)
            if val.any():
                coef = np.linalg.lstsq(A[~val], y[~val], rcond=None)[0]
                self.validation_mse_[order] = float(np.mean((A[val] @ coef - y[val]) ** 2))
            else:
                self.validation_mse_[order] = float(order)  # no validation data: lowest order
        self.order_ = min(self.validation_mse_, key=self.validation_mse_.get)
        self.coef_ = np.linalg.lstsq(self._design(X, self.order_), y, rcond=None)[0]
        return self

    def predict(self, X):
        """Evaluate the fitted polynomial.

        Parameters
        ----------
        X : array_like, shape (n, k)
            Features [unit of each feature].

        Returns
        -------
        ndarray, shape (n,)
            Prediction [unit of y].
        """
        check_is_fitted(self, "coef_")
        X = validate_data(self, X, reset=False, dtype=np.float64)
        return self._design(X, self.order_) @ self.coef_

    def equation(self, feature_names=None, unit: str = "g") -> str:
        """The fitted polynomial with its values, in standardised features z_j = (x_j − mean_j)/scale_j.

        Parameters
        ----------
        feature_names : list of str, optional
            E.g. ``FeatureSet.names()``; default x0, x1, ….
        unit : str
            Unit of y printed in the equation.

        Returns
        -------
        str
            ``y [unit] = …; z(name) = (name − mean) / scale, …``.
        """
        check_is_fitted(self, "coef_")
        k = self.x_mean_.size
        names = list(feature_names or [f"x{j}" for j in range(k)])
        terms = [f"{self.coef_[0]:+.6g}"]
        for order in range(1, self.order_ + 1):
            for j in range(k):
                power = "" if order == 1 else f"^{order}"
                terms.append(f"{self.coef_[1 + (order - 1) * k + j]:+.6g}·z({names[j]}){power}")
        scales = ", ".join(f"z({n}) = ({n} − {m:.6g}) / {s:.6g}" for n, m, s in zip(names, self.x_mean_, self.x_scale_))
        return f"y [{unit}] = {' '.join(terms)}; {scales}"


class EvolvedBPNN(RegressorMixin, BaseEstimator):
    """BPNN whose initial weights come from a population search (GA or PSO-GA), then L-BFGS.

    Parameters
    ----------
    optimizer : {"ga", "psoga"}
        The paper's GA-BPNN or PSO-GA-BPNN.
    generations : int
        GA generations / PSO-GA iterations.
    population_size : int
        Networks in the population.
    hidden_size : int
        Hidden neurons.
    activation : {"tanh", "relu", "sigmoid"}
        Hidden activation.
    bp_iter : int
        L-BFGS iterations after the search (0: the search winner as it is).
    weight_bound : float
        Search box ±bound for every weight (standardised data) [1].
    sample_stride : int
        Fitness on every k-th training sample (1: all of them).
    random_state : int or None
        Seed.

    Attributes
    ----------
    network_ : BPNN
        The trained network.
    history_ : list of float
        Best training MSE (standardised) after each iteration [1].
    n_evaluations_ : int
        Network evaluations (population size × evaluations per iteration).
    search_best_ : ndarray
        Flat weights of the search winner (standardised data).

    References
    ----------
    Qi et al. (2022), Micromachines 13, 2156: §2.2.2 (BPNN, eqs. 36–38) and Table 2 (MSE per iteration).
    """

    def __init__(self, optimizer="psoga", generations=50, population_size=50, hidden_size=10, activation="tanh",
                 bp_iter=100, weight_bound=3.0, sample_stride=1, random_state=None):
        self.optimizer = optimizer
        self.generations = generations
        self.population_size = population_size
        self.hidden_size = hidden_size
        self.activation = activation
        self.bp_iter = bp_iter
        self.weight_bound = weight_bound
        self.sample_stride = sample_stride
        self.random_state = random_state

    def fit(self, X, y):
        """Search the initial weights with the population optimiser, then train by L-BFGS.

        Parameters
        ----------
        X : array_like, shape (n, k)
            Features [unit of each feature].
        y : array_like, shape (n,)
            Target [e.g. g].

        Returns
        -------
        EvolvedBPNN
            ``self``, fitted.
        """
        import torch

        X, y = validate_data(self, X, y, y_numeric=True, dtype=np.float64)
        y = np.asarray(y, float).ravel()
        if self.optimizer not in ("ga", "psoga"):
            raise ValueError(f"optimizer must be 'ga' or 'psoga', got {self.optimizer!r}")
        rng = np.random.default_rng(self.random_state)
        x_mean, x_scale = X.mean(axis=0), X.std(axis=0)
        x_scale[x_scale == 0] = 1.0
        y_mean, y_scale = float(y.mean()), float(y.std()) or 1.0
        stride = max(1, int(self.sample_stride))
        # an (n, d) view of a sample-contiguous (d, n) array: both kernels take Xᵀ without copying it per call
        Xt = torch.as_tensor(np.ascontiguousarray(((X - x_mean) / x_scale)[::stride].T), dtype=torch.float32).T
        yt = torch.as_tensor(((y - y_mean) / y_scale)[::stride], dtype=torch.float32)
        d, h = X.shape[1], int(self.hidden_size)

        def fitness(pop):  # the whole population in one batched evaluation
            return population_mse(torch.as_tensor(pop, dtype=torch.float32), Xt, yt, h, self.activation).numpy()

        cls = GA if self.optimizer == "ga" else PSOGA
        opt = cls(population_size=int(self.population_size), max_iter=int(self.generations),
                  random_state=int(rng.integers(2**31)))
        bounds = [(-self.weight_bound, self.weight_bound)] * n_parameters(d, h)
        x0 = init_weights(d, h, rng, size=max(1, int(self.population_size) // 5))
        opt.fit(fitness, bounds, x0=x0)
        self.history_ = list(opt.history_)
        self.n_evaluations_ = opt.n_evaluations_
        self.search_best_ = opt.x_
        self.network_ = BPNN(hidden_size=h, activation=self.activation, solver="lbfgs", max_iter=int(self.bp_iter),
                             early_stopping=self.bp_iter > 0, init_weights=opt.x_,
                             random_state=int(rng.integers(2**31)))
        if self.bp_iter > 0:
            self.network_.fit(X, y)
        else:  # the search winner is the network: set its fitted state directly
            net = self.network_
            net.x_mean_, net.x_scale_, net.y_mean_, net.y_scale_ = x_mean, x_scale, y_mean, y_scale
            net.coef_, net.n_features_in_, net.n_iter_ = opt.x_.copy(), d, 0
            net.loss_curve_, net.validation_scores_ = [], []
        self.n_features_in_ = X.shape[1]
        return self

    def predict(self, X):
        """Predict with the trained network.

        Parameters
        ----------
        X : array_like, shape (n, k)
            Features [unit of each feature].

        Returns
        -------
        ndarray, shape (n,)
            Prediction [unit of y].
        """
        check_is_fitted(self, "network_")
        X = validate_data(self, X, reset=False, dtype=np.float64)
        return self.network_.predict(X)
