"""Back-propagation network (one hidden layer) in torch, CPU, with the scikit-learn contract.

The weights of a d-h-1 network are one flat vector θ = [W1 (d·h), b1 (h), W2 (h), b2 (1)], so a *population* of
networks is one (P, n_params) tensor: :func:`population_mse` evaluates every member in batched tensor operations
(never one network at a time in Python), which is what GA, PSO and PSO-GA need for their fitness.
Back-propagation itself (:func:`mse_and_gradient`) is written out in float64 and driven by scipy's L-BFGS-B or
torch's Adam. X, y and θ below are standardised (dimensionless), except in :class:`BPNN`'s fit/predict.

References
----------
Rumelhart, Hinton & Williams (1986), back-propagation; Qi et al. (2022) §2.2.2 (BPNN, eq. 36–38).
"""

from __future__ import annotations

import functools

import numpy as np
from sklearn.base import BaseEstimator, RegressorMixin
from sklearn.utils.validation import check_is_fitted, validate_data

ACTIVATIONS = ("tanh", "relu", "sigmoid")


def _torch():
    import torch
    return torch


def n_parameters(n_inputs: int, hidden: int) -> int:
    """Length d·h + h + h + 1 of the flat weights θ of a d-h-1 network (d = ``n_inputs``, h = ``hidden``).

    Parameters
    ----------
    n_inputs, hidden : int

    Returns
    -------
    int
    """
    return n_inputs * hidden + hidden + hidden + 1


def _act(torch, name: str):
    return {"tanh": torch.tanh, "relu": torch.relu, "sigmoid": torch.sigmoid}[name]


def _act_in_place(torch, name: str):
    """The activation applied in place to a contiguous CPU tensor. tanh is NumPy's (the function
    MLPRegressor uses, within 1 ulp): on an AMD EPYC 1.7× torch's float64 tanh on two threads."""
    if name == "tanh":
        return lambda Z: torch.from_numpy(np.tanh(Z.numpy(), out=Z.numpy()))
    return {"relu": torch.relu_, "sigmoid": torch.sigmoid_}[name]


def forward(theta, X, hidden: int, activation: str = "tanh"):
    """Outputs (P, n) of P networks with flat weights ``theta`` (P, n_params) on X (n, d) (standardised).

    Parameters
    ----------
    theta, X, hidden, activation
        Weights and inputs (torch tensors); hidden neurons h (int); ``"tanh"``, ``"relu"`` or ``"sigmoid"``.

    Returns
    -------
    torch.Tensor
    """
    torch = _torch()
    P, d = theta.shape[0], X.shape[1]
    i = d * hidden
    W1 = theta[:, :i].reshape(P, d, hidden)
    b1 = theta[:, i : i + hidden].unsqueeze(1)
    W2 = theta[:, i + hidden : i + 2 * hidden].unsqueeze(2)
    b2 = theta[:, -1:].unsqueeze(1)
    H = _act(torch, activation)(torch.matmul(X.unsqueeze(0), W1) + b1)  # (P, n, h)
    return (torch.matmul(H, W2) + b2).squeeze(2)


@functools.cache
def l2_cache_bytes(default: int = 1 << 20) -> int:
    """Size of the CPU's level-2 cache [bytes] (Linux sysfs), ``default`` where it cannot be read.

    Parameters
    ----------
    default : int

    Returns
    -------
    int
    """
    from pathlib import Path
    for idx in sorted(Path("/sys/devices/system/cpu/cpu0/cache").glob("index*")):
        try:
            if (idx / "level").read_text().strip() == "2" and (idx / "type").read_text().strip() != "Instruction":
                size = (idx / "size").read_text().strip().upper()
                return int(size[:-1]) * {"K": 1 << 10, "M": 1 << 20}[size[-1]] if size[-1] in "KM" else int(size)
        except (OSError, ValueError):
            break
    return default


def block_chunk(rows: int, itemsize: int, cache_bytes: int | None = None) -> int:
    """Samples per chunk: the largest power of two whose (rows, chunk) block fits the L2 cache, in [256, 16384].

    Measured on an Intel Xeon (2 MB L2, 500 rows of float32): 664 evaluations/s at 1024 samples (2 MB), 582
    at 2048, 524 at 4096, 452 at 512 (per-chunk overhead).

    Parameters
    ----------
    rows, itemsize, cache_bytes : int
        Block rows; bytes per element; cache size [bytes] (default :func:`l2_cache_bytes`).

    Returns
    -------
    int
    """
    cache = l2_cache_bytes() if cache_bytes is None else cache_bytes
    fit = max(1, cache // max(1, rows * itemsize))
    return int(min(16384, max(256, 1 << (fit.bit_length() - 1))))


def compiled_kernel_available() -> bool:
    """Whether numba's compiled tanh kernel (:mod:`fitting.kernels`) can run (``TDE_TWIN_NO_NUMBA`` unset).

    Returns
    -------
    bool
    """
    import os
    if os.environ.get("TDE_TWIN_NO_NUMBA"):
        return False
    try:
        import numba  # noqa: F401
    except ImportError:
        return False
    return True


def population_mse(theta, X, y, hidden: int, activation: str = "tanh", chunk: int | None = None, kernel: str = "auto"):
    """Mean squared error of each of P networks on (X, y), in float64, without a Python loop over networks.

    ``kernel="auto"`` runs float32 tanh networks through the compiled kernel
    (:func:`fitting.kernels.population_mse_tanh`: one pass per network, a rational tanh within 5e-7; 1.9× this
    torch kernel on an AMD EPYC) when numba is present; ``"torch"`` forces the torch kernel. There the hidden
    layers of all P networks are one GEMM, (P·h, d) @ (d, chunk), laid out member-major: the activation runs in
    place and the output layer is one batched (1, h) @ (h, chunk) product per member on contiguous rows. Chunks of
    ``chunk`` samples (default :func:`block_chunk`: the (P·h, chunk) block fits the L2 cache); a (P, n, h)
    broadcast, as :func:`forward` does, is ~8× slower on 390k samples (benchmarks/bench_fitting.py measures both).

    Parameters
    ----------
    theta, X, y, hidden, activation, chunk, kernel
        Weights (P, n_params), inputs (n, d), targets (n,) as standardised tensors; then as above.

    Returns
    -------
    torch.Tensor
    """
    torch = _torch()
    if kernel not in ("auto", "torch"):
        raise ValueError(f"kernel must be 'auto' or 'torch', got {kernel!r}")
    if kernel == "auto" and activation == "tanh" and X.dtype == torch.float32 and compiled_kernel_available():
        from fitting.kernels import population_mse_tanh
        mse = population_mse_tanh(theta.to(torch.float32).numpy(), X.T.contiguous().numpy(), y.numpy(), hidden, chunk)
        return torch.from_numpy(mse)
    P, d = theta.shape[0], X.shape[1]
    i = d * hidden
    chunk = block_chunk(P * hidden, X.element_size()) if chunk is None else int(chunk)
    with torch.no_grad():
        theta = theta.to(X.dtype)
        W1 = theta[:, :i].reshape(P, d, hidden).transpose(1, 2).reshape(P * hidden, d)
        b1 = theta[:, i : i + hidden].reshape(P * hidden, 1)
        W2 = theta[:, i + hidden : i + 2 * hidden].unsqueeze(1).contiguous()  # (P, 1, h)
        b2 = theta[:, -1:]
        XT = X.T.contiguous()
        if activation == "tanh":  # tanh(z) = 2σ(2z) − 1, folded into the weights: see tanh_as_sigmoid
            W1, b1, W2, b2 = tanh_as_sigmoid(W1, b1, W2, b2)
        act = {"tanh": torch.sigmoid_, "relu": torch.relu_, "sigmoid": torch.sigmoid_}[activation]
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


def tanh_as_sigmoid(W1, b1, W2, b2):
    """Weights of the sigmoid network equal to a tanh network, from tanh(z) = 2σ(2z) − 1.

    Hidden: 2(W1 x + b1); output: (2 W2)·σ + (b2 − Σ W2). Exact in real arithmetic; in float32 the
    MSE agrees with torch.tanh's to ~1e-6 relative (tested). Why: a vendor's tanh can run at a
    fraction of its sigmoid's speed (0.43 vs 1.57 G elements/s in place on this machine's CPU), and
    this form makes the kernel's speed independent of it with no extra elementwise pass.

    Parameters
    ----------
    W1, b1, W2, b2 : torch.Tensor, shapes (P·h, d), (P·h, 1), (P, 1, h), (P, 1)

    Returns
    -------
    tuple of tensors
        ``(W1', b1', W2', b2')`` in the same shapes.
    """
    return 2 * W1, 2 * b1, 2 * W2, b2 - W2.sum(dim=2)


def _derivative_from_output(torch, name: str, A):
    """Activation derivative from its output (in place): tanh 1 − a², sigmoid a(1 − a), relu [a > 0]."""
    if name == "tanh":
        return A.mul_(A).neg_().add_(1.0)
    if name == "sigmoid":
        return A.mul_(1.0 - A)
    return (A > 0).to(A.dtype)


def mse_and_gradient(theta: np.ndarray, X, y, hidden: int, activation: str = "tanh", gradient: bool = True,
                     chunk: int = 16384):
    """Mean squared error of one network (flat weights ``theta``) on (X, y), and its gradient.

    Back-propagation written out (Rumelhart et al. 1986), float64, no autograd graph: with A = act(X W1 + b1)
    and e = A W2 + b2 − y, ∂/∂W2 = 2Aᵀe/n, ∂/∂W1 = 2Xᵀ[(e W2ᵀ) ⊙ act′]/n. Chunks of ``chunk`` samples keep A
    in cache (2.7× faster than whole arrays on 350k samples). ``gradient=False`` returns ``(mse, None)``.

    Parameters
    ----------
    theta, X, y, hidden, activation, gradient, chunk
        Weights (n_params,) as ndarray; float64 tensors X (n, d), y (n,); then as :func:`population_mse`.

    Returns
    -------
    mse, gradient : float, ndarray or None
    """
    torch = _torch()
    th = torch.as_tensor(np.asarray(theta, dtype=np.float64))
    n, d = X.shape
    i = d * hidden
    W1, b1 = th[:i].view(d, hidden), th[i : i + hidden]
    W2, b2 = th[i + hidden : i + 2 * hidden], th[-1]
    g = torch.zeros_like(th)
    gW1, gb1, gW2 = g[:i].view(d, hidden), g[i : i + hidden], g[i + hidden : i + 2 * hidden]
    act = _act_in_place(torch, activation)
    sse = 0.0
    with torch.no_grad():
        for a in range(0, n, chunk):
            Xc = X[a : a + chunk]
            A = act(torch.addmm(b1, Xc, W1))
            e = torch.mv(A, W2).add_(b2).sub_(y[a : a + chunk])
            sse += float(torch.dot(e, e))
            if not gradient:
                continue
            gW2.add_(torch.mv(A.T, e))
            g[-1] += e.sum()
            dZ = _derivative_from_output(torch, activation, A).mul_(torch.outer(e, W2))
            gW1.addmm_(Xc.T, dZ)
            gb1.add_(dZ.sum(0))
    return sse / n, (g.mul_(2.0 / n).numpy() if gradient else None)


def init_weights(n_inputs: int, hidden: int, rng: np.random.Generator, size: int = 1) -> np.ndarray:
    """Glorot-uniform weights (Glorot & Bengio 2010), zero biases, for ``size`` networks (size, n_params).

    Parameters
    ----------
    n_inputs, hidden, rng, size
        Inputs d, hidden neurons h (int); numpy Generator; number of networks (int).

    Returns
    -------
    ndarray
    """
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
    early_stopping, n_iter_no_change, tol : bool, int, float
        Stop after ``n_iter_no_change`` epochs without a validation improvement > ``tol`` and keep the best
        weights (without validation data: when the training loss changes by < ``tol``).
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
        """Standardise, hold out the validation blocks and train.

        Parameters
        ----------
        X, y : array_like, shapes (n, d) and (n,)

        Returns
        -------
        self : BPNN
        """
        from fitting.splits import interleaved_validation_mask  # local: this module is at the 450-line limit
        from fitting.threads import one_thread
        torch = _torch()
        self._validate_hyperparameters()
        X, y = validate_data(self, X, y, y_numeric=True, dtype=np.float64)
        y = np.asarray(y, float).ravel()
        rng = np.random.default_rng(self.random_state)
        self.x_mean_, self.x_scale_ = X.mean(axis=0), X.std(axis=0)
        self.x_scale_[self.x_scale_ == 0] = 1.0
        self.y_mean_, self.y_scale_ = float(y.mean()), float(y.std()) or 1.0
        Xs = torch.as_tensor((X - self.x_mean_) / self.x_scale_, dtype=torch.float64)
        ys = torch.as_tensor((y - self.y_mean_) / self.y_scale_, dtype=torch.float64)
        n = X.shape[0]
        use_val = self.early_stopping and self.validation_fraction > 0 and n >= 20
        val = interleaved_validation_mask(n, self.validation_fraction) if use_val else np.zeros(n, bool)
        Xtr, ytr = Xs[torch.as_tensor(~val)].contiguous(), ys[torch.as_tensor(~val)].contiguous()
        Xval, yval = Xs[torch.as_tensor(val)], ys[torch.as_tensor(val)]
        d = X.shape[1]
        theta0 = (np.asarray(self.init_weights, float).ravel() if self.init_weights is not None
                  else init_weights(d, self.hidden_size, rng)[0])
        if theta0.size != n_parameters(d, self.hidden_size):
            raise ValueError(f"init_weights has {theta0.size} values; a {d}-{self.hidden_size}-1 network has "
                             f"{n_parameters(d, self.hidden_size)}")
        h, act = self.hidden_size, self.activation
        self.loss_curve_, self.validation_scores_ = [], []
        state = {"best": (np.inf, theta0.copy()), "stall": 0, "n": 0, "recorded": -1}
        every = 1 if self.solver == "adam" else 10  # L-BFGS: validation every 10 iterations

        def record(theta: np.ndarray, train_loss: float) -> bool:
            """Record the losses at iteration state["n"]; True when early stopping says stop."""
            state["recorded"] = state["n"]
            self.loss_curve_.append(float(train_loss))
            if use_val:
                v = float(mse_and_gradient(theta, Xval, yval, h, act, gradient=False)[0])
                self.validation_scores_.append(v)
                if v < state["best"][0] - self.tol:
                    state["best"], state["stall"] = (v, theta.copy()), 0
                else:
                    state["stall"] += 1
                    return state["stall"] >= self.n_iter_no_change
            elif len(self.loss_curve_) > 1 and abs(self.loss_curve_[-2] - self.loss_curve_[-1]) < self.tol:
                return True
            return False

        def check(theta: np.ndarray, train_loss: float) -> bool:
            state["n"] += 1
            return state["n"] % every == 0 and record(theta, train_loss)

        with one_thread(torch):  # small tensors: two threads only wait for each other (fitting.threads)
            final = self._train(torch, theta0, Xtr, ytr, check)
            if state["recorded"] != state["n"]:  # the last iterate is judged too (converged between checks)
                record(final, mse_and_gradient(final, Xtr, ytr, h, act, gradient=False)[0])
        self.coef_ = (state["best"][1] if use_val else final).copy()
        self.n_iter_ = state["n"]
        return self

    def _train(self, torch, theta0, Xtr, ytr, check) -> np.ndarray:
        """The solver's iterations from ``theta0``; ``check(theta, loss)`` after each says when to stop."""
        h, act = self.hidden_size, self.activation
        if self.solver == "lbfgs":  # scipy's L-BFGS-B on an analytic gradient, as MLPRegressor does
            from scipy.optimize import minimize

            def callback(intermediate_result):
                if check(intermediate_result.x, intermediate_result.fun):
                    raise StopIteration

            return minimize(lambda th: mse_and_gradient(th, Xtr, ytr, h, act), theta0, jac=True, method="L-BFGS-B",
                            callback=callback,
                            options={"maxiter": int(self.max_iter), "maxcor": 20, "ftol": 1e-15, "gtol": 1e-10}).x
        theta = torch.tensor(theta0, dtype=torch.float64, requires_grad=True)
        opt = torch.optim.Adam([theta], lr=self.learning_rate)
        for _ in range(int(self.max_iter)):
            loss, grad = mse_and_gradient(theta.detach().numpy(), Xtr, ytr, h, act)
            theta.grad = torch.as_tensor(grad)
            opt.step()
            if check(theta.detach().numpy(), loss):
                break
        return theta.detach().numpy()

    def predict(self, X):
        """Predict [unit of y] with the trained weights.

        Parameters
        ----------
        X : array_like, shape (n, d)

        Returns
        -------
        ndarray, shape (n,)
        """
        torch = _torch()
        check_is_fitted(self, "coef_")
        X = validate_data(self, X, reset=False, dtype=np.float64)
        Xs = torch.as_tensor((X - self.x_mean_) / self.x_scale_, dtype=torch.float64)
        with torch.no_grad():
            out = forward(torch.as_tensor(self.coef_[None, :]), Xs, self.hidden_size, self.activation)[0].numpy()
        return out * self.y_scale_ + self.y_mean_
