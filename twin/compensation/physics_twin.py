"""The calibrated physics twin as a compensator: the benchmark's reference.

It is not a registry entry: it is calibrated on the training measurement with the scenario's
twin effects (plus a thermal lag), not fitted to a feature matrix.
"""

from __future__ import annotations

import numpy as np

from twin.estimation.fit import fit_twin
from twin.estimation.problem import DiagnosisConfig, Problem
from twin.effects import Composition, get_effect


def twin_compensation(loaded, train, test) -> np.ndarray:
    """The calibrated physics twin (its effects + a thermal lag) predicting the test drift [g].

    Parameters
    ----------
    loaded : LoadedScenario
        The scenario: its ``twin.effects`` and geometry.
    train, test : Measurement
        The training samples (the twin is calibrated on them) and the test samples.

    Returns
    -------
    ndarray
        Per test sample, the drift effects' output plus the calibrated offset of the first
        training run [g].
    """
    names = list(dict.fromkeys(loaded.scenario.twin.effects + ["thermal_lag"]))
    ctx = {"geometry": loaded.geometry()}
    comp = Composition([get_effect(n)(ctx) for n in names])
    cfg = DiagnosisConfig()
    cal = fit_twin(Problem(train, cfg), comp)
    p_test = Problem(test, cfg)
    inputs = cal.composition.with_die_temperature(p_test.inputs)
    drift = sum((np.broadcast_to(e.contribution(inputs).output_g(p_test.applied), (p_test.n,))
                 for e in cal.composition.drift_effects), np.zeros(p_test.n))
    offset = float(cal.beta[Problem(train, cfg).nuisance_names.index("offset_run0")])
    return drift + offset
