"""Simulated clock schedule (no ROS master)."""

import pytest

import sim_fixtures  # noqa: F401  (puts harvest_sim on the path)
from harvest_sim.clock import ClockSchedule


def test_schedule_is_deterministic():
    s = ClockSchedule(time_scale=5.0, step=0.01, start=100.0)
    times = [s.advance() for _ in range(1000)]
    assert times[0] == pytest.approx(100.01)
    assert times[-1] == pytest.approx(110.0)
    assert s.wall_offset() == pytest.approx(2.0)           # 10 s simulated in 2 s wall
    assert s.achieved_scale(2.5) == pytest.approx(4.0)
    t = ClockSchedule(time_scale=5.0, step=0.01, start=100.0)
    assert [t.advance() for _ in range(1000)] == times


@pytest.mark.parametrize('kw', [dict(time_scale=0.0), dict(step=-0.1), dict(start=-1.0)])
def test_bad_parameters_raise(kw):
    with pytest.raises(ValueError):
        ClockSchedule(**kw)
