"""Comb thermal drift summarised per reading (``twin comb``)."""

from __future__ import annotations

import numpy as np

from twin.reporting.results import CombReading, CombReport
from sim.microstructure import READINGS, CombGeometry, capacitances_f, check_gaps, displacement_m, drift_g, linear_slope_mg_per_c

MEANING = {
    "P": "paper literal: alpha(T) used as a strain",
    "S": "eq. (15) with strain: fingers grow, anchors fixed",
    "H": "homogeneous dilation, spring fixed",
    "HE": "homogeneous dilation, spring ~ E(T)(1+eps)",
}


def comb_report(geometry: CombGeometry, acceleration_g: float = 1.0, t_low_c: float = -20.0, t_high_c: float = 50.0) -> CombReport:
    """Capacitances at 25 °C and, per reading, the drift slope and ends over the range.

    Parameters
    ----------
    geometry : CombGeometry
        The comb's geometry.
    acceleration_g : float
        Applied acceleration [g].
    t_low_c, t_high_c : float
        Temperature range [°C].

    Returns
    -------
    CombReport
        ``C1_fF``, ``C2_fF`` [fF], ``signal_fF_per_g`` [fF/g], ``du_1g_nm`` (displacement at 1 g) [nm],
        ``acceleration_g`` [g], ``range_c`` [°C] and ``readings``: per reading (:data:`MEANING`) its
        slope [mg/°C], curvature [mg/°C²], drift at both ends and largest offset [mg].
    """
    check_gaps(geometry, max(abs(acceleration_g), 1e-12), t_low_c=t_low_c, t_high_c=t_high_c)
    c = capacitances_f(geometry, 25.0, 1.0, "S")
    temps = np.linspace(t_low_c, t_high_c, 141)
    rows = []
    for reading in READINGS:
        d = drift_g(geometry, temps, acceleration_g, reading)
        slope, curvature = linear_slope_mg_per_c(temps, d["total"])
        rows.append(CombReading(reading=reading, meaning=MEANING[reading], slope_mg_per_c=slope,
                                curvature_mg_per_c2=curvature, drift_low_mg=float(d["total"][0] * 1e3),
                                drift_high_mg=float(d["total"][-1] * 1e3),
                                max_offset_mg=float(np.max(np.abs(d["offset"])) * 1e3)))
    return CombReport(C1_fF=float(c["C1"] * 1e15), C2_fF=float(capacitances_f(geometry, 25.0, 0.0, "S")["C2"] * 1e15),
                      signal_fF_per_g=float(c["differential"] * 1e15),
                      du_1g_nm=float(displacement_m(1.0, geometry.resonance_hz) * 1e9),
                      acceleration_g=acceleration_g, range_c=(t_low_c, t_high_c), readings=rows)
