"""Comb capacitance and thermal drift against docs/physics.md §2.5 (readings P, S, H, HE)."""

import numpy as np
import pytest

from conftest import run_cli
from sim.microstructure import (
    CombGeometry,
    GeometryError,
    capacitances_f,
    check_gaps,
    displacement_m,
    drift_g,
    linear_slope_mg_per_c,
)

G = CombGeometry()
T = np.linspace(-20, 50, 141)


def slope(reading, a=1.0):
    return linear_slope_mg_per_c(T, drift_g(G, T, a, reading)["total"])[0]


def test_cell_capacitances_and_signal():
    # docs/physics.md §2.5: C2 = 6.64 fF, C1 = 0.080 fF, 0.183 fF/g, du(1 g) = 27.6 nm at 3 kHz (3 s.f.)
    c0 = capacitances_f(G, 25.0, 0.0, "S")
    assert c0["C2"] * 1e15 == pytest.approx(6.64, rel=2e-3)
    assert c0["C1"] * 1e15 == pytest.approx(0.080, rel=5e-3)
    assert capacitances_f(G, 25.0, 1.0, "S")["differential"] * 1e15 == pytest.approx(0.183, rel=3e-3)
    assert displacement_m(1.0, 3000.0) * 1e9 == pytest.approx(27.6, rel=2e-3)
    assert G.k1_um == 227.5 and G.k2_um == 3.0 and G.k3_um == 117.5


def test_reading_S_gives_0_015_mg_per_c():
    # notes: 0.015 mg/degC at 1 g; the acceptance allows 20 % (the notes' figure is rounded to 2 s.f.
    # and depends on the fitted range)
    assert slope("S") == pytest.approx(0.015, rel=0.2)
    d = drift_g(G, np.array([-20.0, 50.0]), 1.0, "S")["total"] * 1e3
    assert d == pytest.approx([-0.66, 0.42], abs=0.01)


def test_reading_H_cancels_with_fixed_spring():
    # Homogeneous dilation with the spring held fixed: b j / u is invariant, only du^2/u^2 terms remain.
    assert abs(slope("H")) < 0.005
    assert np.max(np.abs(drift_g(G, T, 1.0, "H")["total"])) < 1e-7  # < 0.1 ug over -20..50 degC


def test_reading_HE_gives_0_064_mg_per_c():
    # notes: 0.064 mg/degC = -TCE - alpha; acceptance 15 %
    assert slope("HE") == pytest.approx(0.064, rel=0.15)
    d = drift_g(G, np.array([-20.0, 50.0]), 1.0, "HE")["total"] * 1e3
    assert d == pytest.approx([-2.80, 1.67], abs=0.02)


def test_paper_literal_reading_is_negligible():
    d = drift_g(G, np.array([-20.0, 50.0]), 1.0, "P")["total"] * 1e3
    assert d == pytest.approx([-0.0027, 0.0012], abs=2e-4)


@pytest.mark.parametrize("reading", ["P", "S", "H", "HE"])
def test_symmetric_comb_has_no_offset_and_drift_scales_with_input(reading):
    d0 = drift_g(G, T, 0.0, reading)
    assert np.all(d0["total"] == 0) and np.all(d0["offset"] == 0)
    d1, d2 = drift_g(G, T, 1.0, reading)["total"], drift_g(G, T, 2.0, reading)["total"]
    if reading == "H":
        # The linear scale-factor change cancels exactly; what remains is the readout's
        # (du/u)^2 term, cubic in the input: twice the input, eight times the (sub-ug) drift.
        mask = np.abs(T - 25) > 1
        np.testing.assert_allclose(d2[mask] / d1[mask], 8.0, rtol=1e-3)
    else:
        # scale factor: twice the input, twice the drift, up to the readout's nonlinearity
        # C2 - C3 ~ du / (u^2 - du^2): (du/u)^2 = 1.9e-4 per g^2, a few 1e-3 relative at 2 g (0.11 % seen).
        np.testing.assert_allclose(d2, 2 * d1, rtol=5e-3, atol=1e-15)
    assert np.all(drift_g(G, 25.0, 1.0, reading)["total"] == 0)  # no drift at the reference


def test_invalid_geometry_errors():
    with pytest.raises(GeometryError, match="b_um must be > 0"):
        CombGeometry(b_um=0)
    with pytest.raises(GeometryError, match=r"closes at 37\.\d °C"):
        check_gaps(CombGeometry(u_um=0.0553))
    with pytest.raises(GeometryError, match="finger-tip gap e closes at"):
        check_gaps(CombGeometry(e_um=0.01))
    check_gaps(G)  # the default geometry is open everywhere


def test_cli_invalid_geometry_exits_2(tmp_path):
    bad = tmp_path / "g.yaml"
    bad.write_text("program:\n  steps: [{type: hold, dwell_s: 10}]\ndevice:\n  geometry: {u_um: 0.0553}\n")
    r = run_cli("comb", str(bad))
    assert r.returncode == 2 and r.stderr.count("\n") == 1 and r.stderr.startswith("twin: error: ")
    assert "g.yaml:4" in r.stderr and "closes at" in r.stderr and "Traceback" not in r.stderr
    neg = tmp_path / "n.yaml"
    neg.write_text("program:\n  steps: [{type: hold, dwell_s: 10}]\ndevice:\n  geometry: {b_um: -3}\n")
    r = run_cli("render", str(neg), "-o", str(tmp_path / "x.png"))
    assert r.returncode == 2 and "device.geometry.b_um" in r.stderr
