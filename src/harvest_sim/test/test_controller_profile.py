"""Trapezoidal profiles of the simulated drives (harvest_sim.controller_profile)."""

import math
import os
import sys

import pytest
from hypothesis import given, settings, strategies as st

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), '..', 'src'))

from harvest_sim.controller_profile import move_duration, plan_move, plan_stop  # noqa: E402

FAST = settings(max_examples=300, deadline=None)
positions = st.floats(-10.0, 10.0)
speeds = st.floats(0.05, 2.0)
accels = st.floats(0.1, 5.0)


def sample(profile, n=400):
    t0, t1 = profile.t0, profile.end_time
    return [profile.state(t0 + (t1 - t0) * i / n) for i in range(n + 1)]


def test_trapezoid_duration_and_shape():
    p = plan_move(2.0, 0.0, 0.0, 3.0, 0.2, 0.6)
    assert p.duration == pytest.approx(3.0 / 0.2 + 0.2 / 0.6)
    assert p.duration == pytest.approx(move_duration(3.0, 0.2, 0.6))
    assert len(p.segments) == 3
    assert p.state(2.0 + 0.2 / 0.6) == pytest.approx((0.5 * 0.6 * (0.2 / 0.6) ** 2, 0.2))
    assert p.state(100.0) == (3.0, 0.0)
    assert p.state(1.0) == (0.0, 0.0)


def test_triangle_for_short_moves():
    p = plan_move(0.0, 0.1, 0.0, 0.0, 1.0472, 3.1416)
    assert p.duration == pytest.approx(2.0 * math.sqrt(0.1 / 3.1416))
    assert len(p.segments) == 2
    assert p.state(p.duration / 2.0)[0] == pytest.approx(0.05)


def test_zero_move_and_bad_limits():
    assert plan_move(0.0, 1.0, 0.0, 1.0, 1.0, 1.0).duration == 0.0
    with pytest.raises(ValueError):
        plan_move(0.0, 0.0, 0.0, 1.0, 0.0, 1.0)
    with pytest.raises(ValueError):
        plan_stop(0.0, 0.0, 1.0, -1.0)


def test_stop_decelerates_at_the_limit():
    p = plan_stop(1.0, 0.5, -0.3, 0.6)
    assert p.duration == pytest.approx(0.5)
    assert p.end_position == pytest.approx(0.5 - 0.3 * 0.3 / 1.2)
    assert p.state(1.25)[1] == pytest.approx(-0.15)


@FAST
@given(positions, positions, speeds, accels)
def test_rest_to_rest_reaches_target_within_limits(p0, p1, vmax, amax):
    p = plan_move(0.0, p0, 0.0, p1, vmax, amax)
    assert p.state(p.end_time) == (p1, 0.0)
    assert p.duration == pytest.approx(move_duration(p1 - p0, vmax, amax), abs=1e-9)
    lo, hi = min(p0, p1), max(p0, p1)
    for pos, vel in sample(p):
        assert abs(vel) <= vmax * (1 + 1e-9)
        assert lo - 1e-9 <= pos <= hi + 1e-9          # no overshoot
    assert sample(p)[-2][0] == pytest.approx(p1, abs=abs(p1 - p0) / 50 + 1e-9)


@FAST
@given(positions, st.floats(-3.0, 3.0), positions, speeds, accels)
def test_moving_start_is_continuous_and_ends_at_target(p0, v0, p1, vmax, amax):
    p = plan_move(0.0, p0, v0, p1, vmax, amax)
    assert p.state(p.end_time) == (p1, 0.0)
    prev = None
    for seg in p.segments:                            # position and velocity continuous
        if prev is not None:
            end = prev.end()
            assert seg.p0 == pytest.approx(end[0], abs=1e-9)
            assert seg.v0 == pytest.approx(end[1], abs=1e-9)
        assert abs(seg.a) <= amax * (1 + 1e-12)
        prev = seg
    assert prev is None or prev.end()[0] == pytest.approx(p1, abs=1e-6)
    assert prev is None or abs(prev.end()[1]) < 1e-9


@FAST
@given(positions, speeds, accels)
def test_the_robots_move_time_is_the_simulated_drives(distance, vmax, amax):
    # motion_pkg budgets a move's time with its own rest-to-rest formula (motion_goals), and
    # bench_mission's lower bound uses that one: it must be the time the simulated drives take
    from motion_pkg.motion_goals import move_duration as robot_move_duration
    assert robot_move_duration(distance, vmax, amax) == pytest.approx(
        move_duration(distance, vmax, amax), rel=1e-12, abs=1e-12)
    assert plan_move(0.0, 0.0, 0.0, distance, vmax, amax).duration == pytest.approx(
        robot_move_duration(distance, vmax, amax), rel=1e-9, abs=1e-9)
