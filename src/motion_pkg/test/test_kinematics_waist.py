"""The waist solve of motion_pkg.kinematics (RobotGeometry.inverse_waist), no ROS master needed."""

import copy
import math
import os
import sys

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(HERE, '..', 'src'))

from motion_pkg import kinematics as kin  # noqa: E402

ROBOT_YAML = os.path.join(HERE, '..', '..', 'harvest_description', 'config', 'robot.yaml')
GEOM = kin.RobotGeometry.from_yaml(ROBOT_YAML)
FAST = settings(max_examples=150, deadline=None)

#: fruit centre (base_link) beside the fixed workspace: the suction arm (standoff = radius)
#: reaches it only with the waist turned to the left
BESIDE_LEFT = np.array([0.66, 0.336, 0.827])
#: beside on the right: the suction arm reaches it at waist 0, the cutting hand at its peduncle not
BESIDE_RIGHT = np.array([0.679, -0.187, 0.863])
RADIUS = 0.035


def peduncle(centre, radius=RADIUS):
    return centre + np.array([0.0, 0.0, radius + 0.01])


def same(a, b):
    """IKResults equal, NaN clearances (branches not checked for clearance) included."""
    return repr(a) == repr(b)


def geometry_with_waist_limits(lo, hi):
    config = copy.deepcopy(GEOM.config)
    config['robot']['waist']['min'] = lo
    config['robot']['waist']['max'] = hi
    return kin.RobotGeometry(config)


def test_target_reachable_where_the_waist_is_gives_exactly_inverse():
    p = np.array([0.5, 0.0, 0.9])
    for waist in (0.0, 0.3, -0.4):
        sol = GEOM.inverse_waist('right', p, standoff=RADIUS, waist=waist)
        assert same(sol.ik, GEOM.inverse('right', p, standoff=RADIUS, waist=waist))
        assert sol.ik.reachable and not sol.moved and sol.waist == waist and sol.other is None


@FAST
@given(st.sampled_from(kin.ARMS), st.floats(0.18, 0.64), st.floats(-math.pi / 2, math.pi / 2),
       st.floats(0.0, 0.30), st.floats(-math.pi, math.pi))
def test_reachable_targets_are_unchanged(arm, r, phi, lift, waist):
    """Wherever inverse() reaches at the current waist angle, inverse_waist returns its answer
    unchanged and does not move the waist."""
    base, yaw, z0 = GEOM._arm_base(arm, waist)
    p = np.array([base[0] + r * math.cos(yaw + phi), base[1] + r * math.sin(yaw + phi), z0 + lift])
    ik = GEOM.inverse(arm, p, waist=waist)
    sol = GEOM.inverse_waist(arm, p, waist=waist)
    if ik.reachable:
        assert same(sol.ik, ik) and not sol.moved and sol.waist == waist


def test_target_only_reachable_with_the_waist_is_solved():
    assert not GEOM.inverse('right', BESIDE_LEFT, standoff=RADIUS).reachable
    sol = GEOM.inverse_waist('right', BESIDE_LEFT, standoff=RADIUS)
    assert sol.ik.reachable and sol.moved, sol.ik.reason
    assert 0.0 < sol.waist < math.radians(45.0)          # turned toward the fruit (left)
    lift, boom, forearm = sol.ik.joints
    tcp = GEOM.forward('right', lift, boom, forearm, waist=sol.waist)
    direction = GEOM.tool_direction('right', boom, forearm, sol.waist)
    assert np.allclose(tcp + RADIUS * direction, BESIDE_LEFT, atol=1e-6)
    assert same(sol.ik, GEOM.inverse('right', BESIDE_LEFT, standoff=RADIUS, waist=sol.waist))


def test_the_smallest_rotation_is_taken_with_a_margin():
    sol = GEOM.inverse_waist('right', BESIDE_LEFT, standoff=RADIUS)
    # the drive's tolerance cannot put the target back out of reach
    for w in (sol.waist - kin.WAIST_MARGIN, sol.waist + kin.WAIST_MARGIN):
        assert GEOM.inverse('right', BESIDE_LEFT, standoff=RADIUS, waist=w).reachable
    # no smaller rotation (either way) keeps that margin
    edge = sol.waist - kin.WAIST_MARGIN - kin.WAIST_STEP
    for w in np.linspace(-edge, edge, 41):
        assert not GEOM.inverse('right', BESIDE_LEFT, standoff=RADIUS, waist=w).reachable, w
    # from another current angle the rotation is counted from there
    start = math.radians(30.0)
    again = GEOM.inverse_waist('right', BESIDE_LEFT, standoff=RADIUS, waist=start)
    assert not again.moved and again.waist == start


def test_waist_limits_are_respected():
    narrow = geometry_with_waist_limits(-0.1, 0.1)
    sol = narrow.inverse_waist('right', BESIDE_LEFT, standoff=RADIUS)
    assert not sol.ik.reachable and not sol.moved and sol.ik.joints is None
    assert sol.ik.reason.startswith('beyond reach: ')
    assert 'no waist angle in [-6, 6] deg reaches it' in sol.ik.reason
    # a limit just past the needed angle: the answer stays inside the limits
    full = GEOM.inverse_waist('right', BESIDE_LEFT, standoff=RADIUS)
    tight = geometry_with_waist_limits(-0.1, full.waist + 0.5 * kin.WAIST_STEP)
    sol = tight.inverse_waist('right', BESIDE_LEFT, standoff=RADIUS)
    assert not sol.ik.reachable or sol.waist <= full.waist + 0.5 * kin.WAIST_STEP


@FAST
@given(st.floats(0.3, 0.9), st.floats(-0.9, 0.9), st.floats(0.8, 1.1), st.floats(-1.0, 1.0),
       st.floats(0.05, 1.0))
def test_solutions_always_within_limits_and_on_target(x, y, z, waist, half_range):
    geom = geometry_with_waist_limits(-half_range, half_range)
    waist = max(-half_range, min(half_range, waist))
    p = np.array([x, y, z])
    sol = geom.inverse_waist('right', p, standoff=RADIUS, waist=waist, other_xyz=peduncle(p))
    if sol.ik.reachable:
        assert -half_range - 1e-9 <= sol.waist <= half_range + 1e-9
        assert geom._limit_reason(sol.ik.joints) == ''
        lift, boom, forearm = sol.ik.joints
        tcp = geom.forward('right', lift, boom, forearm, waist=sol.waist)
        assert np.allclose(tcp + RADIUS * geom.tool_direction('right', boom, forearm, sol.waist),
                           p, atol=1e-6)
        if sol.moved:        # a moved waist always serves both arms
            assert sol.other.reachable
            assert geom.clearance('right', sol.ik.joints, sol.other.joints, sol.waist) >= \
                geom.arm_clearance
    else:
        assert not sol.moved and sol.ik.reason


def test_other_arm_target_turns_the_waist_too():
    """The suction arm reaches the fruit at waist 0, the cutting hand its peduncle does not: with
    the peduncle as the other target the waist turns (right) until both reach, clear of each
    other."""
    ped = peduncle(BESIDE_RIGHT)
    alone = GEOM.inverse_waist('right', BESIDE_RIGHT, standoff=RADIUS)
    assert alone.ik.reachable and not alone.moved
    assert not GEOM.inverse('left', ped, other_arm_joints=alone.ik.joints).reachable
    sol = GEOM.inverse_waist('right', BESIDE_RIGHT, standoff=RADIUS, other_xyz=ped)
    assert sol.moved and sol.waist < 0.0
    assert sol.ik.reachable and sol.other.reachable
    assert same(sol.other, GEOM.inverse('left', ped, other_arm_joints=sol.ik.joints,
                                       waist=sol.waist))
    assert GEOM.clearance('right', sol.ik.joints, sol.other.joints, sol.waist) >= \
        GEOM.arm_clearance


def test_other_target_nowhere_reachable_keeps_this_arms_answer():
    far = np.array([2.0, 0.0, 0.9])
    p = np.array([0.5, 0.0, 0.9])
    sol = GEOM.inverse_waist('right', p, standoff=RADIUS, other_xyz=far)
    assert same(sol.ik, GEOM.inverse('right', p, standoff=RADIUS)) and not sol.moved
    assert not sol.other.reachable and sol.other.reason.startswith('beyond reach')
    # and when this arm does not reach where the waist is either: unreachable, no move
    sol = GEOM.inverse_waist('right', BESIDE_LEFT, standoff=RADIUS, other_xyz=far)
    assert not sol.ik.reachable and not sol.moved
    assert 'reaches both targets' in sol.ik.reason


def test_far_target_is_unreachable_without_search():
    sol = GEOM.inverse_waist('left', (1.5, 0.0, 0.9))
    assert not sol.ik.reachable and not sol.moved
    assert sol.ik.reason.startswith('beyond reach: ') and 'no waist angle' in sol.ik.reason


@pytest.mark.parametrize('kwargs, reason', [
    (dict(xyz=(float('nan'), 0.0, 0.9)), 'NaN in target'),
    (dict(xyz=(0.5, 0.0, 0.9), waist=float('nan')), 'NaN in waist angle'),
    (dict(xyz=(0.5, 0.0, 0.9), standoff=-0.01), 'standoff'),
    (dict(xyz=(0.5, 0.0, 0.9), other_xyz=(0.5, float('nan'), 0.9)), 'NaN in target'),
])
def test_invalid_input_is_refused_without_search(kwargs, reason):
    sol = GEOM.inverse_waist('right', **kwargs)
    assert not sol.ik.reachable and not sol.moved and reason in sol.ik.reason
