"""Stamps of simulated camera frames (harvest_sim.frame_timing)."""

import sim_fixtures  # noqa: F401  (puts harvest_sim on the path)
from harvest_sim.frame_timing import frame_stamp, next_frame_hold


def test_a_frame_carries_the_time_of_the_pose_it_shows():
    # the cart stopped at 150.2; under load the camera's latest joint state is from 149.9,
    # before the move: the frame is 149.9 old, whether rendered anew or taken from the cache
    assert frame_stamp(now=150.5, joint_stamp=149.9, last_stamp=149.0) == 149.9


def test_no_frame_without_a_newer_pose():
    assert frame_stamp(now=151.0, joint_stamp=149.9, last_stamp=149.9) is None
    assert frame_stamp(now=151.0, joint_stamp=149.8, last_stamp=149.9) is None


def test_without_joint_states_the_frame_is_stamped_now():
    assert frame_stamp(now=120.0, joint_stamp=None) == 120.0
    assert frame_stamp(now=120.0, joint_stamp=None, last_stamp=120.0) is None
    assert frame_stamp(now=120.5, joint_stamp=None, last_stamp=120.0) == 120.5


def test_a_joint_state_from_the_future_is_capped_at_now():
    assert frame_stamp(now=100.0, joint_stamp=100.02) == 100.0


def test_free_running_hold_is_one_period_after_the_frame_never_in_the_past():
    # on schedule: the timer fired at its expected time
    assert next_frame_hold(now=106.0, expected=106.0, period=0.5) == 106.5
    # the timer's expected time fell behind (it started before the clock, or a hold was
    # dropped): the hold is one period after now, where the timer fires next, not in the past
    assert next_frame_hold(now=106.48, expected=2.0, period=0.5) == 106.98
    assert next_frame_hold(now=106.48, expected=2.0, period=0.5) > 106.48
