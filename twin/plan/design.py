"""``twin plan``: the chamber test, within a time budget and the chamber's limits, that best separates
the rivals a finding left open, checked by simulation (docs/plan.md).

Every candidate of :func:`~twin.plan.programs.candidate_programs` is scored by its least predicted
rate (each rival named first when true) and then by the T-optimal criterion of
:mod:`~twin.plan.separation` (the least expected ΔBIC over ordered pairs of rivals), fewest hours
breaking ties. The best few (the best of each shape among them), each at every logger rate the
chamber file allows, are then tried by simulation and the blind diagnosis (:mod:`~twin.plan.trials`):
the one it reads best is the plan. Two obvious tests of the same budget are scored beside it: the
scenario's own protocol repeated, and its protocol with a second ramp rate alone.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from dataclasses import dataclass, replace

import yaml

from twin.errors import TwinError
from twin.model.scenario import LoadedScenario
from twin.plan.check import check_plan, job_client, run_jobs
from twin.plan.hypotheses import NULLS, Hypothesis, default_hypothesis, hypotheses_from_finding
from twin.plan.programs import ChamberLimits, PlannedTest, candidate_programs, program_hours
from twin.plan.result import PairSeparation, PlanResult, ProgramStep, RivalRecord, TestDesign
from twin.plan.scenarios import base_scenario, with_hypothesis, with_program
from twin.plan.separation import DETECT_BIC, Separation, separation
from twin.plan.trials import TrialScore, race, race_jobs


@dataclass(frozen=True)
class PlanSettings:
    """How hard ``twin plan`` looks and checks.

    Attributes
    ----------
    budget_h : float
        Chamber hours the test may take, every run included [h].
    limits : ChamberLimits
    rivals : tuple of str
        Effects to separate instead of the finding's (``none`` allowed).
    draws : int
        Parameter draws per rival in the expected separation.
    finalists : int
        Best candidates tried by simulation, each at every logger rate of ``limits`` (0: none; the
        best by the expected separation is the plan).
    trial_seeds : int
        Simulated tests per rival the winning finalist gets (the race starts each on 3).
    check_seeds : int
        Simulated tests per rival in the check (0: no check).
    check_baseline : bool
        Check the scenario's protocol repeated as well.
    seed : int
    workers : int
    executor : str
        ``local`` or ``dask``.
    scheduler : str, optional
    """

    budget_h: float = 12.0
    limits: ChamberLimits = ChamberLimits()
    rivals: tuple[str, ...] = ()
    draws: int = 3
    finalists: int = 6
    trial_seeds: int = 24
    check_seeds: int = 20
    check_baseline: bool = False
    seed: int = 0
    workers: int = 1
    executor: str = "local"
    scheduler: str | None = None


def program_table(start_c: float, steps: list[dict]) -> tuple[ProgramStep, ...]:
    """The lab's table of one run's steps (holds and ramps).

    Parameters
    ----------
    start_c : float
        Set-point at the start [°C].
    steps : list of dict

    Returns
    -------
    tuple of ProgramStep
    """
    rows, temp, end = [], start_c, 0.0
    for k, s in enumerate(steps, 1):
        hours = program_hours(temp, [s])
        end += hours
        target = float(temp if s.get("target_c") is None else s["target_c"])
        rows.append(ProgramStep(k, s["type"], temp, target, s.get("ramp_c_per_h"), hours, end))
        temp = target
    return tuple(rows)


def _design(name: str, description: str, hours: float, test_plan: dict, orientation: str, sep: Separation,
            trial: TrialScore | None = None) -> TestDesign:
    truth, rival, worst = sep.worst_pair()
    pairs = tuple(PairSeparation(a, b, float(sep.expected_delta_bic[i, j]))
                  for i, a in enumerate(sep.effects) for j, b in enumerate(sep.effects) if i != j and a not in NULLS)
    # tried by simulation, the rate predicted is the trials' (the normal approximation misjudges the rule)
    predicted = sep.predicted_rate if trial is None else trial.expected_rate()
    return TestDesign(name, description, round(hours, 3), int(test_plan.get("runs", 1)), orientation,
                      len(test_plan.get("power_on_s", [0.0])), (truth, rival), worst, pairs, predicted,
                      float(test_plan.get("logger_rate_hz", 1.0)), None if trial is None else trial.rate(),
                      0 if trial is None else trial.seeds)


def _orientation(test_plan: dict) -> str:
    if test_plan.get("tumble"):
        return "tumble"
    return "flip" if len(set(test_plan.get("run_applied_g") or [1.0])) > 1 else "fixed"


def protocol_repeated(loaded: LoadedScenario, budget_h: float) -> tuple[dict, dict, float] | None:
    """The scenario's own program and test plan, its cycles repeated to fill the budget.

    Parameters
    ----------
    loaded : LoadedScenario
    budget_h : float

    Returns
    -------
    tuple or None
        (program, test_plan, chamber hours); None when one cycle does not fit the budget.
    """
    scn = loaded.scenario
    program = scn.program.model_dump(mode="json", exclude_none=True)
    plan = scn.test_plan.model_dump(mode="json", exclude_none=True, exclude_defaults=True)
    runs = scn.test_plan.runs
    cycle_h = loaded.program.duration_s / scn.program.cycles / 3600.0
    cycles = int(budget_h // (cycle_h * runs))
    if cycles < 1:
        return None
    program["cycles"] = cycles
    plan["logger_rate_hz"] = float(scn.test_plan.logger_rate_hz)  # stated even where it is the default
    return program, plan, cycles * cycle_h * runs


def second_rate_alone(loaded: LoadedScenario, budget_h: float, limits: ChamberLimits) -> PlannedTest | None:
    """The scenario's range and first dwell, cycled at its first ramp rate and a second one (up to 4×
    faster, or 4× slower where the chamber cannot double it), fixed orientation, one power-on: "just
    add a second ramp rate".

    Parameters
    ----------
    loaded : LoadedScenario
    budget_h : float
    limits : ChamberLimits

    Returns
    -------
    PlannedTest or None
        None when two cycles do not fit the budget or the chamber runs one rate only.
    """
    steps = loaded.scenario.program.steps
    temps = [loaded.scenario.program.start_c] + [s.target_c for s in steps if getattr(s, "target_c", None) is not None]
    rates = [abs(s.ramp_c_per_h) for s in steps if s.type == "ramp"] or [60.0]
    dwell = next((s.dwell_s for s in steps if s.type == "hold"), 1800.0)
    r0 = min(max(rates[0], limits.min_ramp_c_per_h), limits.max_ramp_c_per_h)
    fast = min(4 * r0, limits.max_ramp_c_per_h)  # a second rate at least twice the first, else a slower one
    r1 = fast if fast >= 2 * r0 else max(r0 / 4, limits.min_ramp_c_per_h)
    if r1 == r0:  # the chamber runs one rate only
        return None
    lo, hi = max(min(temps), limits.min_c), min(max(temps), limits.max_c)
    best = None
    for cycles in range(2, 13):
        p = PlannedTest(lo, hi, min(max(temps[0], lo), hi), (r0, r1), dwell, cycles, "fixed", 1, limits.logger_rate_hz)
        if p.hours() > budget_h:
            break
        best = p
    return best


def rivals_of(finding: dict | None, rivals: tuple[str, ...]) -> list[Hypothesis]:
    """The hypotheses to separate: the finding's open rivals, or ``rivals``.

    Parameters
    ----------
    finding : dict or None
    rivals : tuple of str

    Returns
    -------
    list of Hypothesis

    Raises
    ------
    TwinError
        Fewer than two, or an unknown effect.
    """
    if finding is not None:
        return hypotheses_from_finding(finding, list(rivals) or None)
    if len(set(rivals)) < 2:
        raise TwinError("without a finding, name at least two rivals with --rivals A,B")
    return [default_hypothesis(r) for r in dict.fromkeys(rivals)]


def _score(job: tuple) -> Separation:
    """:func:`separation` of one job (scenario, hypotheses, draws, seed)."""
    return separation(*job)


def plan_test(loaded: LoadedScenario, finding: dict | None, settings: PlanSettings,
              progress: Callable[[int, int], None] | None = None) -> tuple[PlanResult, dict]:
    """Design the test; see the module docstring.

    Parameters
    ----------
    loaded : LoadedScenario
        The twin's scenario (sensor, model; its program is the protocol the baselines repeat).
    finding : dict or None
        A ``twin compare --json`` result of one axis (None: ``settings.rivals`` at their defaults).
    settings : PlanSettings
    progress : callable, optional
        ``progress(done, total)`` over candidates, then over the check's simulated tests.

    Returns
    -------
    result : PlanResult
    scenario : dict
        The plan's scenario (the twin plus the leading rival as device).

    Raises
    ------
    TwinError
        Too few rivals, a budget no candidate fits, an unknown effect.
    """
    with job_client(settings.executor, settings.scheduler, settings.workers) as client:  # one cluster, every phase
        return _plan_test(loaded, finding, settings, progress, client)


def _plan_test(loaded: LoadedScenario, finding: dict | None, s: PlanSettings,
               progress: Callable[[int, int], None] | None, client) -> tuple[PlanResult, dict]:
    """:func:`plan_test` on a Dask ``client`` (None: local processes)."""
    start = time.perf_counter()
    hyps = rivals_of(finding, s.rivals)
    base = base_scenario(loaded, finding)
    programs = candidate_programs(s.limits, s.budget_h, start_c=loaded.scenario.program.start_c)
    if not programs:
        raise TwinError(f"--budget-h {s.budget_h:g}: no test within the chamber's limits fits; one cycle "
                        f"{s.limits.min_c:g} → {s.limits.max_c:g} °C needs more hours")
    obvious = obvious_tests(loaded, s)
    tests = [(p.program(), p.test_plan()) for p in programs] + [(o[2], o[3]) for o in obvious]
    check_base = s.check_baseline and bool(obvious) and obvious[0][0] == "protocol_repeated"
    rates = s.limits.logger_rates(loaded.sensor().odr_hz)
    n_trials = min(s.finalists, len(programs)) * len(rates) * (s.trial_seeds > 0)
    total = (len(tests) + (race_jobs(n_trials, len(hyps), s.trial_seeds) + 1 if n_trials else 0)
             + s.check_seeds * len(hyps) * (1 + check_base))
    done = [0]

    def run(fn, jobs):  # every phase on one progress bar
        tick = None if progress is None else (lambda k, n: progress(done[0] + k, total))
        out = run_jobs(fn, jobs, s.workers, client, tick)
        done[0] += len(jobs)
        return out

    seps = run(_score, [(with_program(base, *t), hyps, s.draws, s.seed) for t in tests])
    unseen = _invisible(hyps, seps[:len(programs)])
    hyps = [h for h in hyps if h.effect not in unseen]
    seps = [sep.without(unseen) for sep in seps]
    # the least predicted rate first (the decision rule's held-out gain can bind where ΔBIC does not),
    # then the T-optimal criterion, then the shorter test
    key = lambda i: (round(seps[i].least_rate, 3), seps[i].score, -programs[i].hours())  # noqa: E731
    k = max(range(len(programs)), key=key)
    best, best_sep, trial = programs[k], seps[k], None
    if n_trials:
        # the expected separation misjudges the rule near its thresholds: the finalists race through
        # the blind diagnosis itself, each at every logger rate
        designs = [replace(programs[i], logger_rate_hz=r) for i in _finalists(programs, key, s.finalists) for r in rates]
        w, scores = race([with_program(base, d.program(), d.test_plan()) for d in designs], hyps, s.trial_seeds, run)
        best, trial = designs[w], scores[w]
        if best != programs[k]:  # scored at the chamber file's logger rate only, or not the best
            best_sep = run(_score, [(with_program(base, best.program(), best.test_plan()), hyps, s.draws, s.seed)])[0]
    design = _design("plan", best.label(), best.hours(), best.test_plan(), best.orientation, best_sep, trial)
    baselines = tuple(_design(n, d, h, tp, _orientation(tp), seps[len(programs) + j])
                      for j, (n, d, _, tp, h) in enumerate(obvious))
    scenario = with_program(base, best.program(), best.test_plan())
    check = base_check = None
    designed = time.perf_counter()
    if s.check_seeds > 0:
        check = check_plan(scenario, hyps, s.check_seeds, design.predicted_rate, runner=run)
        if check_base:
            base_check = check_plan(with_program(base, *tests[len(programs)]), hyps, s.check_seeds,
                                    seps[len(programs)].predicted_rate, runner=run)
    result = PlanResult(
        rivals=tuple(RivalRecord(h.effect, h.source, h.values) for h in hyps), set_aside=tuple(sorted(unseen)),
        budget_h=s.budget_h, candidates_evaluated=len(programs), plan=design,
        program=program_table(best.start_c, best.steps()), amplitude_ci95=best_sep.amplitude_ci95,
        baselines=baselines, why=_why(design, baselines), check=check, baseline_check=base_check,
        design_wall_s=designed - start, check_wall_s=time.perf_counter() - designed)
    leading = next((h for h in hyps if h.effect not in NULLS), hyps[0])
    return result, with_hypothesis(scenario, leading)


def _finalists(programs: list[PlannedTest], key: Callable[[int], tuple], n: int) -> list[int]:
    """The ``n`` best candidates by ``key``, the best of each shape among them (a loop or a soak
    program excites what the criterion ranks low near the thresholds: a weak memory of the path, a
    warm-up against aging)."""
    order = sorted(range(len(programs)), key=key, reverse=True)
    firsts: dict[str, int] = {}
    for i in order:
        firsts.setdefault(programs[i].shape, i)
    return list(dict.fromkeys(list(firsts.values())[:n] + order))[:n]


def obvious_tests(loaded: LoadedScenario, s: PlanSettings) -> list[tuple[str, str, dict, dict, float]]:
    """The tests a user would run without a plan, within the budget: the scenario's protocol
    repeated, and a second ramp rate alone.

    Parameters
    ----------
    loaded : LoadedScenario
    s : PlanSettings

    Returns
    -------
    list of tuple
        (name, description, program, test plan, chamber hours) of each that fits the budget.
    """
    out = []
    repeated = protocol_repeated(loaded, s.budget_h)
    if repeated is not None:
        prog, plan, hours = repeated
        out.append(("protocol_repeated", f"the scenario's protocol, {prog['cycles']} cycle(s)", prog, plan, hours))
    second = second_rate_alone(loaded, s.budget_h, s.limits)
    if second is not None:
        out.append(("second_rate_alone", second.label(), second.program(), second.test_plan(), second.hours()))
    return out


def _invisible(hyps: list[Hypothesis], seps: list[Separation]) -> set[str]:
    """Rivals no candidate makes visible: their expected screening ΔBIC against the twin alone is
    under the decision rule's on every test (absorbed by the twin, e.g. a package stress against the
    twin's own bias tempco). No chamber program separates them, so they are set aside.

    Raises
    ------
    TwinError
        Fewer than two rivals would remain.
    """
    unseen = {h.effect for h in hyps if h.effect not in NULLS and max(sep.own_evidence[h.effect] for sep in seps) < DETECT_BIC}
    if len(hyps) - len(unseen) < 2:
        raise TwinError("no test within the budget and the chamber's limits makes "
                        f"{', '.join(sorted(unseen))} visible against the twin: a chamber program cannot "
                        "separate it (see the finding's remedy)")
    return unseen


def _why(plan: TestDesign, baselines: tuple[TestDesign, ...]) -> str:
    """One sentence per baseline: its criterion against the plan's."""
    parts = [f"The plan's least separated pair, {plan.worst_pair[0]} against {plan.worst_pair[1]}, is expected at "
             f"ΔBIC {plan.worst_expected_delta_bic:.3g} in {plan.chamber_hours:.3g} h"]
    for b in baselines:
        ratio = plan.worst_expected_delta_bic / b.worst_expected_delta_bic if b.worst_expected_delta_bic > 0 else math.inf
        parts.append(f"{b.name.replace('_', ' ')} ({b.chamber_hours:.3g} h) reaches {b.worst_expected_delta_bic:.3g} "
                     f"for {b.worst_pair[0]} against {b.worst_pair[1]}"
                     + (f" ({ratio:.3g}× less)" if math.isfinite(ratio) and ratio > 1 else ""))
    return "; ".join(parts) + "."


def scenario_yaml(result: PlanResult, scenario: dict) -> str:
    """The plan's scenario file: the lab's program table and the predicted separation as comments,
    then the scenario ``twin run`` reads.

    Parameters
    ----------
    result : PlanResult
    scenario : dict

    Returns
    -------
    str
    """
    p = result.plan
    lines = [f"# twin plan: {p.description}",
             f"# chamber time {p.chamber_hours:.3g} h ({p.runs} run{'s' * (p.runs > 1)}); rivals: "
             + ", ".join(r.effect for r in result.rivals),
             *([f"# set aside (no test in the budget makes them visible): {', '.join(result.set_aside)}"]
               if result.set_aside else []),
             "# program of each run:",
             "#   step  kind   from °C   to °C   rate °C/h   hours   ends at h"]
    for r in result.program:
        rate = "" if r.rate_c_per_h is None else f"{r.rate_c_per_h:g}"
        lines.append(f"#   {r.step:>4}  {r.kind:<5}  {r.from_c:>7g}  {r.to_c:>6g}  {rate:>9}  {r.duration_h:>6.2f}  "
                     f"{r.end_h:>9.2f}")
    lines.append("# expected ΔBIC of the true rival over the other's best fit:")
    lines += [f"#   {q.truth} over {q.rival}: {q.expected_delta_bic:.3g}" for q in p.pairs]
    lines.append(f"# {result.why}")
    lines.append("# device.effects: the twin as calibrated plus the leading rival; twin.effects: the model diagnosed")
    return "\n".join(lines) + "\n" + yaml.safe_dump(scenario, sort_keys=False)
