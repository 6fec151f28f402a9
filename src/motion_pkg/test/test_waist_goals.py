"""MoveRobot goals with the optional waist target (motion_pkg.motion_goals.validate_arm_goal)."""

import math
import os
import sys

import pytest
import yaml

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(HERE, '..', 'src'))

from motion_pkg import motion_goals as mg  # noqa: E402

with open(os.path.join(HERE, '..', '..', 'harvest_description', 'config', 'robot.yaml')) as _f:
    LIMITS = mg.limits_from_robot_config(yaml.safe_load(_f))
NAN = float('nan')


def test_without_a_waist_the_goal_is_the_arm_alone():
    assert mg.validate_arm_goal([0.1, 0.5, -0.5], [], True, LIMITS) == \
        mg.validate_arm_goal([0.1, 0.5, -0.5], [], True, LIMITS, None)
    names, _, _ = mg.validate_arm_goal([0.1, 0.5, -0.5], [], True, LIMITS)
    assert 'waist' not in names


def test_arm_and_waist_move_together():
    names, targets, speeds = mg.validate_arm_goal([0.1, 0.5, -0.5], [0.05, 0.0, 0.0], False,
                                                  LIMITS, 0.4)
    assert names == mg.arm_axes(False) + ['waist']
    assert targets == [0.1, 0.5, -0.5, 0.4]
    assert speeds[0] == 0.05 and speeds[3] == LIMITS['waist'].speed


def test_waist_alone():
    names, targets, speeds = mg.validate_arm_goal([], [], False, LIMITS, -1.0)
    assert (names, targets, speeds) == (['waist'], [-1.0], [LIMITS['waist'].speed])


@pytest.mark.parametrize('positions,velocities,waist,words', [
    ([], [], NAN, 'waist target is not a finite number'),
    ([0.1, 0.0, 0.0], [], float('inf'), 'waist target is not a finite number'),
    ([], [], 3.2, 'waist target 183.35 deg is beyond the joint limits'),
    ([], [], -3.2, 'waist target -183.35 deg is beyond the joint limits'),
    ([], [0.1], 0.1, 'velocities must be empty for a waist-only goal'),
    ([0.1, NAN, 0.0], [], 0.1, 'NaN'),                  # the arm part is still checked
    ([0.1, 0.0], [], 0.1, 'needs 3 values'),
    ([0.31, 0.0, 0.0], [], 0.1, 'right_lift target 310.0 mm is beyond'),
])
def test_invalid_waist_goals(positions, velocities, waist, words):
    with pytest.raises(mg.GoalError) as err:
        mg.validate_arm_goal(positions, velocities, False, LIMITS, waist)
    assert words in str(err.value)


def test_no_waist_axis_is_refused():
    limits = dict((k, v) for k, v in LIMITS.items() if k != 'waist')
    with pytest.raises(mg.GoalError, match='no waist axis'):
        mg.validate_arm_goal([], [], False, limits, 0.0)


def test_waist_targets_are_planned_like_every_axis():
    names, targets, speeds = mg.validate_arm_goal([], [], False, LIMITS, math.radians(60.0))
    budget = mg.plan_axes_move(names, targets, speeds, [0.0], LIMITS, 1.5, 2.0)
    expect = mg.move_duration(math.radians(60.0), LIMITS['waist'].speed,
                              LIMITS['waist'].acceleration) * 1.5 + 2.0
    assert budget == pytest.approx(expect)
