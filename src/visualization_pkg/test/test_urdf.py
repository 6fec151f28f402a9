"""The committed URDF is what generate_urdf makes of robot.yaml, is valid for check_urdf and
agrees with motion_pkg.kinematics (no ROS master needed)."""

import math
import os
import shutil
import subprocess
import sys
import xml.etree.ElementTree as ET

import numpy as np
import pytest
import yaml

HERE = os.path.dirname(os.path.abspath(__file__))
PKG = os.path.dirname(HERE)
sys.path.insert(0, os.path.join(PKG, 'src'))

from harvest_description.urdf_generator import urdf_from_yaml  # noqa: E402
from motion_pkg import kinematics as kin  # noqa: E402

DESCRIPTION = os.path.join(os.path.dirname(PKG), 'harvest_description')
ROBOT_YAML = os.path.join(DESCRIPTION, 'config', 'robot.yaml')
URDF = os.path.join(DESCRIPTION, 'urdf', 'harvest_robot.urdf')
GEOM = kin.RobotGeometry.from_yaml(ROBOT_YAML)


def parse_urdf(path):
    """{child link: (joint name, type, parent, 4x4 origin, axis, limit attrs)} and the root."""
    root = ET.parse(path).getroot()
    joints = {}
    for j in root.findall('joint'):
        origin = j.find('origin')
        xyz = [float(v) for v in origin.get('xyz', '0 0 0').split()]
        rpy = [float(v) for v in origin.get('rpy', '0 0 0').split()]
        axis = j.find('axis')
        limit = j.find('limit')
        joints[j.find('child').get('link')] = (
            j.get('name'), j.get('type'), j.find('parent').get('link'), kin.transform(xyz, rpy),
            [float(v) for v in axis.get('xyz').split()] if axis is not None else None,
            dict(limit.attrib) if limit is not None else None)
    links = [link.get('name') for link in root.findall('link')]
    roots = [name for name in links if name not in joints]
    return joints, roots, links


JOINTS, ROOTS, LINKS = parse_urdf(URDF)


def urdf_pose(link, q):
    """Pose of a link in the root, composing the parsed URDF joints (independent of kinematics)."""
    if link not in JOINTS:
        return np.eye(4)
    name, jtype, parent, origin, axis, _ = JOINTS[link]
    motion = np.eye(4)
    value = q.get(name, 0.0)
    if jtype == 'prismatic':
        motion[:3, 3] = np.array(axis) * value
    elif jtype in ('revolute', 'continuous'):
        motion = kin.axis_angle_matrix(axis, value)
    return urdf_pose(parent, q).dot(origin).dot(motion)


def test_committed_urdf_is_generated_from_robot_yaml():
    with open(URDF) as f:
        assert f.read() == urdf_from_yaml(ROBOT_YAML), \
            'urdf/harvest_robot.urdf is stale: run scripts/generate_urdf'


def test_generate_urdf_script_check_mode():
    script = os.path.join(DESCRIPTION, 'scripts', 'generate_urdf')
    assert subprocess.call([sys.executable, script, '--check']) == 0


@pytest.mark.skipif(shutil.which('check_urdf') is None, reason='liburdfdom-tools not installed')
def test_check_urdf_accepts_it():
    out = subprocess.run(['check_urdf', URDF], stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                         universal_newlines=True, timeout=30)
    assert out.returncode == 0, out.stdout
    assert 'Successfully Parsed XML' in out.stdout
    assert 'root Link: map' in out.stdout


def test_same_tree_as_kinematics():
    assert ROOTS == ['map']
    assert set(LINKS) == set(GEOM.frame_names())
    for j in GEOM.joints:
        name, jtype, parent = JOINTS[j.child][:3]
        assert (name, jtype, parent) == (j.name, j.type, j.parent)


def test_limits_and_speeds_from_robot_yaml():
    with open(ROBOT_YAML) as f:
        cfg = yaml.load(f, Loader=yaml.SafeLoader)
    speed = cfg['motion']['speed']
    lim = cfg['robot']['joint_limits']
    moving = {j[0]: j[5] for j in JOINTS.values() if j[1] != 'fixed'}
    assert set(moving) == {'cart_joint', 'waist_joint'} | {
        '%s_%s_joint' % (a, k) for a in kin.ARMS for k in ('lift', 'boom', 'forearm')}
    for arm in kin.ARMS:
        for k in ('lift', 'boom', 'forearm'):
            attrs = moving['%s_%s_joint' % (arm, k)]
            assert float(attrs['lower']) == lim[k]['min']
            assert float(attrs['upper']) == lim[k]['max']
            assert float(attrs['velocity']) == speed[k]
    assert float(moving['cart_joint']['velocity']) == speed['cart']
    assert float(moving['waist_joint']['upper']) == cfg['robot']['waist']['max']


def test_fk_matches_urdf_chain_for_random_joints():
    rng = np.random.RandomState(7)
    movable = [j for j in GEOM.joints if j.type != 'fixed']
    for _ in range(200):
        q = {j.name: rng.uniform(j.lower, j.upper) for j in movable}
        poses = GEOM.frame_transforms(q)
        for frame in GEOM.frame_names():
            assert np.allclose(poses[frame], urdf_pose(frame, q), atol=1e-9), frame
        base = np.linalg.inv(poses['base_link'])
        for arm in kin.ARMS:
            aq = [q['%s_%s_joint' % (arm, k)] for k in ('lift', 'boom', 'forearm')]
            tcp = base.dot(urdf_pose(kin.TOOL_FRAME[arm], q))[:3, 3]
            assert np.allclose(tcp, GEOM.forward(arm, *aq, waist=q['waist_joint']), atol=1e-9)


def test_camera_frames():
    q = {'left_boom_joint': 0.3, 'left_forearm_joint': -0.4, 'left_lift_joint': 0.1}
    cam = urdf_pose('hand_camera_optical', q)
    fore = urdf_pose('left_forearm_link', q)
    assert np.allclose(cam[:3, 2], fore[:3, 0])         # looks along the forearm
    assert np.allclose(fore[:3, :3].T.dot(cam[:3, 3] - fore[:3, 3]), [0.22, 0.0, -0.06])
    left, right = urdf_pose('stereo_left_optical', {}), urdf_pose('stereo_right_optical', {})
    assert np.allclose(right[:3, 3], [-0.05, 0.0, 1.00])
    assert np.allclose(left[:3, 3] - right[:3, 3], [0.0, 0.12, 0.0])
    assert np.allclose(right[:3, :3], [[0, 0, 1], [-1, 0, 0], [0, -1, 0]], atol=1e-12)
    assert math.isclose(np.linalg.det(urdf_pose('bumblebee2_link', {})[:3, :3]), 1.0)
