"""Kinematics of the dual-arm harvesting robot (pure numpy, no rospy).

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

Inverse kinematics (one arm, waist angle given): the lift sets the tool height, boom and forearm
form a planar two-link arm (boom length, forearm + tool length). The tool always points along the
forearm x axis, horizontally.

Standoff: the tool centre stops ``standoff`` metres short of the target *along the final tool
direction*, i.e. the forearm axis, extended by the standoff, passes through the target. This is
solved exactly by giving the second link the length forearm + tool + standoff and reaching the
target itself; the tool then points straight at the target (the approach direction is the final
forearm direction, not the radial direction from the boom axis). With standoff 0 the tool centre
is on the target.

Home pose (used for the other arm's clearance when its joints are unknown): lift 0, boom turned
outward to point along waist +y (left) / -y (right), forearm folded back by 135 degrees, which
parks the tool behind the arm base, out of the workspace in front of the robot (HOME_JOINTS).

Waist (RobotGeometry.inverse_waist): a target out of the arm's reach at the current waist angle
may come into it when the waist turns (both arms ride on the waist). The search tries the current
angle first (then the answer is exactly inverse()'s), then angles ever further from it on a grid of
WAIST_STEP within the waist limits; the first angle whose neighbours WAIST_MARGIN to either side are
feasible too wins, so the smallest rotation is taken and the drive's position tolerance cannot put
the target back out of reach. With a second target for the other arm (the cutting hand's peduncle
when the suction arm is solved) an angle counts only when the other arm reaches that target too,
with this arm at its solution (the clearance check of both arms stays valid: the arms turn together,
so their relative pose does not depend on the waist).
"""

import math
from collections import namedtuple

import numpy as np

from harvest_description import robot_config

ARMS = ('left', 'right')
TOOL_FRAME = {'left': 'left_shear_tcp', 'right': 'right_suction_tcp'}
BRANCHES = ('elbow_left', 'elbow_right')
#: other arm for clearance checks
OTHER_ARM = {'left': 'right', 'right': 'left'}
#: branch with the elbow on the side away from the other arm (preferred without a current state)
OUTER_BRANCH = {'left': 'elbow_left', 'right': 'elbow_right'}
#: park pose [lift (m), boom (rad), forearm (rad)] per arm, see module docstring
HOME_JOINTS = {'left': (0.0, math.pi / 4.0, 3.0 * math.pi / 4.0),
               'right': (0.0, -math.pi / 4.0, -3.0 * math.pi / 4.0)}
#: rotation of an optical frame in its camera link (roll, pitch, yaw)
OPTICAL_RPY = (-math.pi / 2.0, 0.0, -math.pi / 2.0)
#: two candidates closer than this (rad) are the same solution (stretched arm)
_SAME_SOLUTION_TOL = 1e-9

#: waist search (inverse_waist): grid step and margin kept to the edge of the feasible range (rad)
WAIST_STEP = math.radians(1.0)
WAIST_MARGIN = math.radians(2.0)

IKResult = namedtuple('IKResult', 'reachable joints branch reason candidates')
IKResult.__doc__ = """Result of RobotGeometry.inverse.

reachable: bool; joints: (lift, boom, forearm) or None; branch: 'elbow_left'/'elbow_right'
or ''; reason: '' or why unreachable; candidates: list of IKCandidate checked."""

IKCandidate = namedtuple('IKCandidate', 'branch joints feasible reason clearance')
IKCandidate.__doc__ = """One IK branch: joints (lift, boom, forearm), feasible bool, reason text,
clearance (m) to the other arm's forearm+tool segment (nan if not computed)."""

WaistSolution = namedtuple('WaistSolution', 'ik waist moved other')
WaistSolution.__doc__ = """Result of RobotGeometry.inverse_waist.

ik: IKResult of this arm at `waist` (the current angle when nothing reaches); waist: the waist
angle (rad) the joints are for; moved: True when it differs from the current angle; other:
IKResult of the other arm at its target (None when no other target was given)."""

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


def wrap_angle(a):
    """Angle in [-pi, pi)."""
    return (a + math.pi) % (2.0 * math.pi) - math.pi


def segment_distance(p1, q1, p2, q2):
    """Shortest distance between 3-D segments p1-q1 and p2-q2."""
    p1, q1, p2, q2 = (np.asarray(v, dtype=float) for v in (p1, q1, p2, q2))
    d1, d2, r = q1 - p1, q2 - p2, p1 - p2
    a, e, f = d1.dot(d1), d2.dot(d2), d2.dot(r)
    eps = 1e-15
    if a <= eps and e <= eps:
        s, t = 0.0, 0.0                # two (near-)points: the endpoint distances below decide
    elif a <= eps:
        s, t = 0.0, min(max(f / e, 0.0), 1.0)
    else:
        c = d1.dot(r)
        if e <= eps:
            t, s = 0.0, min(max(-c / a, 0.0), 1.0)
        else:
            b = d1.dot(d2)
            denom = a * e - b * b
            # parallel segments have denom 0: any other pair of directions gets the closed form
            # (near-parallel segments may cross), whose clamped s and t always name real points
            # of both segments; the endpoint distances below cover the parallel case exactly
            s = min(max((b * f - c * e) / denom, 0.0), 1.0) if denom > 0.0 else 0.0
            t = (b * s + f) / e
            if t < 0.0:
                t, s = 0.0, min(max(-c / a, 0.0), 1.0)
            elif t > 1.0:
                t, s = 1.0, min(max((b - c) / a, 0.0), 1.0)
    best = float(np.linalg.norm((p1 + d1 * s) - (p2 + d2 * t)))
    # near-degenerate (sub-micrometre) segments lose precision in the closed form: the
    # endpoint-to-segment distances bound the answer exactly
    return min(best, _point_segment(p1, p2, q2), _point_segment(q1, p2, q2),
               _point_segment(p2, p1, q1), _point_segment(q2, p1, q1))


def _point_segment(p, a, b):
    """Distance from point p to segment a-b."""
    d = b - a
    dd = d.dot(d)
    t = 0.0 if dd <= 0.0 else min(max((p - a).dot(d) / dd, 0.0), 1.0)
    return float(np.linalg.norm(p - (a + d * t)))


class RobotGeometry(object):
    """Geometry, forward and inverse kinematics of the robot described by robot.yaml."""

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

    def clearance(self, arm, joints, other_joints, waist=0.0):
        """Distance between this arm's and the other arm's forearm+tool segments."""
        _, e1, t1 = self.arm_points(arm, *joints, waist=waist)
        _, e2, t2 = self.arm_points(OTHER_ARM[arm], *other_joints, waist=waist)
        return segment_distance(e1, t1, e2, t2)

    def _limit_reason(self, joints):
        lift, boom, forearm = joints
        lo, hi = self.limits['lift']
        if lift > hi + 1e-12:
            return 'lift %.2f m above limit %.2f m' % (lift, hi)
        if lift < lo - 1e-12:
            return 'lift %.2f m below limit %.2f m' % (lift, lo)
        for name, q in (('boom', boom), ('forearm', forearm)):
            lo, hi = self.limits[name]
            if q < lo - 1e-12 or q > hi + 1e-12:
                return '%s %.0f deg outside [%.0f,%.0f]' % (
                    name, math.degrees(q), math.degrees(lo), math.degrees(hi))
        return ''

    def inverse(self, arm, xyz, standoff=0.0, other_arm_joints=None, current=None, waist=0.0):
        """Joints (lift, boom, forearm) putting the tool centre at xyz (base_link).

        standoff: stop this far short of xyz along the final tool direction (>= 0).
        other_arm_joints: (lift, boom, forearm) of the other arm for the clearance check
        (default: its home pose). current: this arm's joints; the feasible branch closest to
        it is chosen (default: the OUTER_BRANCH elbow). waist: waist angle (rad).
        """
        if arm not in ARMS:
            return IKResult(False, None, '', 'unknown arm %r (left/right)' % (arm,), [])
        try:
            p = np.asarray(xyz, dtype=float).reshape(3)
            standoff = float(standoff)
            waist = float(waist)
        except (TypeError, ValueError):
            return IKResult(False, None, '', 'target must be 3 numbers', [])
        if not np.all(np.isfinite(p)):
            return IKResult(False, None, '', 'NaN in target', [])
        if not math.isfinite(standoff) or standoff < 0.0:
            return IKResult(False, None, '', 'standoff %r must be >= 0' % standoff, [])
        if not math.isfinite(waist):
            return IKResult(False, None, '', 'NaN in waist angle', [])
        other = tuple(other_arm_joints) if other_arm_joints is not None else \
            HOME_JOINTS[OTHER_ARM[arm]]
        cur = tuple(current) if current is not None else ()
        if not all(math.isfinite(v) for v in other + cur):
            return IKResult(False, None, '', 'NaN in current joint states', [])

        base, yaw, z0 = self._arm_base(arm, waist)
        lift = p[2] - z0
        d = p[:2] - base
        r = math.hypot(d[0], d[1])
        l1, l2 = self.boom, self.forearm + self.tool + standoff
        inner, outer = abs(l1 - l2), l1 + l2
        if r > outer + 1e-12:
            return IKResult(False, None, '', 'beyond reach: %.2f m > %.2f m' % (r, outer), [])
        if r < inner - 1e-12:
            return IKResult(False, None, '', 'inside inner reach: %.2f m < %.2f m' % (r, inner),
                            [])
        c2 = (r * r - l1 * l1 - l2 * l2) / (2.0 * l1 * l2)
        q2 = math.acos(min(1.0, max(-1.0, c2)))
        phi = math.atan2(d[1], d[0]) - yaw
        candidates = []
        # forearm turned clockwise (negative) puts the elbow left of the base->target line
        for branch, f in (('elbow_left', -q2), ('elbow_right', q2)):
            if candidates and abs(f - candidates[0].joints[2]) < _SAME_SOLUTION_TOL:
                continue          # stretched or folded arm: both branches coincide
            b = wrap_angle(phi - math.atan2(l2 * math.sin(f), l1 + l2 * math.cos(f)))
            joints = (float(lift), float(b), float(f))
            reason = self._limit_reason(joints)
            clear = float('nan')
            if not reason:
                clear = self.clearance(arm, joints, other, waist)
                if clear < self.arm_clearance:
                    reason = 'collides with %s arm (clearance %.2f m < %.2f m)' % (
                        OTHER_ARM[arm], clear, self.arm_clearance)
            candidates.append(IKCandidate(branch, joints, not reason, reason, clear))
        feasible = [c for c in candidates if c.feasible]
        if not feasible:
            reasons = []
            for c in candidates:
                if c.reason not in reasons:
                    reasons.append(c.reason)
            if len(reasons) == 1:
                text = reasons[0]
            else:
                text = '; '.join('%s: %s' % (c.branch, c.reason) for c in candidates)
            return IKResult(False, None, '', text, candidates)
        if current is None:
            # no state known: prefer the elbow on the outer side, away from the other arm
            best = min(feasible, key=lambda c: c.branch != OUTER_BRANCH[arm])
        else:
            best = min(feasible, key=lambda c: sum(abs(a - b) for a, b in zip(c.joints, cur)))
        return IKResult(True, best.joints, best.branch, '', candidates)

    # ------------------------------------------------------------------ waist
    def _waist_feasible(self, arm, xyz, standoff, other_arm_joints, current, waist, other_xyz,
                        other_standoff, other_current):
        """(ik, other ik) at one waist angle; ik.reachable and other.reachable say if it works."""
        ik = self.inverse(arm, xyz, standoff, other_arm_joints, current, waist)
        if other_xyz is None or not ik.reachable:
            return ik, None
        return ik, self.inverse(OTHER_ARM[arm], other_xyz, other_standoff, ik.joints,
                                other_current, waist)

    def _waist_bound(self, arm, xyz, standoff):
        """False when no waist angle can bring xyz into the arm's reach (distance and height
        do not depend on the waist): skips a pointless search."""
        bx, by, bz = self.arm_base_xyz[arm]
        rho = math.hypot(bx, by)
        d = math.hypot(xyz[0], xyz[1])
        inner, outer = self.reach(standoff)
        lift = xyz[2] - self.waist_height - bz
        lo, hi = self.limits['lift']
        return (d - rho <= outer + 1e-9 and d + rho >= inner - 1e-9 and
                lo - 1e-12 <= lift <= hi + 1e-12)

    def inverse_waist(self, arm, xyz, standoff=0.0, other_arm_joints=None, current=None,
                      waist=0.0, other_xyz=None, other_standoff=0.0, other_current=None,
                      step=WAIST_STEP, margin=WAIST_MARGIN):
        """IK with the waist free to turn: a WaistSolution (module docstring).

        xyz, standoff, other_arm_joints, current: as inverse(); waist: the current waist angle.
        other_xyz / other_standoff / other_current: a target the other arm must reach too at
        the same waist angle (None: this arm only). At the current angle the answer is exactly
        inverse()'s when it reaches (and the other arm reaches its target); otherwise the
        smallest rotation within the waist limits that keeps `margin` to the edge of the
        feasible range. When no angle serves both targets but this arm reaches at the current
        angle, that answer stands (`other` says why the other arm cannot). When nothing works,
        ik is the current angle's, unreachable, its reason followed by why the waist does not
        help.
        """
        try:
            waist = float(waist)
        except (TypeError, ValueError):
            waist = float('nan')
        if not math.isfinite(waist):
            return WaistSolution(IKResult(False, None, '', 'NaN in waist angle', []), waist,
                                 False, None)
        ik, other = self._waist_feasible(arm, xyz, standoff, other_arm_joints, current, waist,
                                         other_xyz, other_standoff, other_current)
        if ik.reachable and (other is None or other.reachable):
            return WaistSolution(ik, waist, False, other)
        try:
            p = np.asarray(xyz, dtype=float).reshape(3)
            bad = arm not in ARMS or not np.all(np.isfinite(p)) or \
                not float(standoff) >= 0.0 or not math.isfinite(float(standoff))
            if other_xyz is not None:
                q = np.asarray(other_xyz, dtype=float).reshape(3)
                bad = bad or not np.all(np.isfinite(q)) or not float(other_standoff) >= 0.0 \
                    or not math.isfinite(float(other_standoff))
        except (TypeError, ValueError):
            bad = True
        if bad:
            if ik.reachable:        # only the other target is bad
                ik = IKResult(False, None, '', '%s arm: %s' % (OTHER_ARM[arm], other.reason),
                              ik.candidates)
            return WaistSolution(ik, waist, False, other)     # invalid input: no search
        lo, hi = self.waist_limits
        found = None
        ok = self._waist_bound(arm, p, standoff)
        if ok and other_xyz is not None:
            ok = self._waist_bound(OTHER_ARM[arm], np.asarray(other_xyz, dtype=float).reshape(3),
                                   other_standoff)
        if ok and step > 0.0:
            cache = {}

            def works(k):
                if k not in cache:
                    w = waist + k * step
                    if w < lo - 1e-12 or w > hi + 1e-12:
                        cache[k] = None
                    else:
                        a, b = self._waist_feasible(arm, p, standoff, other_arm_joints, current,
                                                    w, other_xyz, other_standoff, other_current)
                        cache[k] = (a, b) if a.reachable and (b is None or b.reachable) else None
                return cache[k]

            m = max(0, int(math.ceil(margin / step - 1e-9)))
            kmax = int(math.ceil((hi - lo) / step)) + 1
            for k in range(1, kmax + 1):
                for kk in (k, -k):
                    if works(kk) is not None and all(
                            works(kk + j) is not None for j in (-m, m) if j):
                        found = kk
                        break
                if found is not None:
                    break
        if found is not None:
            a, b = cache[found]
            return WaistSolution(a, waist + found * step, True, b)
        if ik.reachable:
            # this arm reaches where the waist is and no angle serves both: its own answer
            # stands (the other arm's failure shows in `other`, as without the waist)
            return WaistSolution(ik, waist, False, other)
        text = '%s; no waist angle in [%.0f, %.0f] deg reaches %s' % (
            ik.reason, math.degrees(lo), math.degrees(hi),
            'it' if other_xyz is None else 'both targets')
        return WaistSolution(IKResult(False, None, '', text, ik.candidates), waist, False, other)
