"""Temperature-correlated features (the paper's TCQ) that compose and name their columns.

The paper's quantities are T, T², ΔT, ΔT² (§2.2.2). ΔT is defined explicitly here:

* ``reference``: ΔT = T − T0 (default; the reading consistent with the paper's Table 1). Then
  (ΔT, ΔT²) and (T, T²) span the same space, so the paper's Model 1 can differ from the
  conventional model only through optimisation;
* ``window``: ΔT = T(t) − T(t − w), w = the control period (35 s). Then the conventional model
  has no absolute temperature at all.

``dTdt`` (rate of change, from a centred difference over ``window_s``) is our extension: no static
map of T can see the die lagging the thermometer, a rate feature can.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

_TERMS = ("T", "T2", "dT", "dT2", "dTdt")


@dataclass(frozen=True)
class FeatureSet:
    """Named feature columns computed from temperature [°C] and time [s].

    Sets compose with ``+``; :meth:`names` gives the column names (for printing an equation).

    Attributes
    ----------
    terms : tuple of str
        Columns, from ``"T"`` [°C], ``"T2"`` [°C²], ``"dT"`` [°C], ``"dT2"`` [°C²], ``"dTdt"`` [°C/min].
    delta : {"reference", "window"}
        ΔT = T − T0, or ΔT = T(t) − T(t − ``window_s``) (module docstring).
    t0_c : float or None
        Reference temperature T0 [°C]; None: the first sample.
    window_s : float
        Window w of ΔT and of the centred difference of dT/dt [s].

    References
    ----------
    Qi et al. (2022), Micromachines 13, 2156, §2.2.2 (T, T², ΔT, ΔT²); ``dTdt`` is an extension.
    """

    terms: tuple[str, ...]
    delta: str = "reference"
    t0_c: float | None = None  # reference temperature; None = the first sample
    window_s: float = 35.0

    def __post_init__(self) -> None:
        for t in self.terms:
            if t not in _TERMS:
                raise ValueError(f"unknown feature {t!r}; features are {', '.join(_TERMS)}")
        if self.delta not in ("reference", "window"):
            raise ValueError(f"delta must be 'reference' or 'window', got {self.delta!r}")

    def __add__(self, other: FeatureSet) -> FeatureSet:
        if (self.delta, self.t0_c, self.window_s) != (other.delta, other.t0_c, other.window_s):
            raise ValueError("feature sets with different ΔT definitions do not compose")
        terms = tuple(dict.fromkeys(self.terms + other.terms))
        return FeatureSet(terms, self.delta, self.t0_c, self.window_s)

    def names(self) -> list[str]:
        """Printable column names.

        Returns
        -------
        list of str
            E.g. ``["T", "T^2", "dT", "dT^2", "dT/dt"]``.
        """
        label = {"T": "T", "T2": "T^2", "dT": "dT", "dT2": "dT^2", "dTdt": "dT/dt"}
        return [label[t] for t in self.terms]

    def transform(self, temperature_c: np.ndarray, time_s: np.ndarray) -> np.ndarray:
        """Feature matrix (n × k) in the order of ``terms``.

        Parameters
        ----------
        temperature_c : ndarray
            Temperature T [°C].
        time_s : ndarray
            Sample times [s].

        Returns
        -------
        ndarray
            Features (n, k) [°C, °C², °C/min by column].
        """
        t = np.asarray(temperature_c, float)
        time_s = np.asarray(time_s, float)
        if self.delta == "reference":
            t0 = t[0] if self.t0_c is None else self.t0_c
            dT = t - t0
        else:
            dT = t - np.interp(time_s - self.window_s, time_s, t, left=t[0])
        cols = {"T": t, "T2": t * t, "dT": dT, "dT2": dT * dT}
        if "dTdt" in self.terms:
            half = self.window_s / 2
            ahead = np.interp(time_s + half, time_s, t, right=t[-1])
            behind = np.interp(time_s - half, time_s, t, left=t[0])
            cols["dTdt"] = (ahead - behind) / self.window_s * 60.0  # °C/min
        return np.column_stack([cols[k] for k in self.terms])


CONVENTIONAL = FeatureSet(("dT", "dT2"))
PAPER = FeatureSet(("T", "T2", "dT", "dT2"))
EXTENSION = PAPER + FeatureSet(("dTdt",))
