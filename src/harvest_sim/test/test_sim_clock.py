"""Simulated clock schedule (no ROS master)."""

import pytest

import sim_fixtures  # noqa: F401  (puts harvest_sim on the path)
from harvest_sim.clock import ClockHolds, ClockSchedule, RestPace, next_tick_ns


def test_schedule_is_deterministic():
    s = ClockSchedule(time_scale=5.0, step=0.01, start=100.0)
    times = [s.advance() for _ in range(1000)]
    assert times[0] == pytest.approx(100.01)
    assert times[-1] == pytest.approx(110.0)
    assert s.wall_due(s.sim_time_ns()) == pytest.approx(2.0)    # 10 s simulated in 2 s wall
    assert s.achieved_scale(2.5) == pytest.approx(4.0)
    t = ClockSchedule(time_scale=5.0, step=0.01, start=100.0)
    assert [t.advance() for _ in range(1000)] == times


@pytest.mark.parametrize('kw', [dict(time_scale=-1.0), dict(step=-0.1), dict(step=0.0),
                                dict(start=-1.0)])
def test_bad_parameters_raise(kw):
    with pytest.raises(ValueError):
        ClockSchedule(**kw)


def test_time_scale_zero_is_unpaced():
    s = ClockSchedule(time_scale=0.0, step=0.05)
    for _ in range(10):
        s.advance(0.0)
        assert s.wall_offset() == 0.0               # every tick due at once: only holds pace it


def test_tick_times_are_exact_nanoseconds():
    s = ClockSchedule(step=0.02, start=100.0)
    for _ in range(26):
        s.advance()
    assert s.sim_time_ns() == 100520000000          # float 100.52 truncates to ...519999999
    for _ in range(5000 - 26):
        s.advance()
    assert s.sim_time_ns() == 200000000000


def test_a_late_tick_moves_the_anchor_instead_of_racing():
    s = ClockSchedule(time_scale=10.0, step=0.02, max_lag=0.05)
    s.advance(0.002)                                 # on time: due 0.002 s
    assert s.wall_offset() == pytest.approx(0.004)
    s.advance(1.0)                                   # tick 2 published 1 s late (held)
    assert s.reanchors == 1
    assert s.wall_offset() == pytest.approx(1.002)   # the next tick keeps the time scale
    assert s.sim_time() == pytest.approx(100.04)     # times are unchanged: never skipped
    s.advance(1.003)                                 # 1 ms late: within max_lag, kept
    assert s.reanchors == 1


def test_holds_stop_the_clock_once_it_reaches_them():
    h = ClockHolds(timeout=10.0)
    h.set('/cam', 100.5)
    assert h.blocking(100.48, wall_now=0.0) == []
    assert h.blocking(100.5, wall_now=0.0) == ['/cam']         # reached: the timer fires now
    assert h.blocking(100.5 - 1e-9, wall_now=0.0) == ['/cam']  # rounding of the tick
    h.set('/cam', 101.0)                                       # frame out: next one
    assert h.blocking(100.5, wall_now=1.0) == []
    h.set('/hand', 100.6)
    assert h.blocking(100.7, wall_now=1.0) == ['/hand']
    h.set('/hand', 0.0)                                        # released
    assert h.blocking(100.7, wall_now=1.0) == []
    assert len(h) == 1


def test_a_hold_that_stops_the_clock_too_long_is_dropped():
    h = ClockHolds(timeout=2.0)
    h.set('/dead', 100.0)
    h.set('/alive', 100.0)
    assert h.blocking(100.0, wall_now=5.0) == ['/alive', '/dead']   # blocking since 5.0
    h.set('/alive', 100.0)                                          # refreshed at 6.5
    assert h.blocking(100.0, wall_now=6.5) == ['/alive', '/dead']
    assert h.blocking(100.0, wall_now=7.1) == ['/alive']    # /dead blocked 2.1 s > 2: dropped
    assert h.expired == ['/dead']
    h.set('/alive', 102.0)
    assert h.blocking(100.0, wall_now=9.0) == []


def test_set_scale_moves_the_anchor():
    s = ClockSchedule(time_scale=10.0, step=0.02)
    s.advance(0.002)
    s.set_scale(1.0, 0.002)                          # the world rests: real time
    assert s.wall_offset() == pytest.approx(0.022)
    s.advance(0.022)
    s.set_scale(10.0, 0.022)
    assert s.wall_offset() == pytest.approx(0.024)
    assert s.sim_time() == pytest.approx(100.04)


def test_coarse_ticks_while_busy_land_on_the_end_of_the_motion_and_on_holds():
    ms = 1000000
    assert next_tick_ns(100000 * ms, 20 * ms) == 100020 * ms                  # regular
    assert next_tick_ns(100000 * ms, 20 * ms, 100 * ms, 103210 * ms) == 100100 * ms
    assert next_tick_ns(103200 * ms, 20 * ms, 100 * ms, 103210 * ms) == 103220 * ms  # >= step
    assert next_tick_ns(103150 * ms, 20 * ms, 100 * ms, 103210 * ms) == 103210 * ms  # the end
    assert next_tick_ns(103210 * ms, 20 * ms, 100 * ms, 103210 * ms) == 103230 * ms  # at rest
    assert next_tick_ns(100000 * ms, 20 * ms, 100 * ms, 105000 * ms, 100050 * ms) == 100050 * ms
    assert next_tick_ns(100000 * ms, 20 * ms, None, 105000 * ms) == 100020 * ms      # off
    s = ClockSchedule(time_scale=10.0, step=0.02)
    s.advance(0.01, 100100 * ms)
    assert s.sim_time() == pytest.approx(100.1) and s.tick == 1


def test_rest_pace_runs_at_real_time_only_while_the_world_rests():
    r = RestPace(rest_scale=1.0)
    assert r.scale(100.0, 10.0) == 1.0               # start-up: nothing moves, real time
    r.busy('/sim/sim_controller', 100.0)             # at rest
    assert r.scale(100.5, 10.0) == 1.0
    r.busy('/sim/sim_controller', 103.2)             # a move until 103.2
    assert r.scale(101.0, 10.0) == 10.0
    assert r.scale(103.18, 10.0) == 10.0
    assert r.scale(103.2, 10.0) == 1.0               # it has ended: the robot thinks
    assert r.scale(103.2, 0.5) == 0.5                # never faster than the time scale
    assert r.scale(103.2, 0.0) == 1.0                # unpaced clock: real time at rest
    r.busy('/sim/other', 104.0)                      # any source keeps the world busy
    assert r.scale(103.5, 10.0) == 10.0
    assert not RestPace(rest_scale=0.0).resting(200.0)
