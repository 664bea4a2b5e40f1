"""The twin-based compensation: a polynomial in a lagged die temperature plus a thermal-gradient term.

Per axis ``a(t) = p(T_die − T_ref) + b·(T − T_g)`` with ``T_die = lag(T, τ_die)`` and
``T_g = lag(T, τ_rate)``, first-order causal lags of the thermometer reading over the whole log.
``T − T_g = τ_rate·d/dt lag(T, τ_rate)`` is the rate seen through a node of τ_rate (a gradient
across the package, or the Maxwell relaxation of package stress). The firmware needs exactly this:
two first-order filters of T, a polynomial and a product — the fitted ``tau_*_s_``, ``coef_mg_``
and ``rate_mg_per_c_`` are everything it needs.

Selection (``share="auto"``, ``rate_term="auto"``) uses the training rows only: every nonlinear
parameter is a maximum-likelihood fit on them, and the structure — τ's shared by the three axes
or per axis, rate term per axis or not — is chosen by BIC with an AR(1)-effective sample size.
Held-out data (e.g. the cooling branches when fitting on heating) must never steer these choices:
that would turn a validation into a fit. On a log sampled faster than 2 Hz the time constants and
the structure are searched on 1-s means of the training rows, and the amplitudes, the residual's
σ and the effective sample size come from every row (:mod:`twin.calibration.lagprofile`): the fit
costs a few passes over the log, not one per trial.
"""

from __future__ import annotations

import numpy as np
from sklearn.utils.validation import check_is_fitted

from twin.calibration.lag import as_log, fit_inputs, lagged_c, validated_log
from twin.calibration.lagfit import Z95, linear_fit, search
from twin.calibration.lagcache import WholeLog
from twin.calibration.lagprofile import Profile
from twin.calibration.models import AXES, CompensatorBase, poly_text, to_mg_per_c
from twin.errors import TwinError


class LagAwareCompensator(CompensatorBase):
    """Lag-aware ("twin-based") three-axis temperature compensation.

    Parameters
    ----------
    degree : int
        Degree of the polynomial in ``T_die − reference_c`` (3: the PX4 form). A prior, not
        selected: on one heating ramp the static curve's shape and the lag terms are nearly
        aliased (the rate is almost constant), so higher degrees fit the ramp better and
        extrapolate to other rates worse. Select it only when the training rows hold several rates.
    reference_c : float
        Expansion point [°C].
    share : {"auto", "shared", "per_axis"}
        One (τ_die, τ_rate) for all axes — one die, one thermometer path — or one per axis;
        ``"auto"`` lets BIC on the training rows decide.
    rate_term : {"auto", True, False}
        Include ``b·(T − T_g)``; ``"auto"``: per axis by BIC (all axes together when shared).
    tau_bounds_s : (float, float)
        Search range of the time constants [s].
    n_grid : int
        Grid points per time constant before the quasi-Newton polish.

    Attributes
    ----------
    n_features_in_ : int
        Columns of ``X`` seen in ``fit`` (2, or 3 with a run id).
    tau_die_s_, tau_rate_s_ : (3,) arrays
        Fitted τ_die, τ_rate per axis [s] (equal across axes when ``shared_``; τ_rate NaN where
        an axis has no rate term).
    tau_die_ci95_s_, tau_rate_ci95_s_ : (3, 2) arrays
        95 % intervals (Gauss–Newton, AR(1)-inflated).
    coef_mg_, coef_se_mg_ : (3, degree + 1) arrays
        Polynomial coefficients a_k [mg/°C^k] about ``reference_c`` and their standard errors.
    rate_mg_per_c_, rate_se_mg_per_c_ : (3,) arrays
        Rate/gradient amplitude b [mg/°C] (0 where unused) and its standard error.
    rate_ci95_mg_per_c_ : (3, 2) array
    rate_used_ : (3,) bool array
    shared_ : bool
    selected_ : LagCandidate
        The structure chosen; ``candidates_`` holds every structure tried, with its BIC.
    train_rms_mg_ : (3,) array
    """

    rate_dependent = True

    def __init__(self, degree: int = 3, reference_c: float = 35.0, share: str = "auto", rate_term="auto",
                 tau_bounds_s: tuple[float, float] = (0.0, 600.0), n_grid: int = 12):
        self.degree = degree
        self.reference_c = reference_c
        self.share = share
        self.rate_term = rate_term
        self.tau_bounds_s = tau_bounds_s
        self.n_grid = n_grid

    def share_folds(self, X, y) -> WholeLog:
        """The log reduced once for every fold's fit on rows of it (:class:`~twin.calibration.lagcache.WholeLog`),
        given back to :meth:`fit` as ``shared``.

        Parameters
        ----------
        X : array-like, (n, 2) or (n, 3)
            ``[time_s, temperature_c]`` [s, °C], optionally with a run id.
        y : (n, 3) array-like
            Readings [g].

        Returns
        -------
        WholeLog
        """
        return WholeLog(as_log(X), np.asarray(y, float))

    def fit(self, X, y, mask=None, shared=None):
        """Fit on the rows of ``mask`` (default: every row with finite ``y``). Returns self.

        The lags run over every row of ``X``, so the thermal history before the training rows
        (e.g. the cooling that precedes a heating branch) is accounted for.

        Parameters
        ----------
        X : array-like, (n, 2) or (n, 3)
            ``[time_s, temperature_c]`` [s, °C], optionally with a run id.
        y : (n, 3) array-like
            Readings [g].
        mask : array-like of bool or int, optional
            Rows to fit on.
        shared : WholeLog, optional
            :meth:`share_folds` of the same ``X`` and ``y``: the same search, without reducing
            the whole log again (its sums are taken about another level: equal to rounding).

        Returns
        -------
        LagAwareCompensator
            ``self``, fitted.
        """
        if self.share not in ("auto", "shared", "per_axis") or self.rate_term not in ("auto", True, False):
            raise TwinError(f"share must be auto|shared|per_axis and rate_term auto|True|False; "
                            f"got {self.share!r}, {self.rate_term!r}")
        log, y, keep = fit_inputs(self, X, y, mask)
        if shared is not None and shared.rows != log.time_s.size:
            raise TwinError(f"shared is of a log of {shared.rows} rows; X has {log.time_s.size}")
        profile = Profile(log, y, keep, self.degree, self.reference_c, whole_log=shared)
        step = shared.step_s if shared is not None else float(np.median(np.diff(log.time_s)))
        self.selected_, self.candidates_ = search(profile, tuple(self.tau_bounds_s), 2 * step, self.n_grid,
                                                  self.share, self.rate_term)
        self.shared_ = self.selected_.name.startswith("shared")
        self.tau_die_s_ = np.array(self.selected_.tau_die_s)
        self.tau_rate_s_ = np.array(self.selected_.tau_rate_s)
        self.rate_used_ = np.isfinite(self.tau_rate_s_)
        self._fit_linear(profile)
        return self

    def _fit_linear(self, profile: Profile) -> None:
        coef, rms, lin_cov, se_d, se_g = linear_fit(profile, self.tau_die_s_, self.tau_rate_s_, self.shared_)
        d = self.degree + 1
        self.coef_mg_ = np.array([to_mg_per_c(c[:d]) for c in coef])
        self.coef_se_mg_ = np.array([to_mg_per_c(np.sqrt(np.diag(v)[:d])) for v in lin_cov])
        self.rate_mg_per_c_ = np.array([c[d] * 1e3 if c.size > d else 0.0 for c in coef])
        self.rate_se_mg_per_c_ = np.array([np.sqrt(v[d, d]) * 1e3 if v.shape[0] > d else 0.0 for v in lin_cov])
        self.tau_die_se_s_, self.tau_rate_se_s_ = se_d, se_g
        band = np.array([-Z95, Z95])
        self.rate_ci95_mg_per_c_ = self.rate_mg_per_c_[:, None] + self.rate_se_mg_per_c_[:, None] * band
        self.tau_die_ci95_s_ = self.tau_die_s_[:, None] + se_d[:, None] * band
        self.tau_rate_ci95_s_ = self.tau_rate_s_[:, None] + se_g[:, None] * band
        self.train_rms_mg_ = rms

    def die_temperature_c(self, X) -> np.ndarray:
        """``T_die = lag(T, τ_die)`` per axis [°C], (n, 3).

        Parameters
        ----------
        X : array-like, (n, 2) or (n, 3)
            ``[time_s, temperature_c]`` [s, °C], optionally with a run id.

        Returns
        -------
        (n, 3) ndarray
            Die temperature per axis [°C].
        """
        log = validated_log(self, X, reset=False)
        return np.column_stack([lagged_c(log, t) for t in self.tau_die_s_])

    def predict(self, X) -> np.ndarray:
        """Modelled reading [g], (n, 3).

        Parameters
        ----------
        X : array-like, (n, 2) or (n, 3)
            ``[time_s, temperature_c]`` [s, °C], optionally with a run id.

        Returns
        -------
        (n, 3) ndarray
            Modelled reading [g].
        """
        return self.predict_rows(X, slice(None))

    def predict_rows(self, X, rows) -> np.ndarray:
        """:meth:`predict` on ``rows`` only: the lags still run over every row of ``X`` (the
        thermal state before a row is part of its prediction), the polynomial only on ``rows``
        (a held-out branch of a long log need not pay for the training rows).

        Parameters
        ----------
        X : array-like, (n, 2) or (n, 3)
            ``[time_s, temperature_c]`` [s, °C], optionally with a run id.
        rows : slice or (m,) int array
            Rows to predict.

        Returns
        -------
        (m, 3) ndarray
            Modelled reading [g] of ``rows``.
        """
        log = validated_log(self, X, reset=False)
        T = log.temperature_c[rows]
        out = np.empty((T.size, 3))
        lags: dict[float, np.ndarray] = {}
        for a in range(3):
            for tau in (self.tau_die_s_[a], self.tau_rate_s_[a]):
                if np.isfinite(tau) and tau not in lags:
                    lags[tau] = lagged_c(log, tau)[rows]
            dT = lags[self.tau_die_s_[a]] - self.reference_c
            out[:, a] = np.polyval(self.coef_mg_[a, ::-1], dT)
            if self.rate_used_[a]:
                out[:, a] += self.rate_mg_per_c_[a] * (T - lags[self.tau_rate_s_[a]])
        return out * 1e-3

    def equation(self) -> str:
        """The fitted model with values and units, one line per axis, then the lags.

        Returns
        -------
        str
            The model (mg, mg/°C^k, s).
        """
        check_is_fitted(self)
        lines = []
        for a, ax in enumerate(AXES):
            die = f"T_die{'' if self.shared_ else '_' + ax}"
            text = poly_text(self.coef_mg_[a], f"{die} − {self.reference_c:g} °C")
            if self.rate_used_[a]:
                g = f"T_g{'' if self.shared_ else '_' + ax}"
                text += (f" {self.rate_mg_per_c_[a]:+.4g} mg/°C·(T − {g})"
                         f"  [b = {self.rate_mg_per_c_[a]:.3g} ± {Z95 * self.rate_se_mg_per_c_[a]:.2g} mg/°C, 95 %]")
            lines.append(f"{ax}: {text}  [mg]")
        for a in ([0] if self.shared_ else range(3)):
            sfx = "" if self.shared_ else "_" + AXES[a]
            lines.append(f"T_die{sfx} = lag(T, τ_die = {self.tau_die_s_[a]:.3g} ± "
                         f"{Z95 * self.tau_die_se_s_[a]:.2g} s)")
            if self.rate_used_[a]:
                lines.append(f"T_g{sfx} = lag(T, τ_rate = {self.tau_rate_s_[a]:.3g} ± "
                             f"{Z95 * self.tau_rate_se_s_[a]:.2g} s)")
        lines.append(f"structure: {self.selected_.name} (chosen by BIC on the training rows only)")
        return "\n".join(lines)
