"""``twin plan``: design the chamber test that separates rival effects a finding left open
(docs/plan.md).

:func:`~twin.plan.design.plan_test` reads the rivals (:mod:`~twin.plan.hypotheses`), scores the
candidate tests (:mod:`~twin.plan.programs`) by their expected separation
(:mod:`~twin.plan.separation`), and checks the best by simulation (:mod:`~twin.plan.check`).
"""

from twin.plan.design import PlanSettings, plan_test, scenario_yaml
from twin.plan.programs import ChamberLimits, PlannedTest
from twin.plan.result import PlanResult

__all__ = ["ChamberLimits", "PlanResult", "PlanSettings", "PlannedTest", "plan_test", "scenario_yaml"]
