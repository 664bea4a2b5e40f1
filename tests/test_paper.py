"""`twin paper --json` holds every derived number of the paper with the right verdict."""

import json

import pytest

from conftest import run_cli


@pytest.fixture(scope="module")
def report(tmp_path_factory):
    path = tmp_path_factory.mktemp("paper") / "paper.json"
    r = run_cli("paper", "--json", str(path))
    assert r.returncode == 0, r.stderr
    return {i["item"]: i for i in json.loads(path.read_text())["items"]}


def test_every_item_is_present(report):
    expected = {"eq33_beta", "eq34_control_interval", "eq31_35_control_period", "figure3_rmse_order2",
                "table2_iteration_effect_28", "eq45_global_minimum_z", "silicon_cte_323K"}
    expected |= {f"table1_Q{q}_test{t}" for q in (1, 2, 3) for t in (1, 2, 3)}
    assert expected <= set(report)


def test_values_and_verdicts(report):
    assert report["eq33_beta"]["computed"] == pytest.approx(0.64)
    assert report["eq34_control_interval"]["computed"] == pytest.approx(0.4375)
    assert report["eq34_control_interval"]["verdict"].startswith("differs")
    assert report["eq31_35_control_period"]["computed"] == pytest.approx(29.32, abs=0.005)
    assert "s/m" in report["eq31_35_control_period"]["verdict"]
    assert report["figure3_rmse_order2"]["computed"] == pytest.approx(9.3e-10, rel=0.05)
    assert report["figure3_rmse_order2"]["verdict"].startswith("differs")
    assert len(report["figure3_rmse_order2"]["per_order"]) == 6
    assert report["table2_iteration_effect_28"]["computed"] == pytest.approx(98.86, abs=0.005)
    assert report["table2_iteration_effect_28"]["verdict"].startswith("differs")
    assert report["table1_Q3_test3"]["computed"] == pytest.approx(15.07, abs=0.005)
    for q in (1, 2, 3):
        for t in (1, 2, 3):
            assert report[f"table1_Q{q}_test{t}"]["verdict"].startswith("reproduced")
    m = report["eq45_global_minimum_z"]
    assert m["computed"] == pytest.approx(-3.7563359, abs=1e-7)
    assert (m["x"], m["y"]) == (pytest.approx(1.7626786, abs=1e-7), -2.0)
    assert report["silicon_cte_323K"]["computed"] == pytest.approx(2.75e-6, rel=1e-3)
    assert report["silicon_cte_323K"]["verdict"].startswith("differs")
