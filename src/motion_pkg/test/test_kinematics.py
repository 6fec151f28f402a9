"""Unit and property tests of motion_pkg.kinematics (no ROS master needed)."""

import math
import os
import sys

import numpy as np
import pytest
from hypothesis import example, given, settings, strategies as st

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(HERE, '..', 'src'))

from motion_pkg import kinematics as kin  # noqa: E402

ROBOT_YAML = os.path.join(HERE, '..', '..', 'harvest_description', 'config', 'robot.yaml')
GEOM = kin.RobotGeometry.from_yaml(ROBOT_YAML)
FAST = settings(max_examples=300, deadline=None)

arms = st.sampled_from(kin.ARMS)
unit = st.floats(0.0, 1.0)


def point_in_arm_frame(arm, r, phi, lift):
    """base_link point at horizontal distance r, bearing phi from the arm's x, lift above zero."""
    base, yaw, z0 = GEOM._arm_base(arm)
    return np.array([base[0] + r * math.cos(yaw + phi), base[1] + r * math.sin(yaw + phi),
                     z0 + lift])


def test_geometry_from_yaml():
    assert GEOM.boom == pytest.approx(0.30)
    assert GEOM.forearm + GEOM.tool == pytest.approx(0.35)
    assert GEOM.reach() == pytest.approx((0.05, 0.65))
    assert GEOM.limits['lift'] == (0.0, 0.30)


def test_forward_zero_pose_is_stretched_along_arm_yaw():
    p = GEOM.forward('left', 0.0, 0.0, 0.0)
    expect = np.array([0.10, 0.15, 0.80]) + 0.65 * np.array([math.cos(math.pi / 4),
                                                             math.sin(math.pi / 4), 0.0])
    assert np.allclose(p, expect, atol=1e-6)


def test_frame_tree_has_every_frame():
    poses = GEOM.frame_transforms({})
    for f in ('map', 'base_link', 'waist_link', 'left_arm_base', 'right_arm_base',
              'left_lift_link', 'left_boom_link', 'left_forearm_link', 'left_flange',
              'left_shear_tcp', 'right_suction_tcp', 'hand_camera_link', 'hand_camera_optical',
              'stereo_link', 'stereo_left_optical', 'stereo_right_optical', 'bumblebee2_link'):
        assert f in poses
        assert np.allclose(poses[f][:3, :3].T.dot(poses[f][:3, :3]), np.eye(3))
        assert np.linalg.det(poses[f][:3, :3]) == pytest.approx(1.0)   # right-handed


def test_optical_convention():
    poses = GEOM.frame_transforms({})
    link, opt = poses['stereo_link'][:3, :3], poses['stereo_right_optical'][:3, :3]
    assert np.allclose(opt[:, 2], link[:, 0])      # z forward = link x
    assert np.allclose(opt[:, 0], -link[:, 1])     # x right = -link y
    assert np.allclose(opt[:, 1], -link[:, 2])     # y down = -link z
    left = poses['stereo_left_optical'][:3, 3] - poses['stereo_right_optical'][:3, 3]
    assert np.allclose(link.T.dot(left), [0.0, 0.12, 0.0])
    assert np.allclose(poses['bumblebee2_link'], poses['stereo_right_optical'])
    cam, camo = poses['hand_camera_link'][:3, :3], poses['hand_camera_optical'][:3, :3]
    assert np.allclose(camo[:, 2], cam[:, 0])


@FAST
@given(arms, unit, unit, unit, unit, unit, unit)
def test_frame_transforms_agree_with_forward(arm, c, w, lift, boom, forearm, dummy):
    q = (lift * 0.3, (boom - 0.5) * 5.0, (forearm - 0.5) * 5.0)
    cart, waist = c * 30.0, (w - 0.5) * 6.28
    joints = {'cart_joint': cart, 'waist_joint': waist, '%s_lift_joint' % arm: q[0],
              '%s_boom_joint' % arm: q[1], '%s_forearm_joint' % arm: q[2]}
    poses = GEOM.frame_transforms(joints)
    tcp_map = poses[kin.TOOL_FRAME[arm]][:3, 3]
    tcp_base = np.linalg.inv(poses['base_link']).dot(np.append(tcp_map, 1.0))[:3]
    assert np.allclose(tcp_base, GEOM.forward(arm, *q, waist=waist), atol=1e-9)
    assert np.allclose(poses['base_link'][:3, 3], [0.0, cart, 0.0])
    tool_x = poses[kin.TOOL_FRAME[arm]][:3, 0]
    assert np.allclose(tool_x, GEOM.tool_direction(arm, q[1], q[2], waist), atol=1e-9)


@FAST
@given(arms, st.floats(0.0, 1.0), st.floats(-math.pi, math.pi), st.floats(0.0, 0.30),
       st.floats(0.0, 0.1), st.floats(-math.pi, math.pi))
def test_fk_of_ik_is_target(arm, rr, phi, lift, standoff, waist):
    """Over the whole annulus: whatever IK returns lands on the target (1e-6 m)."""
    inner, outer = GEOM.reach(standoff)
    r = inner + (outer - inner) * rr
    p = point_in_arm_frame(arm, r, phi, lift)
    c, s = math.cos(waist), math.sin(waist)
    p = np.array([c * p[0] - s * p[1], s * p[0] + c * p[1], p[2]])
    res = GEOM.inverse(arm, p, standoff=standoff, waist=waist)
    if not res.reachable:
        assert res.reason and res.joints is None
        return
    lift_q, boom, forearm = res.joints
    tcp = GEOM.forward(arm, lift_q, boom, forearm, waist=waist)
    direction = GEOM.tool_direction(arm, boom, forearm, waist)
    assert np.allclose(tcp + standoff * direction, p, atol=1e-6)
    assert GEOM._limit_reason(res.joints) == ''
    assert GEOM.clearance(arm, res.joints, kin.HOME_JOINTS[kin.OTHER_ARM[arm]], waist) \
        >= GEOM.arm_clearance


@FAST
@given(arms, st.floats(0.18, 0.649), st.floats(-math.pi / 2, math.pi / 2),
       st.floats(0.0, 0.30))
def test_ik_solves_points_inside_workspace(arm, r, phi, lift):
    """Strictly inside reach, within 90 deg of the arm's x, other arm parked: solvable."""
    p = point_in_arm_frame(arm, r, phi, lift)
    res = GEOM.inverse(arm, p)
    assert res.reachable, res.reason
    assert res.branch in kin.BRANCHES
    assert np.allclose(GEOM.forward(arm, *res.joints), p, atol=1e-6)


@FAST
@given(arms, st.floats(1e-4, 1.0), st.floats(-math.pi, math.pi), st.floats(0.0, 0.30),
       st.floats(0.0, 0.1))
def test_beyond_outer_reach_is_unreachable(arm, dr, phi, lift, standoff):
    outer = GEOM.reach(standoff)[1]
    res = GEOM.inverse(arm, point_in_arm_frame(arm, outer + dr, phi, lift), standoff=standoff)
    assert not res.reachable
    assert res.reason.startswith('beyond reach: ')
    assert res.joints is None


@FAST
@given(arms, st.floats(0.25, 0.6), st.floats(-math.pi / 2, math.pi / 2), st.floats(1e-4, 0.5))
def test_above_lift_limit_is_unreachable(arm, r, phi, dz):
    res = GEOM.inverse(arm, point_in_arm_frame(arm, r, phi, 0.30 + dz))
    assert not res.reachable
    assert 'above limit 0.30 m' in res.reason


def test_below_lift_limit_is_unreachable():
    res = GEOM.inverse('left', point_in_arm_frame('left', 0.4, 0.0, -0.05))
    assert not res.reachable
    assert res.reason == 'lift -0.05 m below limit 0.00 m'


def test_reason_texts():
    res = GEOM.inverse('left', point_in_arm_frame('left', 0.82, 0.3, 0.1))
    assert res.reason == 'beyond reach: 0.82 m > 0.65 m'
    res = GEOM.inverse('left', point_in_arm_frame('left', 0.3, 0.0, 0.35))
    assert res.reason == 'lift 0.35 m above limit 0.30 m'
    # straight behind the left arm: both branches need |boom| > 150 deg
    res = GEOM.inverse('left', point_in_arm_frame('left', 0.6, math.pi, 0.1))
    assert not res.reachable
    assert 'boom' in res.reason and 'outside [-150,150]' in res.reason


@pytest.mark.parametrize('bad', [(float('nan'), 0.0, 0.9), (0.5, float('inf'), 0.9),
                                 (0.5, 0.0, float('nan'))])
def test_nan_rejected(bad):
    res = GEOM.inverse('left', bad)
    assert not res.reachable and res.reason == 'NaN in target' and res.joints is None


def test_bad_standoff_and_arm():
    assert 'standoff' in GEOM.inverse('left', (0.5, 0.0, 0.9), standoff=-0.1).reason
    assert 'standoff' in GEOM.inverse('left', (0.5, 0.0, 0.9), standoff=float('nan')).reason
    assert 'unknown arm' in GEOM.inverse('middle', (0.5, 0.0, 0.9)).reason


def test_collision_with_other_arm_reported():
    # right arm reaching to where the left arm's tool is
    target_right = np.array([0.45, 0.0, 0.9])
    left = GEOM.inverse('left', target_right).joints
    res = GEOM.inverse('right', target_right, other_arm_joints=left)
    assert not res.reachable
    assert 'collides with left arm (clearance 0.00 m < %.2f m)' % GEOM.arm_clearance in res.reason
    # same point with the left arm parked is fine
    assert GEOM.inverse('right', target_right).reachable


def test_branch_choice_follows_current_state():
    p = point_in_arm_frame('left', 0.45, 0.2, 0.1)
    both = GEOM.inverse('left', p)
    assert len(both.candidates) == 2 and all(c.feasible for c in both.candidates)
    assert both.branch == 'elbow_left'        # outer elbow without a state
    for cand in both.candidates:
        res = GEOM.inverse('left', p, current=cand.joints)
        assert res.branch == cand.branch
        assert np.allclose(res.joints, cand.joints)


def test_elbow_branch_names():
    p = point_in_arm_frame('right', 0.45, 0.0, 0.1)
    res = GEOM.inverse('right', p)
    for cand in res.candidates:
        base, elbow, tip = GEOM.arm_points('right', *cand.joints)
        cross = (tip[0] - base[0]) * (elbow[1] - base[1]) - (tip[1] - base[1]) * (elbow[0] - base[0])
        assert (cross > 0) == (cand.branch == 'elbow_left')


def test_stretched_arm_single_candidate():
    res = GEOM.inverse('left', point_in_arm_frame('left', 0.65, 0.1, 0.1))
    assert res.reachable and len(res.candidates) == 1


def test_home_pose_within_limits_and_clear():
    for arm in kin.ARMS:
        assert GEOM._limit_reason(kin.HOME_JOINTS[arm]) == ''
        assert GEOM.forward(arm, *kin.HOME_JOINTS[arm])[0] < 0.0    # parked behind the bases
    assert GEOM.clearance('left', kin.HOME_JOINTS['left'], kin.HOME_JOINTS['right']) > 0.3


@FAST
@given(st.lists(st.floats(-1, 1), min_size=12, max_size=12))
@example([0.0, 0.0, 0.0, -1.192092896e-07, 0.0, -0.9999999999999999,
          -5.960464477539063e-08, 0.0, -1.0, 0.0, 0.0, 0.5])   # crossing, 1e-7 rad apart
def test_segment_distance_matches_sampling(v):
    p1, q1, p2, q2 = (np.array(v[i:i + 3]) for i in range(0, 12, 3))
    d = kin.segment_distance(p1, q1, p2, q2)
    t = np.linspace(0.0, 1.0, 41)
    a = p1 + np.outer(t, q1 - p1)
    b = p2 + np.outer(t, q2 - p2)
    sampled = np.min(np.linalg.norm(a[:, None, :] - b[None, :, :], axis=2))
    assert d <= sampled + 1e-9
    assert d >= sampled - 0.1   # grid step bound
