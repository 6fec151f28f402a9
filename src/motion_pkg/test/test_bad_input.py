"""Bad input never moves the robot (issue 14): a bad robot.yaml is refused by motion_pkg's
readers, and no NaN, infinity or overflow of a goal reaches the register encoding."""

import math
import os
import sys

import pytest
import yaml
from hypothesis import given, settings, strategies as st

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(HERE, '..', 'src'))

from motion_pkg import kinematics as kin  # noqa: E402
from motion_pkg import motion_goals as mg  # noqa: E402
from motion_pkg.modbus_map import RegisterMap  # noqa: E402
from harvest_description.robot_config import RobotConfigError  # noqa: E402
from harvest_test_utils.config import with_value  # noqa: E402

ROBOT_YAML = os.path.join(HERE, '..', '..', 'harvest_description', 'config', 'robot.yaml')
with open(ROBOT_YAML) as _f:
    ROBOT = yaml.safe_load(_f)
MAP = RegisterMap.from_file(os.path.join(HERE, '..', 'config', 'register_map.yaml'))
LIMITS = mg.limits_from_robot_config(ROBOT)
NAN = float('nan')
RIGHT = mg.arm_axes(False)


def changed(path, value):
    return with_value(ROBOT, path, value)


def write(tmp_path, config):
    path = tmp_path / 'robot.yaml'
    path.write_text(yaml.safe_dump(config))
    return str(path)


# --- robot.yaml ------------------------------------------------------------------------------
def test_nan_boom_speed_is_refused_when_the_limits_are_read():
    with pytest.raises(RobotConfigError) as err:
        mg.limits_from_robot_config(changed(('motion', 'speed', 'boom'), NAN))
    assert str(err.value) == 'robot.yaml: motion.speed.boom: NaN is not finite'


def test_nan_link_length_is_refused_instead_of_every_fruit_unreachable(tmp_path):
    path = write(tmp_path, changed(('robot', 'link_lengths', 'forearm'), NAN))
    with pytest.raises(RobotConfigError) as err:
        kin.RobotGeometry.from_yaml(path)
    assert str(err.value) == '%s: robot.link_lengths.forearm: NaN is not finite' % path
    with pytest.raises(RobotConfigError):
        kin.RobotGeometry(changed(('robot', 'link_lengths', 'boom'), -0.3))


def test_nan_joint_limit_is_refused(tmp_path):
    path = write(tmp_path, changed(('robot', 'joint_limits', 'boom', 'min'), NAN))
    with pytest.raises(RobotConfigError) as err:
        kin.RobotGeometry.from_yaml(path)
    assert err.value.field == 'robot.joint_limits.boom.min'


# --- goal-time conversions -------------------------------------------------------------------
class Recorder(object):
    """encode callable recording what would be sent (the real register encoding)."""

    def __init__(self):
        self.calls = []

    def __call__(self, name, target, speed, acceleration):
        self.calls.append((name, target, speed, acceleration))
        return MAP.encode_move(MAP.axis(name).index, target, speed, acceleration)


def plan(targets, speeds, starts=(0.0, 0.0, 0.0), limits=None, factor=1.5, margin=2.0,
         encode=None):
    return mg.plan_axes_move(RIGHT, list(targets), list(speeds), list(starts), limits or LIMITS,
                             factor, margin, encode)


def test_plan_returns_the_time_budget_and_encodes_every_axis():
    enc = Recorder()
    budget = plan([0.1, 0.5, -0.5], [0.1, 1.0, 1.0], encode=enc)
    slowest = max(mg.move_duration(d, s, LIMITS[n].acceleration)
                  for n, d, s in zip(RIGHT, [0.1, 0.5, -0.5], [0.1, 1.0, 1.0]))
    assert budget == pytest.approx(slowest * 1.5 + 2.0)
    assert [c[0] for c in enc.calls] == RIGHT


def test_nan_speed_of_one_axis_moves_no_axis():
    # the probe: a NaN boom speed wrote the lift's move, then int(NaN) raised on the boom
    nan_speed = dict(LIMITS)
    nan_speed['right_boom'] = mg.AxisLimits('right_boom', -2.6, 2.6, NAN, 3.0, False)
    enc = Recorder()
    with pytest.raises(mg.GoalError, match='right_boom speed is not a finite number'):
        plan([0.1, 0.5, -0.5], [0.1, nan_speed['right_boom'].speed, 1.0], limits=nan_speed,
             encode=enc)
    assert enc.calls == []


@pytest.mark.parametrize('targets,speeds,starts,factor,margin,words', [
    ([0.1, NAN, 0.0], [0.1, 1.0, 1.0], [0.0] * 3, 1.5, 2.0, 'right_boom target'),
    ([0.1, 0.0, 0.0], [0.1, 1.0, 1.0], [0.0, float('inf'), 0.0], 1.5, 2.0, 'current position'),
    ([0.1, 0.0, 0.0], [0.0, 1.0, 1.0], [0.0] * 3, 1.5, 2.0, 'speed and acceleration > 0'),
    ([0.1, 0.0, 0.0], [0.1, 1.0, 1.0], [0.0] * 3, NAN, 2.0, 'deadline'),
    ([0.1, 0.0, 0.0], [0.1, 1.0, 1.0], [0.0] * 3, 1.5, float('inf'), 'deadline'),
    ([1e9, 0.0, 0.0], [0.1, 1.0, 1.0], [0.0] * 3, 1.5, 2.0, 'cannot be sent'),
    ([0.0, 0.0, 0.0], [1.8e303, 1.0, 1.0], [0.0] * 3, 0.0, 1.0, 'cannot be sent'),  # -> inf
])
def test_bad_values_are_goal_errors_before_any_write(targets, speeds, starts, factor, margin,
                                                     words):
    enc = Recorder()
    with pytest.raises(mg.GoalError, match=words):
        plan(targets, speeds, starts, factor=factor, margin=margin, encode=enc)
    assert all(all(math.isfinite(v) for v in call[1:]) for call in enc.calls)


ANY = st.floats(allow_nan=True, allow_infinity=True)


@settings(max_examples=300, deadline=None)
@given(st.lists(ANY, min_size=3, max_size=3), st.lists(ANY, min_size=3, max_size=3),
       st.lists(ANY, min_size=3, max_size=3), ANY, ANY)
def test_only_goal_errors_and_finite_values_reach_the_registers(targets, speeds, starts, factor,
                                                                margin):
    enc = Recorder()
    try:
        budget = plan(targets, speeds, starts, factor=factor, margin=margin, encode=enc)
    except mg.GoalError:
        pass
    else:
        assert math.isfinite(budget) and budget > 0.0
        assert len(enc.calls) == 3
    for _, target, speed, acceleration in enc.calls:
        assert math.isfinite(target) and speed > 0.0 and math.isfinite(speed)
        assert acceleration > 0.0 and math.isfinite(acceleration)
