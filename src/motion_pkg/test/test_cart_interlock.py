"""The cart interlock of motion_server (motion_pkg.motion_interlock), against robot.yaml's
geometry, control_pkg's park poses and the simulated plant factory's fruit."""

import glob
import math
import os
import sys

import numpy as np
import pytest
import yaml

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(HERE, '..', 'src'))

from motion_pkg import kinematics as kin  # noqa: E402
from motion_pkg.motion_interlock import CartInterlock, move_robot_refusal  # noqa: E402

SRC = os.path.join(HERE, '..', '..')
GEOM = kin.RobotGeometry.from_yaml(os.path.join(SRC, 'harvest_description', 'config',
                                                'robot.yaml'))
with open(os.path.join(SRC, 'motion_pkg', 'config', 'motion_server.yaml')) as _f:
    MAX_X = yaml.safe_load(_f)['stowed_max_x']
with open(os.path.join(SRC, 'control_pkg', 'config', 'executive.yaml')) as _f:
    _EXECUTIVE = yaml.safe_load(_f)
HOME = {arm: tuple(_EXECUTIVE['home'][arm]) for arm in kin.ARMS}
BOX = tuple(_EXECUTIVE['collection_box_right'][:3])
LOCK = CartInterlock(GEOM, MAX_X)
NAN = float('nan')


def scenario_fruit_poses():
    """(scenario, fruit id, arm, joints) of every fruit an arm reaches from a picking point of
    a simulated scenario, at the centre and the peduncle, with standoffs 0, 5 and 10 cm (the
    suction, approach and standby poses are among them)."""
    out = []
    for path in sorted(glob.glob(os.path.join(SRC, 'harvest_sim', 'scenarios', '*.yaml'))):
        with open(path) as f:
            scenario = yaml.safe_load(f)
        for fruit in scenario['fruits']:
            for point in scenario['track']['picking_points']:
                for where in (fruit['position'], fruit['peduncle']):
                    xyz = np.array(where, dtype=float) - np.array([0.0, point, 0.0])
                    for arm in kin.ARMS:
                        for standoff in (0.0, 0.05, 0.10):
                            res = GEOM.inverse(arm, xyz, standoff=standoff)
                            if res.reachable:
                                out.append((os.path.basename(path), fruit['id'], arm,
                                            res.joints))
    return out


def test_the_park_poses_are_stowed():
    assert LOCK.arms_out({'left': HOME['left'], 'right': BOX}) == []
    assert LOCK.arms_out({'left': HOME['left'], 'right': HOME['right']}) == []
    assert LOCK.move_base_refusal({'left': HOME['left'], 'right': BOX}, 0.0, []) == ''
    # the lift does not matter, only where the chain is ahead of the waist axis
    assert LOCK.arms_out({'left': (0.3,) + HOME['left'][1:], 'right': BOX}) == []


def test_the_arms_at_zero_are_out():
    """The simulated controller starts every axis at 0: both arms stretched 45 degrees out."""
    out = LOCK.arms_out({'left': (0.0, 0.0, 0.0), 'right': (0.0, 0.0, 0.0)})
    assert len(out) == 2
    assert out[0].startswith('left arm: tool 0.56 m ahead') and out[1].startswith('right arm')
    why = LOCK.move_base_refusal({'left': HOME['left'], 'right': (0.0, 0.0, 0.0)}, 0.0, [])
    assert 'the cart does not move with an arm out' in why and 'right arm: tool' in why
    assert 'left arm' not in why and 'park the arms first' in why


def test_every_fruit_pose_of_the_scenarios_is_out():
    poses = scenario_fruit_poses()
    assert len(poses) > 1000
    for scenario, fruit, arm, joints in poses:
        x, _ = LOCK.furthest(arm, *joints)
        assert x > MAX_X, (scenario, fruit, arm, joints, x)
        other = 'right' if arm == 'left' else 'left'
        assert LOCK.arms_out({arm: joints, other: HOME[other]}), (scenario, fruit, arm)


def test_a_running_arm_goal_refuses_the_cart():
    why = LOCK.move_base_refusal({'left': HOME['left'], 'right': BOX}, 0.0, ['right'])
    assert why.startswith('the cart does not move while an arm does') and 'right arm' in why
    why = LOCK.move_base_refusal({'left': HOME['left'], 'right': BOX}, 0.0, ['right', 'left'])
    assert 'left and right arm' in why


def test_a_moving_cart_refuses_the_arms():
    assert move_robot_refusal(True) == 'no arm moves while the cart does (a move_base goal is ' \
                                       'running)'
    assert move_robot_refusal(False) == ''


@pytest.mark.parametrize('joints,waist,words', [
    ({'left': (0.0, NAN, 0.0), 'right': BOX}, 0.0, 'left arm: joints not known'),
    ({'left': HOME['left']}, 0.0, 'right arm: joints not known (None)'),
    ({'left': HOME['left'], 'right': BOX[:2]}, 0.0, 'right arm: joints not known'),
    ({'left': HOME['left'], 'right': BOX}, NAN, 'the waist angle is not known'),
])
def test_unknown_joints_count_as_out(joints, waist, words):
    out = LOCK.arms_out(joints, waist)
    assert out and words in out[0]


def test_the_waist_angle_counts():
    """Parked joints turned with the waist can point ahead: the left arm's elbow, 0.45 m to
    its side at waist 0, is 0.45 m ahead with the waist turned a quarter to the right."""
    out = LOCK.arms_out({'left': HOME['left'], 'right': HOME['right']}, -math.pi / 2.0)
    assert any(o.startswith('left arm: elbow 0.45 m ahead') for o in out), out
    assert LOCK.arms_out({'left': HOME['left'], 'right': HOME['right']}, 0.0) == []


def test_a_limit_that_is_not_a_distance_is_refused():
    for bad in (NAN, float('inf')):
        with pytest.raises(ValueError, match='stowed_max_x must be a finite distance'):
            CartInterlock(GEOM, bad)
