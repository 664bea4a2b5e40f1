"""Linear algebra of the diagnosis: rank-revealing bases, novelty, bounded fits, held-out errors."""

from __future__ import annotations

import numpy as np


def orthonormal_basis(Aw: np.ndarray) -> np.ndarray:
    """Orthonormal basis of the column space, rank-revealing (SVD of the column-normalised matrix).

    Plain QR is not: for a dependent column it still returns a unit vector, in an arbitrary
    direction outside the span, and the later columns are made orthogonal to it.

    Parameters
    ----------
    Aw : np.ndarray
        n × k matrix.

    Returns
    -------
    np.ndarray
        n × r, r the numerical rank (singular values above 1e-9 of the largest).
    """
    if Aw.shape[1] == 0:
        return np.zeros((Aw.shape[0], 0))
    norms = np.linalg.norm(Aw, axis=0)
    A = Aw[:, norms > 0] / norms[norms > 0]
    if A.shape[1] == 0:
        return np.zeros((Aw.shape[0], 0))
    u, sv, _ = np.linalg.svd(A, full_matrices=False)
    return u[:, sv > 1e-9 * sv[0]]


def novelty(X: np.ndarray, Q: np.ndarray) -> float:
    """Share of a column's variance the design spanned by ``Q`` cannot mimic: 1 − R²(X ~ J)
    (docs/diagnosis.md §1 step 0).

    The smallest over the columns of X; 0 for a (numerically) constant column.

    Parameters
    ----------
    X : np.ndarray
        n × m candidate columns.
    Q : np.ndarray
        Orthonormal basis of the design, from :func:`orthonormal_basis`.

    Returns
    -------
    float
        In [0, 1].
    """
    perp = X - Q @ (Q.T @ X)
    centred = X - X.mean(axis=0)
    denom = np.linalg.norm(centred, axis=0)
    scale = np.linalg.norm(X, axis=0)
    ok = denom > 1e-9 * np.maximum(scale, 1e-300)
    ratios = np.where(ok, (np.linalg.norm(perp, axis=0) / np.where(ok, denom, 1.0)) ** 2, 0.0)
    return float(np.clip(ratios.min(), 0.0, 1.0)) if ratios.size else 0.0


def closest_column(A: np.ndarray, j: int, others: list[int], labels: list[str]) -> str:
    """Label of the column among ``others`` most correlated with column ``j``.

    Parameters
    ----------
    A : np.ndarray
        n × k matrix.
    j : int
        The column to match.
    others : list of int
        Candidate columns.
    labels : list of str
        Label of every column of ``A``.

    Returns
    -------
    str
        The label, or ``"the offsets"`` when ``others`` is empty or column ``j`` is constant.
    """
    if np.std(A[:, j]) == 0:  # a constant column has no correlation to rank: it is an offset
        return "the offsets"
    corr = [abs(np.corrcoef(A[:, j], A[:, k])[0, 1]) if np.std(A[:, k]) > 0 else 0.0 for k in others]
    return labels[others[int(np.argmax(corr))]] if corr else "the offsets"


def fit_bounded_linear(A: np.ndarray, b: np.ndarray, lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
    """Least squares ``A x ≈ b`` with ``lo ≤ x ≤ hi`` (BVLS on norm-scaled columns).

    Parameters
    ----------
    A : np.ndarray
        n × k design.
    b : np.ndarray
        Target, length n.
    lo, hi : np.ndarray
        Bounds, length k (±inf where free).

    Returns
    -------
    np.ndarray
        Coefficients, length k.
    """
    if A.shape[1] == 0:
        return np.zeros(0)
    scale = np.linalg.norm(A, axis=0)
    scale[scale == 0] = 1.0
    As = A / scale
    if np.all(np.isinf(lo)) and np.all(np.isinf(hi)):
        x = np.linalg.lstsq(As, b, rcond=None)[0]
    else:
        x = np.linalg.lstsq(As, b, rcond=-1)[0]  # lsq_linear's first step, to the bit
        if not np.all((x >= lo * scale) & (x <= hi * scale)):  # a bound is active: BVLS proper
            from scipy.optimize import lsq_linear  # most fits end inside: scipy.optimize costs 0.3 s to import

            x = lsq_linear(As, b, bounds=(lo * scale, hi * scale), method="bvls", lsmr_tol="auto").x
    return x / scale


def heldout_errors(A: np.ndarray, b: np.ndarray, folds: np.ndarray) -> np.ndarray:
    """Prediction errors of each block when its fold is held out (interleaved-block CV).

    Parameters
    ----------
    A : np.ndarray
        n × k design on averaged blocks.
    b : np.ndarray
        Target, length n.
    folds : np.ndarray
        Fold of each block.

    Returns
    -------
    np.ndarray
        Held-out error of each block, length n.
    """
    err = np.empty_like(b)
    for f in np.unique(folds):
        test = folds == f
        beta = np.linalg.lstsq(A[~test], b[~test], rcond=None)[0]
        err[test] = b[test] - A[test] @ beta
    return err


def heldout_sse(A: np.ndarray, b: np.ndarray, folds: np.ndarray) -> float:
    """Sum of squared :func:`heldout_errors`.

    Parameters
    ----------
    A, b, folds
        As for :func:`heldout_errors`.

    Returns
    -------
    float
    """
    e = heldout_errors(A, b, folds)
    return float(e @ e)
