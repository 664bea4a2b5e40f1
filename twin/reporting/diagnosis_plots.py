"""The compare report's displays: measured vs twin, residual, hysteresis, ±1 g, dwells, ACF and Allan
deviation (each a :class:`~twin.reporting.plots.Display`); the evidence displays are in
:mod:`twin.reporting.evidence_plots`."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from twin.arrays import moving_mean
from twin.reporting.evidence_plots import CandidateRankingDisplay, LedgerDisplay
from twin.reporting.plots import Display, stride


@dataclass
class MeasuredVsTwinDisplay(Display):
    """Measured output and the twin over time, heating/cooling shaded, temperature on the right.

    Attributes
    ----------
    time_h, measured_mg, twin_mg, temperature_c, segment_kind : np.ndarray
        Per sample: time [h], output measured and of the twin [mg], temperature [°C], segment kind.
    """

    time_h: np.ndarray
    measured_mg: np.ndarray
    twin_mg: np.ndarray
    temperature_c: np.ndarray
    segment_kind: np.ndarray
    figsize = (10, 3.6)
    title = "Measured vs twin (heating/cooling shaded; temperature on the right)"

    @classmethod
    def from_diagnosis(cls, d):
        """The display of diagnosis ``d``: output and twin in mg, time in h.
        Parameters
        ----------
        d : Diagnosis

        Returns
        -------
        MeasuredVsTwinDisplay
        """
        p, m = d.problem, d.problem.m
        pred = p.applied + d.fit.prediction_minus_applied
        return cls(m.time_s / 3600, m.output_g * 1e3, pred * 1e3, m.temperature_c, d.segment_kind)

    def _draw(self, ax):
        s = stride(self.time_h.size)
        t = self.time_h[::s]
        ax.plot(t, self.measured_mg[::s], ",", color="0.6", label="measured")
        ax.plot(t, self.twin_mg[::s], "-", color="C0", lw=1, label="twin")
        for k, c in (("heating", "C3"), ("cooling", "C0")):
            sel = self.segment_kind == k
            if sel.any():
                ax.fill_between(t, 0, 1, where=sel[::s], transform=ax.get_xaxis_transform(), color=c, alpha=0.07,
                                label=k)
        ax.set_xlabel("time [h]")
        ax.set_ylabel("output [mg]")
        ax2 = ax.twinx()
        ax2.plot(t, self.temperature_c[::s], color="C1", lw=0.8)
        ax2.set_ylabel("temperature [°C]", color="C1")
        ax.legend(loc="upper left", fontsize=8, ncol=4)


@dataclass
class ResidualDisplay(Display):
    """Residual over time with its 10-min mean and the ±2σ noise band.

    Attributes
    ----------
    time_h, residual_mg : np.ndarray
        Time [h] and residual [mg] per sample.
    noise_floor_mg, rate_hz : float
        White-noise floor [mg] and sample rate [Hz].
    """

    time_h: np.ndarray
    residual_mg: np.ndarray
    noise_floor_mg: float
    rate_hz: float
    figsize = (10, 3.2)
    title = "Residual (measured − twin) with the noise band"

    @classmethod
    def from_diagnosis(cls, d):
        """The display of diagnosis ``d``: full-rate residual and noise floor in mg.
        Parameters
        ----------
        d : Diagnosis

        Returns
        -------
        ResidualDisplay
        """
        return cls(d.problem.m.time_s / 3600, d.fit.residual * 1e3, d.noise_floor_g * 1e3, d.problem.rate_hz)

    def _draw(self, ax):
        s = stride(self.time_h.size)
        ax.plot(self.time_h[::s], self.residual_mg[::s], ",", color="0.5")
        w = max(1, int(600 * self.rate_hz))
        ax.plot(self.time_h, moving_mean(self.residual_mg, w), color="C3", lw=1.2,
                label="10-min mean")
        ax.axhspan(-2 * self.noise_floor_mg, 2 * self.noise_floor_mg, color="C2", alpha=0.12, label="±2σ noise floor")
        ax.set_xlabel("time [h]")
        ax.set_ylabel("residual [mg]")
        ax.legend(fontsize=8)


@dataclass
class HysteresisDisplay(Display):
    """Block-mean residual against temperature, by segment kind, with the loop area per run.

    Attributes
    ----------
    temperature_c, residual_mg, segment_kind : np.ndarray
        Per block: die temperature [°C], residual [mg], segment kind.
    loop_area_mg_c : dict
        Run → loop area ∮ r dT [mg·°C].
    average_s : float
        Block length [s].
    """

    temperature_c: np.ndarray
    residual_mg: np.ndarray
    segment_kind: np.ndarray
    loop_area_mg_c: dict
    average_s: float
    figsize = (6.5, 4.2)
    title = "Hysteresis view: residual vs temperature"

    @classmethod
    def from_diagnosis(cls, d):
        """The display of diagnosis ``d``: block means of die temperature and residual.
        Parameters
        ----------
        d : Diagnosis

        Returns
        -------
        HysteresisDisplay
        """
        p = d.problem
        kind = np.array(d.segment_kind)[p.avg.starts]
        return cls(p.avg(p.inputs.die_c), p.avg(d.fit.residual) * 1e3, kind, d.segments.loop_area_mg_c,
                   p.config.average_s)

    def _draw(self, ax):
        for k, c in (("heating", "C3"), ("cooling", "C0"), ("dwell", "0.5")):
            sel = self.segment_kind == k
            ax.plot(self.temperature_c[sel], self.residual_mg[sel], ".", ms=3, color=c, label=k)
        area = ", ".join(f"run {k}: {v:.2f}" for k, v in self.loop_area_mg_c.items())
        ax.set_title(f"loop area ∮r dT [mg·°C]: {area}", fontsize=9)
        ax.set_xlabel("temperature [°C]")
        ax.set_ylabel(f"residual, {self.average_s:g}-s mean [mg]")
        ax.legend(fontsize=8)


@dataclass
class HalfSumDifferenceDisplay(Display):
    """±1 g half-sum (bias-like) and half-difference (scale-factor-like) of the residual vs temperature.

    Attributes
    ----------
    temperature_c, half_sum_mg, half_difference_mg : np.ndarray
        Per temperature bin: centre [°C], (r₊ + r₋)/2 and (r₊ − r₋)/2 [mg] (docs/diagnosis.md §1 step 2).
    """

    temperature_c: np.ndarray
    half_sum_mg: np.ndarray
    half_difference_mg: np.ndarray
    figsize = (6.5, 4)
    title = "±1 g half-sum and half-difference"

    @classmethod
    def from_diagnosis(cls, d):
        """``None`` unless the measurement holds both +1 g and −1 g.
        Parameters
        ----------
        d : Diagnosis

        Returns
        -------
        HalfSumDifferenceDisplay or None
        """
        p = d.problem
        if not (p.m.applied_known and np.any(np.isclose(p.applied, 1)) and np.any(np.isclose(p.applied, -1))):
            return None
        tavg, ravg, aavg = p.avg(p.inputs.die_c), p.avg(d.fit.residual) * 1e3, p.avg(p.applied)
        bins = np.linspace(tavg.min(), tavg.max(), 25)

        def binned(sel):
            return np.array([np.mean(ravg[sel & (tavg >= a) & (tavg < b)]) if np.any(sel & (tavg >= a) & (tavg < b))
                             else np.nan for a, b in zip(bins[:-1], bins[1:])])

        rp, rn = binned(aavg > 0.9), binned(aavg < -0.9)
        return cls(0.5 * (bins[1:] + bins[:-1]), 0.5 * (rp + rn), 0.5 * (rp - rn))

    def _draw(self, ax):
        ax.plot(self.temperature_c, self.half_sum_mg, "o-", label="half-sum (bias-like)")
        ax.plot(self.temperature_c, self.half_difference_mg, "s-", label="half-difference (scale-factor-like)")
        ax.set_xlabel("temperature [°C]")
        ax.set_ylabel("residual [mg]")
        ax.legend(fontsize=8)


@dataclass
class DwellSettlingDisplay(Display):
    """The residual's 1-min mean after each dwell start (up to eight dwells).

    Attributes
    ----------
    curves : list of (np.ndarray, np.ndarray)
        Per dwell: minutes since its start [min] and the residual [mg].
    starts_h : list of float
        When each dwell starts [h] (the legend).
    """

    curves: list = field(default_factory=list)  # (minutes since dwell start, residual [mg]) per dwell
    starts_h: list = field(default_factory=list)  # when each dwell starts [h]
    figsize = (6.5, 3.8)
    title = "Dwell settling (minutes: lag; hours: creep; flat: static)"

    @classmethod
    def from_diagnosis(cls, d):
        """``None`` when the measurement has no dwell.
        Parameters
        ----------
        d : Diagnosis

        Returns
        -------
        DwellSettlingDisplay or None
        """
        p, m = d.problem, d.problem.m
        dwell = d.segment_kind == "dwell"
        starts = np.flatnonzero(np.diff(dwell.astype(int)) == 1) + 1
        if not starts.size:
            return None
        w = max(1, int(60 * p.rate_hz))
        r_mg = d.fit.residual * 1e3
        curves = []
        for s in starts[:8]:
            e = s
            while e < dwell.size and dwell[e]:
                e += 1
            curves.append(((m.time_s[s:e] - m.time_s[s]) / 60, moving_mean(r_mg[s:e], w)))
        return cls(curves, [(m.time_s[s] - m.time_s[0]) / 3600 for s in starts[:8]])

    def _draw(self, ax):
        for k, (minutes, residual_mg) in enumerate(self.curves):
            ax.plot(minutes, residual_mg, lw=1, label=f"dwell from {self.starts_h[k]:.2f} h" if k < len(self.starts_h) else None)
        if self.starts_h:
            ax.legend(fontsize=8, ncol=2)
        ax.set_xlabel("time since dwell start [min]")
        ax.set_ylabel("residual, 1-min mean [mg]")


@dataclass
class ResidualACFDisplay(Display):
    """Autocorrelation of the block-mean residual with the ±1.96/√N white-noise bounds.

    Attributes
    ----------
    lag_min, acf : np.ndarray
        Lag [min] and autocorrelation [1].
    n_blocks : int
        N, the blocks.
    bar_width_min : float
        Bar width [min].
    """

    lag_min: np.ndarray
    acf: np.ndarray
    n_blocks: int
    bar_width_min: float
    figsize = (5.5, 3.8)
    title = "Residual autocorrelation"

    @classmethod
    def from_diagnosis(cls, d):
        """The display of diagnosis ``d``: ACF of the block-mean residual, lags up to 59 blocks.
        Parameters
        ----------
        d : Diagnosis

        Returns
        -------
        ResidualACFDisplay
        """
        p = d.problem
        ra = p.avg(d.fit.residual)
        lags = np.arange(1, min(60, ra.size // 4))
        acf = np.array([np.corrcoef(ra[:-k], ra[k:])[0, 1] for k in lags])
        return cls(lags * p.config.average_s / 60, acf, ra.size, p.config.average_s / 60 * 0.8)

    def _draw(self, ax):
        ax.bar(self.lag_min, self.acf, width=self.bar_width_min)
        for sign in (1, -1):
            ax.axhline(sign * 1.96 / np.sqrt(self.n_blocks), color="k", ls=":")
        ax.set_xlabel("lag [min]")
        ax.set_ylabel("residual ACF")


@dataclass
class AllanDeviationDisplay(Display):
    """Allan deviation of the residual beside white noise at the floor (and the sensor model's).

    Attributes
    ----------
    tau_s, adev_mg : np.ndarray
        Averaging time [s] and Allan deviation [mg].
    noise_floor_mg, noise_floor_model_mg : float
        White-noise σ from the data, and the sensor model's (or None) [mg].
    rate_hz : float
        Sample rate [Hz].
    """

    tau_s: np.ndarray
    adev_mg: np.ndarray
    noise_floor_mg: float
    noise_floor_model_mg: float | None
    rate_hz: float
    figsize = (5.5, 3.8)
    title = "Allan deviation against a noise-only reference"

    @classmethod
    def from_diagnosis(cls, d):
        """The display of diagnosis ``d``: Allan deviation of the full-rate residual.
        Parameters
        ----------
        d : Diagnosis

        Returns
        -------
        AllanDeviationDisplay
        """
        from sim.sensor import allan_deviation
        from twin.estimation.noise import allan_taus_s

        rate = d.problem.rate_hz
        taus, adev = allan_deviation(d.fit.residual, rate, allan_taus_s(len(d.fit.residual), rate))
        model = d.noise_floor_model_g * 1e3 if d.noise_floor_model_g else None
        return cls(taus, adev * 1e3, d.noise_floor_g * 1e3, model, d.problem.rate_hz)

    def _draw(self, ax):
        ax.loglog(self.tau_s, self.adev_mg, label="residual")
        white = 1 / np.sqrt(self.tau_s * self.rate_hz)
        ax.loglog(self.tau_s, self.noise_floor_mg * white, "--", label="white noise at the floor")
        if self.noise_floor_model_mg:
            ax.loglog(self.tau_s, self.noise_floor_model_mg * white, ":", label="sensor model")
        ax.set_xlabel("averaging time [s]")
        ax.set_ylabel("Allan deviation [mg]")
        ax.legend(fontsize=8)


def diagnosis_displays(d, ledger: list[dict]) -> list[Display]:
    """Every display of a compare report, in report order (absent ones skipped).

    Parameters
    ----------
    d : Diagnosis
    ledger : list of dict
        The ledger's entries (``model``, ``rms_residual_g`` [g], ``noise_floor_g`` [g]).

    Returns
    -------
    list of Display
    """
    shown = [MeasuredVsTwinDisplay.from_diagnosis(d), ResidualDisplay.from_diagnosis(d),
             HysteresisDisplay.from_diagnosis(d), HalfSumDifferenceDisplay.from_diagnosis(d),
             DwellSettlingDisplay.from_diagnosis(d), ResidualACFDisplay.from_diagnosis(d),
             AllanDeviationDisplay.from_diagnosis(d), CandidateRankingDisplay.from_diagnosis(d),
             LedgerDisplay.from_ledger(ledger)]
    return [s for s in shown if s is not None]
