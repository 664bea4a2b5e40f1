"""DOE responses of the finite-element package model (``package_fem``): TCOff, TCSo and die bow.

They read the device's ``package_fem`` effect (its parameters are the study's factors, e.g.
``device.effects.package_fem.mould_cte_ppm_per_k``) and evaluate the FE model directly: one
cached solve per design, no simulation needed for the number itself. Load with
``plugins: [twin.studies.package_response]`` in the study file.
"""

from __future__ import annotations

from twin.model.results import PackagePrediction
from twin.studies.responses import ResponseError, RunContext, register_response


def _prediction(run: RunContext) -> PackagePrediction:
    from twin.model.package import package_prediction

    effects = [e for e in run.loaded.device_composition().effects if e.name == "package_fem"]
    if not effects:
        raise ResponseError("the package responses need device.effects.package_fem in the scenario")
    return package_prediction(effects[0], run.loaded.part)  # the FE solve is cached per design


@register_response("package_tcoff_mg_per_c", description="TCOff of the FE package model: least-squares slope of "
                   "the zero-g offset over -40..85 °C", unit="mg/°C")
def package_tcoff_mg_per_c(run: RunContext) -> float:
    """TCOff of the FE package model over -40..85 °C [mg/°C].

    Parameters
    ----------
    run : RunContext
        The run (its ``device.effects.package_fem``).

    Returns
    -------
    float
        Least-squares slope of the zero-g offset [mg/°C].
    """
    return _prediction(run).tcoff_mg_per_c


@register_response("package_tcso_ppm_per_c", description="package-induced TCSo of the FE model over -40..85 °C",
                   unit="ppm/°C")
def package_tcso_ppm_per_c(run: RunContext) -> float:
    """Package-induced TCSo of the FE model over -40..85 °C [ppm/°C].

    Parameters
    ----------
    run : RunContext
        The run (its ``device.effects.package_fem``).

    Returns
    -------
    float
        TCSo [ppm/°C].
    """
    return _prediction(run).tcso_ppm_per_c


@register_response("package_die_bow_um", description="die bow (peak-to-valley after the best line) at -40 °C",
                   unit="µm")
def package_die_bow_um(run: RunContext) -> float:
    """Die bow of the FE package model at -40 °C [µm].

    Parameters
    ----------
    run : RunContext
        The run (its ``device.effects.package_fem``).

    Returns
    -------
    float
        Peak-to-valley after the best line [µm].
    """
    return _prediction(run).warpage[0].die_bow_um
