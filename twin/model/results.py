"""Typed results of the model commands: ``twin run`` and ``twin package`` (see :mod:`twin.results`)."""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class RunSummary:
    """Summary of a simulated dataset (``twin run --json``).

    Attributes
    ----------
    samples : int
        Logged samples.
    duration_h : float
        Duration [h].
    seed : int
        Random seed.
    runs : int
        Power-on runs.
    effects : list of str
        Effects simulated.
    setpoint_range_c, die_range_c : tuple of float
        Set-point and die temperature range [°C].
    die_minus_thermometer_max_abs_c : float
        Largest |die − thermometer| [°C].
    drift_range_mg : tuple of float
        Drift range [mg] (over all axes of a three-axis dataset).
    white_noise_sigma_mg : float
        White-noise σ [mg].
    output_rms_minus_truth_mg : float
        RMS of output minus truth [mg].
    saturated_samples : int
        Samples at the output's limit.
    output : str, optional
        The HDF5 file written.
    axes : list of str, optional
        The axes of a three-axis dataset.
    """

    samples: int
    duration_h: float
    seed: int
    runs: int
    effects: list[str]
    setpoint_range_c: tuple[float, float]
    die_range_c: tuple[float, float]
    die_minus_thermometer_max_abs_c: float
    drift_range_mg: tuple[float, float]
    white_noise_sigma_mg: float
    output_rms_minus_truth_mg: float
    saturated_samples: int
    output: str | None = None
    axes: list[str] | None = None


@dataclass(frozen=True)
class PackageMesh:
    """The finite-element mesh of the package model.

    Attributes
    ----------
    elements, dofs : int
        Element and degree-of-freedom counts.
    element : str
        Element type.
    kinematics : str
        Plane kinematics (``gps``: generalised plane strain).
    """

    elements: int
    dofs: int
    element: str
    kinematics: str


@dataclass(frozen=True)
class Warpage:
    """The die's warpage at one temperature.

    Attributes
    ----------
    temperature_c : float
        Temperature [°C].
    die_bow_um : float
        Die bow [µm].
    curvature_per_m : float
        Curvature [1/m].
    """

    temperature_c: float
    die_bow_um: float
    curvature_per_m: float


@dataclass(frozen=True)
class DatasheetDrift:
    """The datasheet's drift figures quoted beside the model.

    Attributes
    ----------
    tcoff_mg_per_c : float
        TCOff [mg/°C].
    tcso_ppm_per_c : float
        TCSo [ppm/°C].
    source : str
    """

    tcoff_mg_per_c: float
    tcso_ppm_per_c: float
    source: str


@dataclass(frozen=True)
class PackageSweep:
    """Offset and scale factor over the temperature sweep.

    Attributes
    ----------
    temperature_c : list of float
        Temperatures [°C].
    offset_mg : list of float
        Offset [mg].
    scale_factor_ppm : list of float
        Scale-factor change [ppm].
    """

    temperature_c: list[float]
    offset_mg: list[float]
    scale_factor_ppm: list[float]


@dataclass(frozen=True)
class PackagePrediction:
    """The finite-element package model's drift prediction (``twin package --json``).

    Attributes
    ----------
    design : dict of str to float
        The ``package_fem`` parameters, each in its unit.
    mesh : PackageMesh
    warpage : list of Warpage
        At −40, 25 and 85 °C.
    curvature_per_m_per_k : float
        Curvature slope [1/(m K)].
    tcoff_mg_per_c, tcoff_excursion_mg_per_c : float
        TCOff: least-squares slope and largest excursion from the reference [mg/°C].
    tcso_ppm_per_c, tcso_excursion_ppm_per_c : float
        TCSo: slope and largest excursion [ppm/°C].
    tcoff_by_material_mg_per_c : dict of str to float
        TCOff split by material [mg/°C].
    delta_pm_per_k : float
        Input-equivalent gap change [pm/K].
    anchor_motion_pm_per_k, gap_change_pm_per_k : dict of str to float
        Anchor motion and gap change [pm/K].
    anchors_um : dict of str to float
        Anchor positions [µm].
    datasheet : DatasheetDrift
    sweep : PackageSweep
    effect_source : str, optional
        Where the ``package_fem`` effect came from (``twin package``).
    """

    design: dict[str, float]
    mesh: PackageMesh
    warpage: list[Warpage]
    curvature_per_m_per_k: float
    tcoff_mg_per_c: float
    tcoff_excursion_mg_per_c: float
    tcso_ppm_per_c: float
    tcso_excursion_ppm_per_c: float
    tcoff_by_material_mg_per_c: dict[str, float]
    delta_pm_per_k: float
    anchor_motion_pm_per_k: dict[str, float]
    gap_change_pm_per_k: dict[str, float]
    anchors_um: dict[str, float]
    datasheet: DatasheetDrift
    sweep: PackageSweep
    effect_source: str | None = None
