"""A diagnosis into the typed compare result, built once: parameters, candidates, the finding.

:func:`compare_measurement` is the blind compare of one single-axis measurement, discovery and
the discovered plugin included; :func:`imu_result` gathers one IMU's axes.
"""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np

from twin.diagnosis.axes import AxisDiagnoses
from twin.diagnosis.compare import diagnose_measurement
from twin.diagnosis.diagnose import Diagnosis
from twin.discovery.search import Discovery, discover
from twin.estimation.noise import white_noise_sigma_from_differences
from twin.finding.discovery import write_plugin
from twin.finding.language import finding_text, joint_finding
from twin.finding.lookalikes import FEATURE_FAMILY, attribution, lookalikes
from twin.finding.result import (
    Amplitude,
    Candidate,
    CompareResult,
    DiscoveredTerm,
    DiscoverySummary,
    Feature,
    ImuCompareResult,
    LookAlike,
    MeasurementInfo,
    NoiseModel,
    NuisanceEstimate,
    ParameterEstimate,
)
from twin.measurement import Measurement
from twin.model.scenario import LoadedScenario


def _parameters(d: Diagnosis) -> dict[str, dict[str, ParameterEstimate]]:
    """Every parameter of the calibrated twin with its 95 % interval and flags."""
    cal = d.fit
    nn = d.problem.nuisance.shape[1]
    out: dict[str, dict[str, ParameterEstimate]] = {}
    for e in cal.composition.effects:
        entry = {}
        for p in e.parameters:
            key = (e.name, p.name)
            v = e.values[p.name]
            ci = None
            if key in cal.names:
                half = 1.96 * float(np.sqrt(max(cal.cov[nn + cal.names.index(key), nn + cal.names.index(key)], 0.0)))
                ci = (v - half, v + half)
            if key in cal.nonlinear_ci:
                ci = tuple(cal.nonlinear_ci[key])
            partner = next((pt for k, pt in cal.pinned if k == key), None)
            lo, hi = p.bounds
            fitted = key in cal.names or key in cal.nonlinear_ci
            on_bound = fitted and (np.isclose(v, lo, rtol=1e-6, atol=1e-12) or np.isclose(v, hi, rtol=1e-6, atol=1e-12))
            entry[p.name] = ParameterEstimate(
                value=v, unit=p.unit, role=p.role, free=p.free, on_bound=bool(on_bound),
                outside_physical_range=bool(not lo <= v <= hi), ci95=ci,
                pinned=None if partner is None else f"held at its default: aliased with {partner} in this data")
        out[e.name] = entry
    return out


def _candidate(c) -> Candidate:
    return Candidate(c.effect, c.family, c.significant, c.rms_residual_g, c.explained_fraction, c.delta_bic,
                     c.p_adjusted, c.heldout_gain, c.novelty, dict(c.grid_values),
                     {k: Amplitude(v, w) for k, (v, w) in c.amplitudes.items()},
                     dict(c.refined_values) if c.refined_values else None)


def _look_alikes(family: str, effect: str | None) -> tuple[LookAlike, ...]:
    return tuple(LookAlike(m.name, m.effect, m.in_library, m.reason, m.test) for m in lookalikes(family, effect))


def _discovery(disc: Discovery, plugin_path: str | None) -> DiscoverySummary:
    terms = tuple(DiscoveredTerm(Feature(t.spec.kind, dict(t.spec.params), t.spec.label, t.spec.unit), t.coef_mg,
                                 t.ci95_mg, t.delta_bic, t.p_adjusted) for t in disc.terms)
    summary = DiscoverySummary(disc.proposed, disc.reason, disc.equation(), terms, disc.features_tried,
                               disc.heldout_gain, disc.delta_bic, disc.rms_before_g, disc.rms_predicted_g,
                               tuple(disc.beaten), disc.preferred_library, disc.average_s)
    if not disc.proposed:
        return summary
    family = FEATURE_FAMILY.get(disc.terms[0].spec.kind, "discovered")
    return replace(summary, attribution="signature", lookalikes=_look_alikes(family, None), plugin=plugin_path)


def compare_result(d: Diagnosis, discovery: Discovery | None = None, plugin_path: str | None = None) -> CompareResult:
    """The typed result of a diagnosis; the finding is worded here, once.

    Parameters
    ----------
    d : Diagnosis
    discovery : Discovery, optional
        What ``--discover`` found on ``d``.
    plugin_path : str, optional
        Where the discovered term was written as an effect.

    Returns
    -------
    CompareResult
    """
    cal, p = d.fit, d.problem
    m = p.m
    top = d.selected[0] if d.selected else None
    return CompareResult(
        rms_residual_g=d.rms_residual_g, noise_floor_g=d.noise_floor_g, noise_floor_model_g=d.noise_floor_model_g,
        heldout_rms_g=d.heldout_rms_g, effects=tuple(e.name for e in cal.composition.effects),
        parameters=_parameters(d),
        nuisance={name: NuisanceEstimate(float(cal.beta[j]), "g" if name.startswith("offset") else "1")
                  for j, name in enumerate(p.nuisance_names)},
        missing_effect_detected=bool(d.selected), selected=tuple(c.effect for c in d.selected),
        withheld=tuple(d.withheld), rivals=tuple(d.rivals), family_choices=tuple(d.family_choices),
        confidence=d.confidence, candidates=tuple(_candidate(c) for c in d.candidates), aliases=tuple(d.aliases),
        untestable=tuple(d.untestable), finding=finding_text(d, discovery, plugin_path),
        noise_model=NoiseModel(cal.ar.order, p.config.average_s), residual=d.segments, samples=d.samples,
        sample_rate_hz=d.sample_rate_hz, runs=m.runs,
        measurement=MeasurementInfo(tuple(m.sources), m.bad_rows_skipped, tuple(m.notes), m.applied_known,
                                    d.means_of),
        rms_after_selected_g=d.rms_after_selected_g, structure=tuple(d.structure),
        attribution=None if top is None else attribution(top.family, top.effect),
        lookalikes=None if top is None else _look_alikes(top.family, top.effect),
        discovery=None if discovery is None else _discovery(discovery, plugin_path))


def run_discovery(d: Diagnosis, plugin_path: Path | None, sources: list[str]) -> tuple[Discovery, str | None]:
    """Search for a term outside the library; a proposed one is written as a plugin to ``plugin_path``.

    Parameters
    ----------
    d : Diagnosis
    plugin_path : Path, optional
        Where to write the plugin (not written when None).
    sources : list of str
        Measurement files, quoted in the plugin's docstring.

    Returns
    -------
    discovery : Discovery
    written : str or None
        The plugin's path, when one was written.
    """
    # the floor on the problem's own rows: a fast log is diagnosed on k-sample means (estimation.decimate),
    # and d.noise_floor_g is then the full-rate floor, not comparable with residuals on the means
    floor = white_noise_sigma_from_differences(d.fit.residual, d.problem.m.run_index)
    disc = discover(d.problem, d.fit, d.selected, d.candidates, floor)
    if not disc.proposed or plugin_path is None:
        return disc, None
    write_plugin(Path(plugin_path), disc, sources, [c.effect for c in d.selected])
    return disc, str(plugin_path)


def finished_result(d: Diagnosis, discover: bool, plugin_path: Path | None, sources: list[str]) -> CompareResult:
    """The result of a diagnosis, after the discovery when asked (and its plugin written).

    Parameters
    ----------
    d : Diagnosis
    discover : bool
    plugin_path : Path, optional
        Where a proposed term is written.
    sources : list of str
        Measurement files, quoted in the plugin.

    Returns
    -------
    CompareResult
    """
    disc, written = run_discovery(d, plugin_path, sources) if discover else (None, None)
    return compare_result(d, disc, written)


def compare_measurement(loaded: LoadedScenario, m: Measurement, with_effects: list[str], average_s: float = 10.0,
                        discover: bool = False, plugin_path: Path | None = None
                        ) -> tuple[Diagnosis, CompareResult]:
    """The blind compare of the scenario's twin with one single-axis measurement.

    Parameters
    ----------
    loaded : LoadedScenario
    m : Measurement
    with_effects : list of str
        Registered effects added to the twin.
    average_s : float
        Screening block length [s].
    discover : bool
        Also search a dictionary of terms for one outside the library.
    plugin_path : Path, optional
        With ``discover``: where to write a proposed term as an effect plugin.

    Returns
    -------
    diagnosis : Diagnosis
        For the report's plots and the ledger.
    result : CompareResult
    """
    d = diagnose_measurement(loaded, m, with_effects, average_s)
    return d, finished_result(d, discover, plugin_path, list(m.sources))


def imu_result(axd: AxisDiagnoses, results: dict[str, CompareResult]) -> ImuCompareResult:
    """One IMU's axes gathered, with the joint finding.

    Parameters
    ----------
    axd : AxisDiagnoses
        The IMU's per-axis diagnoses and the rows they used.
    results : dict of str to CompareResult
        Each axis' result.

    Returns
    -------
    ImuCompareResult
    """
    return ImuCompareResult(
        instance=axd.instance, device_id=axd.device_id, orientation_applied_g=dict(axd.applied_g),
        orientation_per_stretch={a: tuple(s for r in rows for s in r.stretches) for a, rows in axd.rows.items()},
        log_quality=tuple(q.record() for q in axd.qualities), finding=joint_finding(results), axes=dict(results))
