"""Held-out validation of temperature compensators under a branch protocol.

Every estimator is cloned and fitted on each fold's training rows only; its residual is scored on
each held-out branch. The noise floor — white-noise σ from first differences of the residual,
divided by √2 — says how far any compensation could still go.
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np
from sklearn.base import clone

from twin.calibration.branches import Protocol
from twin.calibration.lag import MIN_ROWS, make_X
from twin.calibration.models import AXES
from twin.errors import TwinError
from twin.estimation.noise import white_sigma_of_differences
from twin.firmware import CalibrationRangeError


IN_RANGE = "in range"  # a fold's held-out samples inside its training temperatures, pooled
MIN_IN_RANGE = 30  # fewer in-range samples than this score no "in range" test


@dataclass(frozen=True)
class Score:
    """Held-out RMS of one method on one test set (``test == "overall"``: the fold's tests pooled).

    Attributes
    ----------
    fold, method, test : str
        Fold, method and test set.
    rms_mg : tuple of 3 floats
        Held-out RMS per axis [mg].
    n : int
        Samples scored.
    extrapolated_fraction : float
        Share of samples outside the training temperatures [0–1].
    """

    fold: str
    method: str
    test: str
    rms_mg: tuple[float, float, float]
    n: int
    extrapolated_fraction: float


@dataclass(frozen=True)
class ValidationResult:
    """Scores per fold, method and test branch, the noise floor and the best method per axis.

    Attributes
    ----------
    scores : tuple of Score
    noise_floor_mg : (float, float, float)
        White-noise σ per axis [mg], median over folds and methods.
    best_method : (str, str, str)
        Lowest RMS over all folds' held-out samples pooled, per axis.
    fit_time_s : dict
        ``{(fold, method): seconds}`` for one fit.
    notes : tuple of str
    """

    scores: tuple[Score, ...]
    noise_floor_mg: tuple[float, float, float]
    best_method: tuple[str, str, str]
    fit_time_s: dict
    notes: tuple[str, ...] = ()

    @property
    def methods(self) -> list[str]:
        """Names of the methods scored, in first-seen order."""
        return list(dict.fromkeys(s.method for s in self.scores))

    def rms_mg(self, method: str, test: str = "overall", fold: str | tuple[str, ...] | None = None) -> np.ndarray:
        """RMS [mg] per axis of ``method`` on ``test``, pooled over every fold, the folds named, or one.

        Parameters
        ----------
        method, test : str
            Method and test set.
        fold : str or tuple of str, optional
            One fold or several (default: all).

        Returns
        -------
        (3,) ndarray
            Pooled RMS [mg].
        """
        folds = (fold,) if isinstance(fold, str) else fold
        hits = [s for s in self.scores if s.method == method and s.test == test and (folds is None or s.fold in folds)]
        if not hits:
            raise TwinError(f"no score for method {method!r}, test {test!r}, fold {fold!r}")
        sse = sum(np.square(s.rms_mg) * s.n for s in hits)
        return np.sqrt(sse / sum(s.n for s in hits))

    def table(self, reference: str | None = None) -> str:
        """Text table: RMS [mg] per axis, per method, per test set; ``reference`` adds % below it.

        Parameters
        ----------
        reference : str, optional
            Method to compare against.

        Returns
        -------
        str
            The table.
        """
        lines = []
        for fold in dict.fromkeys(s.fold for s in self.scores):
            tests = list(dict.fromkeys(s.test for s in self.scores if s.fold == fold))
            lines.append(f"{fold}: held-out RMS [mg] x / y / z")
            for test in tests:
                lines.append(f"  {test}")
                ref = self.rms_mg(reference, test, fold) if reference else None
                for m in self.methods:
                    r = self.rms_mg(m, test, fold)
                    text = " / ".join(f"{v:6.2f}" for v in r)
                    if ref is not None and m != reference:
                        text += "   (" + " / ".join(f"{100 * (1 - v / w):+4.0f} %" for v, w in zip(r, ref)) + \
                                f" vs {reference})"
                    lines.append(f"    {m:22s} {text}")
        lines.append("noise floor [mg]: " + " / ".join(f"{v:.2f}" for v in self.noise_floor_mg))
        lines.append("best method: " + ", ".join(f"{a}: {m}" for a, m in zip(AXES, self.best_method)))
        return "\n".join(lines + list(self.notes))


def held_out_noise_floor_mg(residual_g: np.ndarray, index: np.ndarray) -> np.ndarray:
    """White-noise σ [mg] per axis of a held-out branch: the project's noise floor
    (:func:`twin.estimation.noise.white_sigma_of_differences`) of the differences of consecutive
    held-out samples, the same estimator ``twin compare`` quotes.

    Parameters
    ----------
    residual_g : np.ndarray
        Residual, shape (n, 3) [g].
    index : np.ndarray
        Held-out rows; consecutive ones (index step 1) are differenced.

    Returns
    -------
    np.ndarray
        σ per axis [mg]; NaN when fewer than three pairs.
    """
    index = np.asarray(index)
    pairs = np.flatnonzero(np.diff(index) == 1)
    if pairs.size <= 2:
        return np.full(3, np.nan)
    d = residual_g[index[pairs + 1]] - residual_g[index[pairs]]
    return np.array([white_sigma_of_differences(d[:, k]) for k in range(d.shape[1])]) * 1e3


def validate(models: dict, time_s, temperature_c, accel_g, protocol: Protocol, run=None,
             on_fit=None) -> ValidationResult:
    """Fit each estimator on each fold's training rows and score it on the held-out branches.

    Parameters
    ----------
    models : dict of name → estimator
        Unfitted scikit-learn estimators (``sklearn.base.clone``-able) with ``fit(X, y, mask)`` and
        ``predict(X)``. One with ``share_folds(X, y)`` gets its result, computed once, as
        ``fit(..., shared=…)`` in every fold (what the folds of one log have in common: the cost
        of a fold is then what differs between folds). One with ``predict_rows(X, rows)`` (a
        thermal state over every row) is evaluated on the held-out rows only.
    time_s, temperature_c : (n,) arrays
    accel_g : (n, 3) array
    protocol : Protocol
        From :func:`twin.calibration.branches.protocol_heating_vs_cooling`.
    run : (n,) int array, optional
        Run id per sample (the lags restart at each run).
    on_fit : callable, optional
        Called with ``"<method> on <fold>"`` after each fit (and skipped fit), e.g. a progress bar's step.

    Returns
    -------
    ValidationResult
    """
    X = make_X(time_s, temperature_c, run)
    y = np.asarray(accel_g, float)
    if y.shape != (X.shape[0], 3):
        raise TwinError(f"accel_g must be (n, 3) with n = {X.shape[0]}; got {y.shape}")
    scores, floors, times, skipped = [], [], {}, []
    shared = _Shared(X, y) if len(protocol.folds) > 1 else None
    for fold in protocol.folds:
        mask = np.zeros(X.shape[0], bool)
        mask[fold.train] = True
        held = np.concatenate([t.index for t in fold.tests]) if fold.tests else np.zeros(0, int)
        held_rows = np.zeros(X.shape[0], bool)
        held_rows[held] = True
        held_rows = np.flatnonzero(held_rows)  # sorted, once: the rows a row-by-row model predicts
        extrap = np.concatenate([t.extrapolated for t in fold.tests]) if fold.tests else np.zeros(0, bool)
        this_fold = {}  # original estimator (by identity) → its fit on this fold
        for name, est in models.items():
            start = time.perf_counter()
            try:
                inner = this_fold.get(id(getattr(est, "method", None)))
                if inner is not None and hasattr(est, "fit_from"):  # a wrapper of a method fitted just before
                    fitted = clone(est).fit_from(inner, X, y, mask=mask)
                else:
                    given = shared.of(est) if shared is not None else {}
                    fitted = this_fold[id(est)] = clone(est).fit(X, y, mask=mask, **given)
            except CalibrationRangeError as exc:  # e.g. ArduPilot's 10 °C on a fold's narrower training rows
                skipped.append(f"note ({fold.name}): {name} not fitted on this fold: {exc}")
                if on_fit:
                    on_fit(f"{name} on {fold.name}")
                continue
            times[(fold.name, name)] = time.perf_counter() - start
            if on_fit:
                on_fit(f"{name} on {fold.name}")
            resid = _residual(fitted, X, y, held_rows)
            for t in fold.tests:
                scores.append(Score(fold.name, name, t.name, _rms(resid[t.index]), int(t.index.size),
                                    t.extrapolated_fraction))
            if held.size:
                scores.append(Score(fold.name, name, "overall", _rms(resid[held]), int(held.size),
                                    float(extrap.mean())))
                if np.sum(~extrap) >= MIN_IN_RANGE:  # inside the fold's training temperatures
                    scores.append(Score(fold.name, name, IN_RANGE, _rms(resid[held[~extrap]]), int(np.sum(~extrap)),
                                        0.0))
                floors.append(np.concatenate([held_out_noise_floor_mg(resid, t.index)
                                              for t in fold.tests]).reshape(-1, 3))
    if not scores:
        raise TwinError(f"protocol {protocol.name!r} has no held-out samples")
    floor = np.nanmedian(np.concatenate(floors), axis=0)
    dummy = ValidationResult(tuple(scores), tuple(floor), ("",) * 3, times)
    pooled = np.array([dummy.rms_mg(m) for m in dummy.methods])
    best = tuple(dummy.methods[i] for i in np.argmin(pooled, axis=0))
    notes = ((f"note ({protocol.name}): {protocol.note}",) if protocol.note else ()) + \
        tuple(f"note ({f.name}): {f.note}" for f in protocol.folds if f.note) + tuple(skipped)
    return ValidationResult(tuple(scores), tuple(float(v) for v in floor), best, times, notes)


class _Shared:
    """What an estimator's fits on the folds of one log share (its ``share_folds(X, y)``, computed
    at its first fold): a fold's fit then costs what differs between folds, not the whole log again."""

    def __init__(self, X: np.ndarray, y: np.ndarray):
        self.X, self.y, self.found = X, y, {}

    def of(self, est) -> dict:
        """Keywords for ``est.fit``: ``{"shared": …}``, or none when it shares nothing."""
        if not hasattr(est, "share_folds"):
            return {}
        if id(est) not in self.found:
            self.found[id(est)] = est.share_folds(self.X, self.y)
        given = self.found[id(est)]
        return {} if given is None else {"shared": given}


def _residual(fitted, X: np.ndarray, y: np.ndarray, rows: np.ndarray) -> np.ndarray:
    """``y − prediction`` on the held-out ``rows`` (sorted; the other rows' values undefined): a
    model predicting each row from its own temperature predicts only those; one with a thermal
    state runs over the whole log."""
    if rows.size >= X.shape[0] or rows.size < MIN_ROWS:
        return y - fitted.predict(X)
    if getattr(fitted, "row_by_row", False):
        predicted = fitted.predict(X[rows])
    elif hasattr(fitted, "predict_rows"):  # a thermal state over every row, evaluated on these only
        predicted = fitted.predict_rows(X, rows)
    else:
        return y - fitted.predict(X)
    resid = np.empty_like(y)  # pages of rows never written are never touched
    resid[rows] = y[rows] - predicted
    return resid


def _rms(r: np.ndarray) -> tuple[float, float, float]:
    return tuple(float(v) for v in np.sqrt(np.mean(r * r, axis=0)) * 1e3)
