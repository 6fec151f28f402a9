"""The simulated controller refuses a bad robot.yaml naming the field (issue 14): a NaN joint
limit crashed it at start with an unrelated message, a NaN speed made a model that cannot move."""

import os
import sys

import pytest
import yaml

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(HERE, '..', 'src'))

from harvest_sim.controller_model import axes_from_robot_config  # noqa: E402
from harvest_description.robot_config import RobotConfigError  # noqa: E402
from harvest_test_utils.config import with_value  # noqa: E402

ROBOT_YAML = os.path.join(HERE, '..', '..', 'harvest_description', 'config', 'robot.yaml')
with open(ROBOT_YAML) as _f:
    ROBOT = yaml.safe_load(_f)
NAN = float('nan')


def changed(path, value):
    return with_value(ROBOT, path, value)


@pytest.mark.parametrize('path,value,field', [
    (('robot', 'joint_limits', 'boom', 'max'), NAN, 'robot.joint_limits.boom.max'),
    (('motion', 'speed', 'lift'), NAN, 'motion.speed.lift'),
    (('motion', 'acceleration', 'cart'), float('inf'), 'motion.acceleration.cart'),
    (('robot', 'track', 'min'), 31.0, 'robot.track'),
    (('axes',), ['cart', 'cart'], 'axes[1]'),
])
def test_bad_robot_yaml_is_refused_naming_the_field(path, value, field):
    with pytest.raises(RobotConfigError) as err:
        axes_from_robot_config(changed(path, value))
    assert err.value.field == field
    assert str(err.value).startswith('robot.yaml: %s: ' % field)


def test_the_committed_robot_yaml_makes_every_axis():
    configs = axes_from_robot_config(ROBOT)
    assert [c.name for c in configs] == ROBOT['axes']
