"""Display objects of many-run results: the compensation benchmark and design-of-experiment studies.

Same pattern as :mod:`twin.reporting.plots`: data in the object, ``from_*`` builders, and
``plot(ax=None)`` that draws on the axes given (a grid of a study's plots passes its own axes).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from twin.reporting.plots import Display


@dataclass
class NoiseFloorRatioDisplay(Display):
    """Table 1 of the benchmark: each model's mean MSE over the noise floor.

    Attributes
    ----------
    models : list of str
    ratios : list of float
        Mean MSE over the noise floor's, per model [1].
    """

    models: list
    ratios: list
    figsize = (8, 3.8)
    title = "Table 1 as a ratio to the noise floor (mean over tests)"

    @classmethod
    def from_benchmark(cls, result: dict):
        """The display of a benchmark result.

        Parameters
        ----------
        result : dict
            The benchmark result; its ``table1`` rows (``model``, ``ratio_mean``) are read.

        Returns
        -------
        NoiseFloorRatioDisplay
        """
        rows = result["table1"]
        return cls([r["model"] for r in rows], [r["ratio_mean"] for r in rows])

    def _draw(self, ax):
        ax.bar(self.models, self.ratios, color="C0")
        ax.axhline(1.0, color="k", ls=":", label="noise floor")
        ax.set_ylabel("MSE / noise floor")
        ax.tick_params(axis="x", rotation=30)
        ax.set_ylim(min(0.98, min(self.ratios) * 0.99), None)
        ax.legend()


@dataclass
class ConvergenceDisplay(Display):
    """Table 2 of the benchmark: the search winner's training MSE after each iteration.

    Attributes
    ----------
    series : dict
        Model → (iterations, mean MSE [g²]).
    noise_floor_mse : float
        The noise floor's MSE [g²].
    """

    series: dict  # name → (iterations, mean MSE [g²])
    noise_floor_mse: float
    title = "Table 2: MSE vs iteration before back-propagation"

    @classmethod
    def from_benchmark(cls, result: dict):
        """The display of a benchmark result.

        Parameters
        ----------
        result : dict
            The benchmark result; ``table2`` (MSE [g²] per iteration) and ``noise_floor_mse`` [g²] are read.

        Returns
        -------
        ConvergenceDisplay
        """
        series = {}
        for name, t in result["table2"].items():
            its = sorted(int(k) for k in t["mse_g2_at_iteration"])
            series[name] = (its, [t["mse_g2_at_iteration"][str(i)]["mean"] for i in its])
        return cls(series, result["noise_floor_mse"])

    def _draw(self, ax):
        for name, (its, mse) in self.series.items():
            ax.plot(its, mse, "o-", label=name)
        ax.axhline(self.noise_floor_mse, color="k", ls=":", label="noise floor")
        ax.set_yscale("log")
        ax.set_xlabel("iteration (GA generation / PSO-GA step)")
        ax.set_ylabel("training MSE of the search winner [g²]")
        ax.legend(fontsize=8)


@dataclass
class SplitRatioDisplay(Display):
    """MSE over the noise floor of every model on one benchmark split (log scale).

    Attributes
    ----------
    label : str
        The split, shown as the title.
    models : list of str
    ratios : list of float
        MSE over the noise floor's, per model [1].
    """

    label: str
    models: list
    ratios: list
    figsize = (8, 3.5)

    @classmethod
    def from_split(cls, label: str, split: dict | None):
        """The display of one split; ``None`` when the benchmark has no such split.

        Parameters
        ----------
        label : str
            The split's title.
        split : dict or None
            Model → MSE [g²], with ``noise_floor``.

        Returns
        -------
        SplitRatioDisplay or None
        """
        if not split:
            return None
        names = [k for k in split if k != "noise_floor"]
        return cls(label, names, [split[k] / split["noise_floor"] for k in names])

    @property
    def title(self) -> str:
        """The split's label, as the title."""
        return self.label

    def _draw(self, ax):
        ax.bar(self.models, self.ratios, color="C1")
        ax.axhline(1.0, color="k", ls=":")
        if max(self.ratios, default=1.0) > 10 * max(min(self.ratios, default=1.0), 1e-12):
            ax.set_yscale("log")  # a log axis only where the ratios span a decade: no 1.07 × 10⁰ ticks
        else:
            ax.set_ylim(min(0.98, 0.99 * min(self.ratios, default=1.0)), None)
        ax.set_ylabel("MSE / noise floor")
        ax.tick_params(axis="x", rotation=30)


def benchmark_displays(result: dict) -> list[Display]:
    """Every display of the benchmark report, in report order.

    Parameters
    ----------
    result : dict
        The benchmark result.

    Returns
    -------
    list of Display
        Absent splits skipped.
    """
    shown = [NoiseFloorRatioDisplay.from_benchmark(result), ConvergenceDisplay.from_benchmark(result),
             SplitRatioDisplay.from_split("extrapolation split (train ≤ 30 °C, test > 30 °C)",
                                          result.get("extrapolation_split")),
             SplitRatioDisplay.from_split("ramp-rate split (test at twice the ramp rate)", result.get("ramp_rate_split"))]
    return [s for s in shown if s is not None]


@dataclass
class MainEffectDisplay(Display):
    """A study's response averaged at each level of one factor.

    Attributes
    ----------
    factor, response : str
        Names, with their units, as the axis labels.
    levels, means : list
        The factor's levels and the mean response at each [the response's unit].
    """

    factor: str
    response: str
    levels: list
    means: list
    figsize = (3.2, 2.6)
    title = "Main effect"

    def _draw(self, ax):
        ax.plot(self.levels, self.means, "o-")
        ax.set_xlabel(self.factor, fontsize=8)
        ax.set_ylabel(self.response, fontsize=8)
        ax.tick_params(labelsize=7, axis="x", rotation=30)


@dataclass
class ResponseSurfaceDisplay(Display):
    """A response over two numeric factors: the runs as points, a triangulated contour behind them.

    Attributes
    ----------
    x_name, y_name, response : str
        Names of the two factors and of the response (axis labels).
    x, y, z : list of float
        Per run: both factors and the response [their units].
    """

    x_name: str
    y_name: str
    response: str
    x: list
    y: list
    z: list
    figsize = (4.2, 3.6)
    title = "Response surface"

    def _draw(self, ax):
        sc = ax.scatter(self.x, self.y, c=self.z, cmap="viridis", s=40)
        try:
            ax.tricontourf(self.x, self.y, self.z, levels=10, alpha=0.5, cmap="viridis")
        except Exception:  # too few distinct points for a triangulation: the scatter stays
            pass
        ax.figure.colorbar(sc, ax=ax, label=self.response)
        ax.set_xlabel(self.x_name, fontsize=8)
        ax.set_ylabel(self.y_name, fontsize=8)


@dataclass
class SobolDisplay(Display):
    """First-order (S1) and total (ST) Sobol indices of one response.

    Attributes
    ----------
    response : str
    factors : list of str
    s1, st : list of float
        First-order and total index per factor [1] (:func:`twin.studies.analysis.sobol_indices`).
    """

    response: str
    factors: list
    s1: list
    st: list
    figsize = (4, 3.4)
    title = "Sobol indices"

    def _draw(self, ax):
        x = np.arange(len(self.factors))
        ax.bar(x - 0.2, self.s1, 0.4, label="S1")
        ax.bar(x + 0.2, self.st, 0.4, label="ST")
        ax.set_xticks(x, self.factors, rotation=30, fontsize=7)
        ax.set_title(self.response, fontsize=9)
        ax.legend(fontsize=7)


@dataclass
class ResidualByMethodDisplay(Display):
    """One axis: the residual of each compensation method against temperature, heating and cooling
    apart (where a method misses a lag or gradient, its two branches split).

    Attributes
    ----------
    axis : str
    temperature_c : np.ndarray
        Temperature per sample [°C].
    residual_mg : dict
        Method → (n,) residual [mg].
    heating : np.ndarray
        Bool per sample.
    noise_floor_mg : float
        White-noise σ [mg].
    """

    axis: str
    temperature_c: np.ndarray
    residual_mg: dict  # method → (n,) residual [mg]
    heating: np.ndarray  # bool per sample
    noise_floor_mg: float
    figsize = (7, 3.8)

    @property
    def title(self) -> str:
        """The axis and what the markers mean."""
        return f"Axis {self.axis}: residual after each method vs temperature (dots: heating, crosses: cooling)"

    def _draw(self, ax):
        stride = max(1, self.temperature_c.size // 4000)
        for k, (method, r) in enumerate(self.residual_mg.items()):
            for sel, marker in ((self.heating, "."), (~self.heating, "+")):
                idx = np.flatnonzero(sel)[::stride]
                ax.plot(self.temperature_c[idx], r[idx], marker, ls="none", ms=2, color=f"C{k}",
                        label=method if marker == "." else None)
        ax.axhspan(-2 * self.noise_floor_mg, 2 * self.noise_floor_mg, color="0.85", label="±2σ noise floor")
        ax.set_xlabel("temperature [°C]")
        ax.set_ylabel("residual [mg]")
        ax.legend(fontsize=7, ncol=3)
