"""Back-propagation network (one hidden layer) in torch, CPU, with the scikit-learn contract.

The weights of a d-h-1 network are one flat vector θ = [W1 (d·h), b1 (h), W2 (h), b2 (1)], so a
*population* of networks is one (P, n_params) tensor: :func:`population_mse` evaluates every
member in batched tensor operations (never one network at a time in Python), which is what GA,
PSO and PSO-GA need for their fitness.

References
----------
Rumelhart, Hinton & Williams (1986), back-propagation; Qi et al. (2022) §2.2.2 (BPNN, eq. 36–38).
"""

from __future__ import annotations

import numpy as np
from sklearn.base import BaseEstimator, RegressorMixin
from sklearn.utils.validation import check_is_fitted, validate_data

ACTIVATIONS = ("tanh", "relu", "sigmoid")


def _torch():
    import torch

    return torch


def n_parameters(n_inputs: int, hidden: int) -> int:
    return n_inputs * hidden + hidden + hidden + 1


def _act(torch, name: str):
    return {"tanh": torch.tanh, "relu": torch.relu, "sigmoid": torch.sigmoid}[name]


def forward(theta, X, hidden: int, activation: str = "tanh"):
    """Outputs (P, n) of P networks with flat weights ``theta`` (P, n_params) on X (n, d)."""
    torch = _torch()
    P, d = theta.shape[0], X.shape[1]
    i = d * hidden
    W1 = theta[:, :i].reshape(P, d, hidden)
    b1 = theta[:, i : i + hidden].unsqueeze(1)
    W2 = theta[:, i + hidden : i + 2 * hidden].unsqueeze(2)
    b2 = theta[:, -1:].unsqueeze(1)
    H = _act(torch, activation)(torch.matmul(X.unsqueeze(0), W1) + b1)  # (P, n, h)
    return (torch.matmul(H, W2) + b2).squeeze(2)


def population_mse(theta, X, y, hidden: int, activation: str = "tanh", chunk: int = 4096):
    """Mean squared error of each of P networks on (X, y), in float64, without a Python loop over networks.

    The hidden layers of all P networks are one GEMM, (P·h, d) @ (d, chunk), so the work is laid
    out member-major: the activation runs in place and the output layer is one batched
    (1, h) @ (h, chunk) product per member on contiguous rows. Chunks of ``chunk`` samples keep
    the (P·h, chunk) block near cache; a (P, n, h) broadcast, as :func:`forward` does, is ~8×
    slower on 390k samples (benchmarks/bench_fitting.py measures both).
    """
    torch = _torch()
    P, d = theta.shape[0], X.shape[1]
    i = d * hidden
    with torch.no_grad():
        theta = theta.to(X.dtype)
        W1 = theta[:, :i].reshape(P, d, hidden).transpose(1, 2).reshape(P * hidden, d)
        b1 = theta[:, i : i + hidden].reshape(P * hidden, 1)
        W2 = theta[:, i + hidden : i + 2 * hidden].unsqueeze(1).contiguous()  # (P, 1, h)
        b2 = theta[:, -1:]
        XT = X.T.contiguous()
        act = {"tanh": torch.tanh_, "relu": torch.relu_, "sigmoid": torch.sigmoid_}[activation]
        sse = torch.zeros(P, dtype=torch.float64)
        work = torch.empty(P * hidden * min(chunk, X.shape[0]), dtype=X.dtype)
        for a in range(0, X.shape[0], chunk):
            c = min(chunk, X.shape[0] - a)
            Z = work[: P * hidden * c].view(P * hidden, c)
            torch.addmm(b1, W1, XT[:, a : a + c], out=Z)
            act(Z)
            err = torch.bmm(W2, Z.view(P, hidden, c)).view(P, c)
            err.add_(b2).sub_(y[a : a + c])
            sse += torch.linalg.vecdot(err, err).to(torch.float64)
    return sse / X.shape[0]


def init_weights(n_inputs: int, hidden: int, rng: np.random.Generator, size: int = 1) -> np.ndarray:
    """Glorot-uniform weights, zero biases, for ``size`` networks (size, n_params)."""
    lim1 = np.sqrt(6.0 / (n_inputs + hidden))
    lim2 = np.sqrt(6.0 / (hidden + 1))
    out = np.zeros((size, n_parameters(n_inputs, hidden)))
    i = n_inputs * hidden
    out[:, :i] = rng.uniform(-lim1, lim1, (size, i))
    out[:, i + hidden : i + 2 * hidden] = rng.uniform(-lim2, lim2, (size, hidden))
    return out


class BPNN(RegressorMixin, BaseEstimator):
    """One-hidden-layer back-propagation network (scikit-learn estimator, torch on the CPU).

    Parameters
    ----------
    hidden_size : int
        Neurons in the hidden layer (the paper's networks: 10).
    activation : {"tanh", "relu", "sigmoid"}
    solver : {"lbfgs", "adam"}
        Full-batch training.
    max_iter : int
        Epochs (Adam) or L-BFGS iterations (checked against the validation set every 10).
    learning_rate : float
        Adam step size (L-BFGS uses its line search).
    early_stopping : bool
        Stop when the validation loss has not improved for ``n_iter_no_change`` epochs and keep
        the best weights.
    validation_fraction : float
        Share of the training data held out, as interleaved blocks (time series).
    init_weights : array, optional
        Flat initial weights (e.g. the winner of a GA/PSO search) on standardised data.
    random_state : int or None

    Attributes
    ----------
    coef_ : ndarray — flat weights on standardised data
    n_iter_ : int — epochs (Adam) or L-BFGS iterations run
    loss_curve_ : list of float — training MSE (standardised) per epoch (Adam) or per 10 L-BFGS iterations
    validation_scores_ : list of float
    x_mean_, x_scale_, y_mean_, y_scale_ : standardisation
    n_features_in_ : int
    """

    def __init__(self, hidden_size=10, activation="tanh", solver="lbfgs", max_iter=200, learning_rate=1e-2,
                 early_stopping=True, validation_fraction=0.1, n_iter_no_change=20, tol=1e-7, init_weights=None,
                 random_state=None):
        self.hidden_size = hidden_size
        self.activation = activation
        self.solver = solver
        self.max_iter = max_iter
        self.learning_rate = learning_rate
        self.early_stopping = early_stopping
        self.validation_fraction = validation_fraction
        self.n_iter_no_change = n_iter_no_change
        self.tol = tol
        self.init_weights = init_weights
        self.random_state = random_state

    def _validate_hyperparameters(self):
        if self.activation not in ACTIVATIONS:
            raise ValueError(f"activation must be one of {ACTIVATIONS}, got {self.activation!r}")
        if self.solver not in ("lbfgs", "adam"):
            raise ValueError(f"solver must be 'lbfgs' or 'adam', got {self.solver!r}")
        if not (isinstance(self.hidden_size, (int, np.integer)) and self.hidden_size >= 1):
            raise ValueError(f"hidden_size must be a positive integer, got {self.hidden_size!r}")
        if not 0 <= self.validation_fraction < 1:
            raise ValueError(f"validation_fraction must be in [0, 1), got {self.validation_fraction}")

    def fit(self, X, y):
        torch = _torch()
        self._validate_hyperparameters()
        X, y = validate_data(self, X, y, y_numeric=True, dtype=np.float64)
        y = np.asarray(y, float).ravel()
        rng = np.random.default_rng(self.random_state)
        torch.manual_seed(int(rng.integers(2**31)))
        self.x_mean_, self.x_scale_ = X.mean(axis=0), X.std(axis=0)
        self.x_scale_[self.x_scale_ == 0] = 1.0
        self.y_mean_, self.y_scale_ = float(y.mean()), float(y.std()) or 1.0
        Xs = torch.as_tensor((X - self.x_mean_) / self.x_scale_, dtype=torch.float64)
        ys = torch.as_tensor((y - self.y_mean_) / self.y_scale_, dtype=torch.float64)
        n = X.shape[0]
        block = max(1, n // 200)  # interleaved blocks: every part of the record is seen in both sets
        use_val = self.early_stopping and self.validation_fraction > 0 and n >= 20
        val = ((np.arange(n) // block) % max(2, int(round(1 / self.validation_fraction))) == 0) if use_val else np.zeros(n, bool)
        split = {"train": (Xs[torch.as_tensor(~val)], ys[torch.as_tensor(~val)]),
                 "val": (Xs[torch.as_tensor(val)], ys[torch.as_tensor(val)])}  # indexed once, not per step
        d = X.shape[1]
        theta0 = (np.asarray(self.init_weights, float).ravel() if self.init_weights is not None
                  else init_weights(d, self.hidden_size, rng)[0])
        if theta0.size != n_parameters(d, self.hidden_size):
            raise ValueError(f"init_weights has {theta0.size} values; a {d}-{self.hidden_size}-1 network has "
                             f"{n_parameters(d, self.hidden_size)}")
        theta = torch.tensor(theta0[None, :], dtype=torch.float64, requires_grad=True)
        h, act = self.hidden_size, self.activation

        def loss_on(part):
            Xp, yp = split[part]
            e = forward(theta, Xp, h, act)[0] - yp
            return (e * e).mean()

        self.loss_curve_, self.validation_scores_ = [], []
        best = (np.inf, theta.detach().clone())
        stall = 0
        # L-BFGS runs in chunks of 10 iterations between validation checks: stepped one iteration
        # per call, torch's L-BFGS stalls once a line search fails (its state carries over).
        chunk = 1 if self.solver == "adam" else 10
        if self.solver == "adam":
            opt = torch.optim.Adam([theta], lr=self.learning_rate)
        else:
            opt = torch.optim.LBFGS([theta], lr=1.0, max_iter=chunk, history_size=20, line_search_fn="strong_wolfe",
                                    tolerance_change=1e-12)
        n_done = 0
        while n_done < int(self.max_iter):
            def closure():
                opt.zero_grad()
                loss = loss_on("train")
                loss.backward()
                return loss

            opt.step(closure)
            n_done += chunk
            with torch.no_grad():
                loss = loss_on("train")
            self.loss_curve_.append(float(loss))
            if use_val:
                with torch.no_grad():
                    v = float(loss_on("val"))
                self.validation_scores_.append(v)
                if v < best[0] - self.tol:
                    best, stall = (v, theta.detach().clone()), 0
                else:
                    stall += 1
                    if stall >= self.n_iter_no_change:
                        break
            elif len(self.loss_curve_) > 1 and abs(self.loss_curve_[-2] - self.loss_curve_[-1]) < self.tol:
                break
        final = best[1] if use_val else theta.detach()
        self.coef_ = final[0].numpy().copy()
        self.n_iter_ = n_done
        return self

    def predict(self, X):
        torch = _torch()
        check_is_fitted(self, "coef_")
        X = validate_data(self, X, reset=False, dtype=np.float64)
        Xs = torch.as_tensor((X - self.x_mean_) / self.x_scale_, dtype=torch.float64)
        with torch.no_grad():
            out = forward(torch.as_tensor(self.coef_[None, :]), Xs, self.hidden_size, self.activation)[0].numpy()
        return out * self.y_scale_ + self.y_mean_
