"""Typed results of ``twin render``, ``twin comb``, ``twin test-design`` and ``twin export`` (see :mod:`twin.results`)."""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class RenderResult:
    """What ``twin render`` wrote (``--json``).

    Attributes
    ----------
    output : str
        The image or animation written.
    temperatures_c : list of float
        The temperature of each frame [°C].
    frames : int
        Frames written.
    exaggeration : float
        Displacement scale factor [1].
    reading : str, optional
        Thermal reading of the comb (P, S, H or HE).
    acceleration_g : float, optional
        Input acceleration of the comb [g].
    dofs : int, optional
        Degrees of freedom of the finite-element field (``--fem``).
    field : str, optional
        The finite-element field drawn (``--fem``).
    """

    output: str
    temperatures_c: list[float]
    frames: int
    exaggeration: float
    reading: str | None = None
    acceleration_g: float | None = None
    dofs: int | None = None
    field: str | None = None


@dataclass(frozen=True)
class ExportResult:
    """What ``twin export`` wrote (``--json``).

    Attributes
    ----------
    output : str
        The canonical CSV written.
    rows, runs : int
        Rows and power-on runs written.
    """

    output: str
    rows: int
    runs: int


@dataclass(frozen=True)
class CombReading:
    """Comb drift under one thermal reading.

    Attributes
    ----------
    reading : str
        P, S, H or HE.
    meaning : str
    slope_mg_per_c : float
        Drift slope [mg/°C].
    curvature_mg_per_c2 : float
        Drift curvature [mg/°C²].
    drift_low_mg, drift_high_mg : float
        Drift at both ends of the range [mg].
    max_offset_mg : float
        Largest offset part [mg].
    """

    reading: str
    meaning: str
    slope_mg_per_c: float
    curvature_mg_per_c2: float
    drift_low_mg: float
    drift_high_mg: float
    max_offset_mg: float


@dataclass(frozen=True)
class CombReport:
    """Comb thermal drift under each reading (``twin comb --json``).

    Attributes
    ----------
    C1_fF, C2_fF : float
        Cell capacitances [fF].
    signal_fF_per_g : float
        Differential signal [fF/g].
    du_1g_nm : float
        Displacement at 1 g [nm].
    acceleration_g : float
        Input acceleration [g].
    range_c : tuple of float
        Temperature range [°C].
    readings : list of CombReading
    """

    C1_fF: float
    C2_fF: float
    signal_fF_per_g: float
    du_1g_nm: float
    acceleration_g: float
    range_c: tuple[float, float]
    readings: list[CombReading]


@dataclass(frozen=True)
class DesignItem:
    """One test-design number.

    Attributes
    ----------
    name : str
    value : float
        In ``unit``.
    unit : str
    kind : str
        ``paper-as-printed`` or ``physical``.
    note : str
    """

    name: str
    value: float
    unit: str
    kind: str
    note: str


@dataclass(frozen=True)
class DesignReport:
    """The paper's test-design numbers beside physical time scales (``twin test-design --json``).

    Attributes
    ----------
    items : list of DesignItem
    """

    items: list[DesignItem]


@dataclass(frozen=True)
class CteOrderFit:
    """One polynomial order fitted to silicon's α(T) (the paper's Figure 3).

    Attributes
    ----------
    order : int
        Polynomial order.
    rmse_per_k : float
        Root-mean-square error of the fit [1/K].
    max_abs_error_per_k : float
        Largest absolute error of the fit [1/K].
    """

    order: int
    rmse_per_k: float
    max_abs_error_per_k: float


@dataclass(frozen=True)
class PaperItem:
    """One derived number of the paper next to what the code computes.

    Attributes
    ----------
    item : str
        Name of the number (equation, table or figure).
    paper : float or str or None
        The paper's figure [``unit``]; None where the paper gives none.
    computed : float or str
        What the code computes [``unit``].
    unit : str
        Unit of ``paper`` and ``computed``.
    verdict : str
        ``reproduced``, ``differs`` or ``computed`` (not in the paper), then why.
    per_order : list of CteOrderFit, optional
        The fit of each polynomial order (Figure 3 items).
    x, y : float, optional
        Where the computed minimum lies [1] (eq. (45)).
    """

    item: str
    paper: float | str | None
    computed: float | str
    unit: str
    verdict: str
    per_order: list[CteOrderFit] | None = None
    x: float | None = None
    y: float | None = None


@dataclass(frozen=True)
class PaperReport:
    """The paper's derived numbers with a verdict each (``twin paper --json``).

    Attributes
    ----------
    items : list of PaperItem
        Each number.
    reproduced, differs, computed : int
        Items of each verdict.
    """

    items: list[PaperItem]
    reproduced: int
    differs: int
    computed: int
