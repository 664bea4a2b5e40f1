"""The result of ``twin plan``, typed: its JSON and schema derive from the types (:mod:`twin.results`)."""

from __future__ import annotations

from dataclasses import dataclass

from twin.plan.check import CheckRate
from twin.results import to_json


@dataclass(frozen=True)
class RivalRecord:
    """One rival the plan separates, as calibrated to the data.

    Attributes
    ----------
    effect : str
        A registered effect or ``none``.
    source : str
        Why it is a rival (``named``, ``rival``, ``withheld``, ``alias``, ``untestable``, ``given`` …).
    values : dict of str to float
        Its parameters, in each one's unit.
    """

    effect: str
    source: str
    values: dict[str, float]


@dataclass(frozen=True)
class PairSeparation:
    """Expected ΔBIC of ``truth`` over ``rival``'s best fit when ``truth`` is true [1].

    Attributes
    ----------
    truth, rival : str
    expected_delta_bic : float
    """

    truth: str
    rival: str
    expected_delta_bic: float


@dataclass(frozen=True)
class ProgramStep:
    """One line of the lab's program table.

    Attributes
    ----------
    step : int
    kind : str
        ``hold`` or ``ramp``.
    from_c, to_c : float
        Set-points [°C].
    rate_c_per_h : float or None
        Ramp rate [°C/h] (None for a hold).
    duration_h, end_h : float
        Its duration and the elapsed time at its end, within the run [h].
    """

    step: int
    kind: str
    from_c: float
    to_c: float
    rate_c_per_h: float | None
    duration_h: float
    end_h: float


@dataclass(frozen=True)
class TestDesign:
    """A test and what it is expected to separate.

    Attributes
    ----------
    name : str
        ``plan`` or the baseline's name.
    description : str
    chamber_hours : float
        Every run included [h].
    runs : int
    orientation : str
    power_ons_per_run : int
    worst_pair : tuple of str
        (truth, rival) with the least expected ΔBIC.
    worst_expected_delta_bic : float
        The criterion [1].
    pairs : tuple of PairSeparation
    predicted_rate : dict of str to float
        Predicted probability that the diagnosis names each rival first when true [1]: from the
        simulated trials' margins where the test was tried (the plan), else the expected separation's
        normal approximation.
    logger_rate_hz : float
        Logger rate of the test [Hz].
    trial_rate : dict of str to float, optional
        Share of the ranking's simulated tests on which the blind diagnosis named each rival first
        when true [1] (the plan, when its finalists were tried by simulation).
    trial_seeds : int
        Simulated tests per rival behind ``trial_rate``.
    """

    name: str
    description: str
    chamber_hours: float
    runs: int
    orientation: str
    power_ons_per_run: int
    worst_pair: tuple[str, str]
    worst_expected_delta_bic: float
    pairs: tuple[PairSeparation, ...]
    predicted_rate: dict[str, float]
    logger_rate_hz: float = 1.0
    trial_rate: dict[str, float] | None = None
    trial_seeds: int = 0


@dataclass(frozen=True)
class PlanResult:
    """``twin plan``: the test that best separates the rivals within the budget.

    Attributes
    ----------
    rivals : tuple of RivalRecord
    set_aside : tuple of str
        Rivals no candidate test makes visible against the twin (no chamber program separates them).
    budget_h : float
        Chamber hours allowed [h].
    candidates_evaluated : int
    plan : TestDesign
    program : tuple of ProgramStep
        One run's program, for the lab.
    amplitude_ci95 : dict of str to dict of str to float
        Predicted 95 % half-width of each rival's amplitudes under the plan [their unit].
    baselines : tuple of TestDesign
        The obvious tests of the same budget (the scenario's protocol repeated, a second ramp rate alone).
    why : str
        Why the plan beats them, in one or two sentences.
    scenario : str, optional
        Where the plan's scenario YAML was written.
    check : tuple of CheckRate, optional
        The plan simulated with each rival as truth and diagnosed blind.
    baseline_check : tuple of CheckRate, optional
        The same for the scenario's protocol repeated, when asked.
    design_wall_s : float
        Wall-clock time of the design: the candidates scored and the finalists' trials [s].
    check_wall_s : float
        Wall-clock time of the check, the baseline's included [s].
    """

    rivals: tuple[RivalRecord, ...]
    set_aside: tuple[str, ...]
    budget_h: float
    candidates_evaluated: int
    plan: TestDesign
    program: tuple[ProgramStep, ...]
    amplitude_ci95: dict[str, dict[str, float]]
    baselines: tuple[TestDesign, ...]
    why: str
    scenario: str | None = None
    check: tuple[CheckRate, ...] | None = None
    baseline_check: tuple[CheckRate, ...] | None = None
    design_wall_s: float = 0.0
    check_wall_s: float = 0.0

    def to_json(self) -> dict:
        """The JSON of ``twin plan --json``.

        Returns
        -------
        dict
        """
        return to_json(self)
