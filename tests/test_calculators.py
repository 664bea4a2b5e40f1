"""Paper test-design numbers (docs/physics.md §2.1-2.3)."""

import pytest

from sim import calculators as calc
from twin.reporting.paper import design_report


def test_eq34_control_interval():
    # 0.98 / (1.6 + 0.64) = 0.4375 exactly; the paper's "0.43" truncates it.
    assert calc.control_interval_c(0.98, 0.8, 0.64) == pytest.approx(0.4375, abs=1e-12)


def test_eq33_beta_only_with_percent_dropped():
    assert calc.paper_beta_mg_per_c() == pytest.approx(0.64)
    assert calc.paper_beta_mg_per_c(honour_percent=True) == pytest.approx(0.0064)
    assert calc.physical_beta_mg_per_c(0.01, 1.0) == pytest.approx(0.1)


def test_eq31_control_period_as_printed():
    # C in kJ/(kg K), b1 = 0.600 m, b2 = 0.605 m: 29.3230 s (docs/physics.md §2.3).
    assert calc.paper_control_period_s() == pytest.approx(29.32, abs=0.005)


def test_physical_conduction_time_scales():
    a = calc.thermal_diffusivity_m2_per_s()
    assert a == pytest.approx(2.05e-5, rel=0.005)
    assert calc.conduction_time_scale_s(0.3, a) == pytest.approx(4380, rel=0.001)
    assert calc.first_mode_time_constant_s(0.3, a) == pytest.approx(1775, rel=0.001)
    # centre-plane Fourier numbers: 50 % 0.379, 63.2 % 0.503, 90 % 1.03, 99 % 1.96 (docs/physics.md §2.3)
    for frac, fo in [(0.5, 0.379), (0.632, 0.503), (0.9, 1.03), (0.99, 1.96)]:
        assert calc.centre_response_fourier(frac) == pytest.approx(fo, abs=0.005)


def test_air_density_ideal_gas():
    # docs/physics.md §1.5 (CoolProp): 1.293 at 0 degC, 1.205 at 20 degC
    assert calc.air_density_kg_per_m3(0.0) == pytest.approx(1.293, abs=0.002)
    assert calc.air_density_kg_per_m3(20.0) == pytest.approx(1.205, abs=0.002)


def test_report_labels_paper_and_physical_numbers():
    items = {r.name: r for r in design_report().items}
    assert items["eq34_control_interval"].value == pytest.approx(0.4375)
    assert items["eq31_35_control_period"].value == pytest.approx(29.32, abs=0.005)
    assert items["eq31_35_control_period"].kind == "paper-as-printed"
    assert "s/m" in items["eq31_35_control_period"].note
    assert items["first_mode_time_constant"].kind == "physical"
