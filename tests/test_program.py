"""Chamber program: staircase, ramp, hold, cycles; impossible programs."""

import numpy as np
import pytest

from sim.program import Hold, ProgramError, Ramp, Staircase, compile_program, segment_kind


def test_paper_program_duration_and_levels():
    p = compile_program(-20, [Hold(3600), Staircase(50, 0.4, 35), Hold(3600), Staircase(-20, 0.4, 35)], 3)
    # 70 degC / 0.4 = 175 steps x 35 s = 6125 s per ramp; cycle 19450 s; three cycles 16.2 h.
    assert p.duration_s == pytest.approx(3 * (2 * 3600 + 2 * 6125))
    t = np.array([0, 3599.9, 3600, 3634.9, 3635, 3600 + 6124.9, 3600 + 6125, 19450 + 1])
    sp = p.setpoint_c(t)
    np.testing.assert_allclose(sp, [-20, -20, -20, -20, -19.6, 49.6, 50, -20], atol=1e-9)
    # the staircase's average rate, from the compiled set-point: 70 °C over 6125 s = 41.14 °C/h
    start, end = 3600.0, 3600.0 + 6125.0
    assert (p.setpoint_c(np.array([end]))[0] - p.setpoint_c(np.array([start]))[0]) / (end - start) * 3600 == \
        pytest.approx(41.14, abs=0.01)


def test_ramp_and_hold_with_target():
    p = compile_program(25, [Ramp(85, 60), Hold(600, target_c=-40)], 1)
    assert p.duration_s == pytest.approx(3600 + 600)
    np.testing.assert_allclose(p.setpoint_c(np.array([0, 1800, 3599.99, 3601, 4200])), [25, 55, 85, -40, -40], atol=1e-3)
    np.testing.assert_array_equal(segment_kind(p, np.array([10, 3700])), [1, 0])


def test_negative_rate_is_signed_and_must_point_at_target():
    assert compile_program(50, [Ramp(-20, -35)]).duration_s == pytest.approx(7200)
    with pytest.raises(ProgramError, match="never reaches"):
        compile_program(-20, [Ramp(50, -41)])
    with pytest.raises(ProgramError, match="never reaches"):
        compile_program(-20, [Ramp(50, 0)])


def test_partial_last_staircase_step():
    p = compile_program(0, [Staircase(1.0, 0.4, 10)])
    assert p.duration_s == 30  # 0.4, 0.8, then a partial 0.2 step
    np.testing.assert_allclose(p.setpoint_c(np.array([5, 15, 25, 30])), [0, 0.4, 0.8, 1.0])


@pytest.mark.parametrize("step", [Hold(0), Hold(-5), Staircase(1, 0, 10), Staircase(1, 0.4, -1)])
def test_impossible_steps(step):
    with pytest.raises(ProgramError) as exc:
        compile_program(0, [step])
    assert exc.value.step_index == 0
