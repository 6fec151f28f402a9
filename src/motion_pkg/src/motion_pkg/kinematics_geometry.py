"""Robot geometry and forward kinematics of the dual-arm harvesting robot (pure numpy, no rospy).

The geometry comes from harvest_description/config/robot.yaml; the frame tree is exactly the one of
harvest_description/urdf/harvest_robot.urdf (a test composes the URDF joints and compares):

    map -cart_joint (prismatic, +y)-> base_link -waist_joint (revolute z)-> waist_link
    waist_link -fixed (base_xyz, base_yaw)-> <arm>_arm_base
      -<arm>_lift_joint (prismatic z)-> <arm>_lift_link
      -<arm>_boom_joint (revolute z)-> <arm>_boom_link
      -<arm>_forearm_joint (revolute z, x = boom)-> <arm>_forearm_link
      -fixed (x = forearm)-> <arm>_flange -fixed (x = tool)-> left_shear_tcp / right_suction_tcp
    left_forearm_link -fixed (hand_camera xyz/rpy)-> hand_camera_link -fixed-> hand_camera_optical
    waist_link -fixed (stereo_head xyz/rpy)-> stereo_link (right eye, x forward)
      -> stereo_right_optical (same origin), stereo_left_optical (baseline to +y)
    stereo_right_optical -fixed (identity)-> bumblebee2_link

Optical frames follow REP 103: z forward (= link x), x right (= -link y), y down (= -link z).

Bumblebee2: the camera's native (Triclops) frame is left-handed (x right, y up, z forward). The
paper reverses its y axis to make it right-handed; the result, x right, y down, z forward at the
right eye, is exactly stereo_right_optical. bumblebee2_link is that frame under the paper's name
(identity transform): a point (x, y, z) in native Bumblebee2 coordinates is (x, -y, z) in
bumblebee2_link / stereo_right_optical.

Home pose (used for the other arm's clearance when its joints are unknown): lift 0, boom turned
outward to point along waist +y (left) / -y (right), forearm folded back by 135 degrees, which
parks the tool behind the arm base, out of the workspace in front of the robot (HOME_JOINTS).

ForwardKinematics is the base of kinematics.RobotGeometry, which adds the arms' clearance
(kinematics_clearance) and the inverse solution (kinematics).
"""

import math
from collections import namedtuple

import numpy as np

from harvest_description import robot_config

ARMS = ('left', 'right')
TOOL_FRAME = {'left': 'left_shear_tcp', 'right': 'right_suction_tcp'}
#: other arm for clearance checks
OTHER_ARM = {'left': 'right', 'right': 'left'}
#: park pose [lift (m), boom (rad), forearm (rad)] per arm, see module docstring
HOME_JOINTS = {'left': (0.0, math.pi / 4.0, 3.0 * math.pi / 4.0),
               'right': (0.0, -math.pi / 4.0, -3.0 * math.pi / 4.0)}
#: rotation of an optical frame in its camera link (roll, pitch, yaw)
OPTICAL_RPY = (-math.pi / 2.0, 0.0, -math.pi / 2.0)

JointDef = namedtuple('JointDef', 'name type parent child xyz rpy axis lower upper velocity')
JointDef.__doc__ = """A URDF joint: type 'fixed'/'prismatic'/'revolute', origin xyz/rpy, axis,
limits (None for fixed) and velocity limit (None for fixed)."""


def rpy_matrix(roll, pitch, yaw):
    """3x3 rotation of URDF rpy (fixed axes x, y, z): Rz(yaw) Ry(pitch) Rx(roll)."""
    cr, sr = math.cos(roll), math.sin(roll)
    cp, sp = math.cos(pitch), math.sin(pitch)
    cy, sy = math.cos(yaw), math.sin(yaw)
    return np.array([[cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr],
                     [sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr],
                     [-sp, cp * sr, cp * cr]])


def transform(xyz=(0.0, 0.0, 0.0), rpy=(0.0, 0.0, 0.0)):
    """4x4 homogeneous transform from a translation and URDF rpy."""
    t = np.eye(4)
    t[:3, :3] = rpy_matrix(*rpy)
    t[:3, 3] = xyz
    return t


def axis_angle_matrix(axis, angle):
    """4x4 rotation about a unit axis (Rodrigues)."""
    a = np.asarray(axis, dtype=float)
    a = a / np.linalg.norm(a)
    k = np.array([[0.0, -a[2], a[1]], [a[2], 0.0, -a[0]], [-a[1], a[0], 0.0]])
    t = np.eye(4)
    t[:3, :3] = np.eye(3) + math.sin(angle) * k + (1.0 - math.cos(angle)) * k.dot(k)
    return t


def joint_motion(jdef, q):
    """4x4 motion of a joint at position q (identity for fixed joints)."""
    if jdef.type == 'fixed':
        return np.eye(4)
    if jdef.type == 'prismatic':
        t = np.eye(4)
        t[:3, 3] = np.asarray(jdef.axis, dtype=float) * q
        return t
    return axis_angle_matrix(jdef.axis, q)


class ForwardKinematics(object):
    """Geometry read from robot.yaml, its frame tree and forward kinematics (the base of
    kinematics.RobotGeometry)."""

    def __init__(self, config):
        """config: the parsed robot.yaml; refused (RobotConfigError) unless it is valid."""
        robot_config.validate(config)
        robot = config['robot']
        self.config = config
        self.track_axis = tuple(float(v) for v in robot['track']['axis'])
        self.track_limits = (float(robot['track']['min']), float(robot['track']['max']))
        self.waist_height = float(robot['waist'].get('height', 0.0))
        self.waist_limits = (float(robot['waist']['min']), float(robot['waist']['max']))
        self.arm_base_xyz = {a: tuple(float(v) for v in robot['arms'][a]['base_xyz']) for a in ARMS}
        self.arm_base_yaw = {a: float(robot['arms'][a]['base_yaw']) for a in ARMS}
        # (min, max) radius of the fruit an arm's tool takes, None: any (robot.yaml, optional)
        self.fruit_radius = {a: (float(robot['arms'][a]['fruit_radius']['min']),
                                 float(robot['arms'][a]['fruit_radius']['max']))
                             if 'fruit_radius' in robot['arms'][a] else None for a in ARMS}
        lengths = robot['link_lengths']
        self.boom = float(lengths['boom'])
        self.forearm = float(lengths['forearm'])
        self.tool = float(lengths['tool'])
        lim = robot['joint_limits']
        self.limits = {j: (float(lim[j]['min']), float(lim[j]['max']))
                       for j in ('lift', 'boom', 'forearm')}
        self.arm_clearance = float(robot['arm_clearance'])
        self.hand_camera_xyz = tuple(float(v) for v in robot['hand_camera']['xyz'])
        self.hand_camera_rpy = tuple(float(v) for v in robot['hand_camera']['rpy'])
        self.stereo_xyz = tuple(float(v) for v in robot['stereo_head']['xyz'])
        self.stereo_rpy = tuple(float(v) for v in robot['stereo_head']['rpy'])
        self.stereo_baseline = float(robot['stereo_head']['baseline'])
        speed = config.get('motion', {}).get('speed', {})
        self.speed = {k: float(v) for k, v in speed.items()}
        self.joints = self._joint_defs()
        self._by_child = {j.child: j for j in self.joints}

    @classmethod
    def from_yaml(cls, path):
        """Load robot.yaml from a file path (RobotConfigError naming the file and field if bad)."""
        return cls(robot_config.load(path))

    # ------------------------------------------------------------------ frame tree
    def _joint_defs(self):
        sp = self.speed
        defs = [JointDef('cart_joint', 'prismatic', 'map', 'base_link', (0.0, 0.0, 0.0),
                         (0.0, 0.0, 0.0), self.track_axis, self.track_limits[0],
                         self.track_limits[1], sp.get('cart')),
                JointDef('waist_joint', 'revolute', 'base_link', 'waist_link',
                         (0.0, 0.0, self.waist_height), (0.0, 0.0, 0.0), (0.0, 0.0, 1.0),
                         self.waist_limits[0], self.waist_limits[1], sp.get('waist'))]
        z = (0.0, 0.0, 1.0)
        zero = (0.0, 0.0, 0.0)
        for arm in ARMS:
            defs += [
                JointDef('%s_arm_base_joint' % arm, 'fixed', 'waist_link', '%s_arm_base' % arm,
                         self.arm_base_xyz[arm], (0.0, 0.0, self.arm_base_yaw[arm]), None,
                         None, None, None),
                JointDef('%s_lift_joint' % arm, 'prismatic', '%s_arm_base' % arm,
                         '%s_lift_link' % arm, zero, zero, z, self.limits['lift'][0],
                         self.limits['lift'][1], sp.get('lift')),
                JointDef('%s_boom_joint' % arm, 'revolute', '%s_lift_link' % arm,
                         '%s_boom_link' % arm, zero, zero, z, self.limits['boom'][0],
                         self.limits['boom'][1], sp.get('boom')),
                JointDef('%s_forearm_joint' % arm, 'revolute', '%s_boom_link' % arm,
                         '%s_forearm_link' % arm, (self.boom, 0.0, 0.0), zero, z,
                         self.limits['forearm'][0], self.limits['forearm'][1],
                         sp.get('forearm')),
                JointDef('%s_flange_joint' % arm, 'fixed', '%s_forearm_link' % arm,
                         '%s_flange' % arm, (self.forearm, 0.0, 0.0), zero, None, None, None,
                         None),
                JointDef('%s_tcp_joint' % arm, 'fixed', '%s_flange' % arm, TOOL_FRAME[arm],
                         (self.tool, 0.0, 0.0), zero, None, None, None, None)]
        defs += [
            JointDef('hand_camera_joint', 'fixed', 'left_forearm_link', 'hand_camera_link',
                     self.hand_camera_xyz, self.hand_camera_rpy, None, None, None, None),
            JointDef('hand_camera_optical_joint', 'fixed', 'hand_camera_link',
                     'hand_camera_optical', zero, OPTICAL_RPY, None, None, None, None),
            JointDef('stereo_joint', 'fixed', 'waist_link', 'stereo_link', self.stereo_xyz,
                     self.stereo_rpy, None, None, None, None),
            JointDef('stereo_right_optical_joint', 'fixed', 'stereo_link',
                     'stereo_right_optical', zero, OPTICAL_RPY, None, None, None, None),
            JointDef('stereo_left_optical_joint', 'fixed', 'stereo_link',
                     'stereo_left_optical', (0.0, self.stereo_baseline, 0.0), OPTICAL_RPY,
                     None, None, None, None),
            # the paper's y-reversed Bumblebee2 frame = stereo_right_optical (module docstring)
            JointDef('bumblebee2_joint', 'fixed', 'stereo_right_optical', 'bumblebee2_link',
                     zero, zero, None, None, None, None)]
        return defs

    def frame_names(self):
        """All frames, root ('map') first, parents before children."""
        return ['map'] + [j.child for j in self.joints]

    def frame_transforms(self, joints=None):
        """Pose in `map` (4x4) of every frame; joints: {URDF joint name: position}, missing = 0."""
        joints = joints or {}
        poses = {'map': np.eye(4)}
        for j in self.joints:
            q = float(joints.get(j.name, 0.0))
            poses[j.child] = poses[j.parent].dot(transform(j.xyz, j.rpy)).dot(joint_motion(j, q))
        return poses

    # ------------------------------------------------------------------ one arm, planar model
    def _arm_base(self, arm, waist=0.0):
        """(xy of the boom axis, yaw, z of lift zero) of an arm in base_link."""
        bx, by, bz = self.arm_base_xyz[arm]
        c, s = math.cos(waist), math.sin(waist)
        return (np.array([c * bx - s * by, s * bx + c * by]), waist + self.arm_base_yaw[arm],
                self.waist_height + bz)

    def arm_points(self, arm, lift, boom, forearm, waist=0.0, extension=0.0):
        """Boom axis, elbow (forearm axis) and tool centre (+extension) in base_link, 3-D."""
        base, yaw, z0 = self._arm_base(arm, waist)
        z = z0 + lift
        a1 = yaw + boom
        a2 = a1 + forearm
        elbow = base + self.boom * np.array([math.cos(a1), math.sin(a1)])
        tip = elbow + (self.forearm + self.tool + extension) * np.array([math.cos(a2), math.sin(a2)])
        return (np.array([base[0], base[1], z]), np.array([elbow[0], elbow[1], z]),
                np.array([tip[0], tip[1], z]))

    def forward(self, arm, lift, boom, forearm, waist=0.0):
        """Tool centre xyz in base_link (waist angle default 0)."""
        return self.arm_points(arm, lift, boom, forearm, waist)[2]

    def tool_direction(self, arm, boom, forearm, waist=0.0):
        """Unit horizontal direction (base_link) the tool points to."""
        a = waist + self.arm_base_yaw[arm] + boom + forearm
        return np.array([math.cos(a), math.sin(a), 0.0])

    def reach(self, standoff=0.0):
        """(inner, outer) horizontal reach of the tool centre from the boom axis."""
        l2 = self.forearm + self.tool + standoff
        return abs(self.boom - l2), self.boom + l2

    def home(self, arm):
        """Park joints (lift, boom, forearm) of an arm."""
        return HOME_JOINTS[arm]
