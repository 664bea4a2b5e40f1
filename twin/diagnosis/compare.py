"""The blind compare of a scenario's twin with one single-axis measurement."""

from __future__ import annotations

import numpy as np

from sim.sensor import logger_white_sigma_g
from twin.diagnosis.sample_rate import decimated_problem, restore_sample_rate
from twin.diagnosis.diagnose import Diagnosis, diagnose
from twin.estimation.problem import DiagnosisConfig
from twin.effects import Composition, get_effect
from twin.errors import ModelError, TwinError
from twin.measurement import Measurement
from twin.model.scenario import LoadedScenario


def sensor_noise_floor_g(loaded: LoadedScenario, rate_hz: float) -> float | None:
    """Per-sample noise σ of the scenario's sensor at the measurement's rate [g]: white,
    quantisation (LSB/√12) and bias instability in quadrature.

    Parameters
    ----------
    loaded : LoadedScenario
    rate_hz : float
        Sample rate of the measurement [Hz].

    Returns
    -------
    float or None
        None when the sensor model has no noise figure at that rate.
    """
    sensor = loaded.sensor()
    tp = loaded.scenario.test_plan
    try:
        white = logger_white_sigma_g(sensor, min(rate_hz, sensor.odr_hz), tp.logger_mode)
    except ValueError:
        return None
    lsb = sensor.sensitivity_mg_per_digit * 1e-3
    return float(np.sqrt(white**2 + lsb**2 / 12 + (sensor.bias_instability_mg * 1e-3) ** 2))


def twin_model(loaded: LoadedScenario, with_effects: list[str]) -> Composition:
    """The scenario's ``twin.effects`` plus ``--with-effect`` names (never ``device.effects``).

    Parameters
    ----------
    loaded : LoadedScenario
    with_effects : list of str
        Registered effect names to add.

    Returns
    -------
    Composition
    """
    for name in with_effects:
        try:
            get_effect(name)
        except ModelError as exc:
            raise TwinError(f"--with-effect: {exc}") from None
    return loaded.twin_composition().added(with_effects, {"geometry": loaded.geometry()})


def diagnose_measurement(loaded: LoadedScenario, m: Measurement, with_effects: list[str],
                         average_s: float = 10.0) -> Diagnosis:
    """The scenario's twin (plus ``with_effects``) diagnosed blind against one single-axis measurement.

    Parameters
    ----------
    loaded : LoadedScenario
        Its ``twin``, ``device.sensor`` and ``test_plan`` are read; never ``device.effects``.
    m : Measurement
    with_effects : list of str
        Registered effects added to the twin.
    average_s : float
        Screening block length [s].

    Returns
    -------
    Diagnosis
        A :class:`~twin.diagnosis.sample_rate.SampleRateDiagnosis` when a fast or long log was diagnosed on means.
    """
    cfg = DiagnosisConfig(average_s=average_s)
    rate = m.sample_rate_hz
    # a fast or long log is diagnosed on means; per-sample figures come from the full rate
    problem, blocks, k = decimated_problem(m, rate, cfg)
    d = diagnose(problem, twin_model(loaded, with_effects), sensor_noise_floor_g(loaded, rate))
    return d if blocks is None else restore_sample_rate(d, m, blocks, k)
