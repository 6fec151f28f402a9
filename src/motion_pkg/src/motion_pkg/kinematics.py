"""Kinematics of the dual-arm harvesting robot (pure numpy, no rospy).

Modules: kinematics_geometry holds the geometry of robot.yaml, the frame tree (URDF), forward
kinematics and the home pose; kinematics_clearance the collision check between the arms. This
module holds the inverse solution, its elbow branches and the waist search; RobotGeometry
composes the three, and the names of the other two are re-exported here.

Inverse kinematics (one arm, waist angle given): the lift sets the tool height, boom and forearm
form a planar two-link arm (boom length, forearm + tool length). The tool always points along the
forearm x axis, horizontally.

Standoff: the tool centre stops ``standoff`` metres short of the target *along the final tool
direction*, i.e. the forearm axis, extended by the standoff, passes through the target. This is
solved exactly by giving the second link the length forearm + tool + standoff and reaching the
target itself; the tool then points straight at the target (the approach direction is the final
forearm direction, not the radial direction from the boom axis). With standoff 0 the tool centre
is on the target.

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

# re-exported: every kinematics.<name> keeps working
from motion_pkg.kinematics_clearance import ArmClearance, segment_distance  # noqa: F401
from motion_pkg.kinematics_geometry import (  # noqa: F401
    ARMS, HOME_JOINTS, OPTICAL_RPY, OTHER_ARM, TOOL_FRAME, ForwardKinematics, JointDef,
    axis_angle_matrix, joint_motion, rpy_matrix, transform)

BRANCHES = ('elbow_left', 'elbow_right')
#: branch with the elbow on the side away from the other arm (preferred without a current state)
OUTER_BRANCH = {'left': 'elbow_left', 'right': 'elbow_right'}
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


def wrap_angle(a):
    """Angle in [-pi, pi)."""
    return (a + math.pi) % (2.0 * math.pi) - math.pi


class RobotGeometry(ForwardKinematics, ArmClearance):
    """Geometry, forward and inverse kinematics of the robot described by robot.yaml."""

    # ------------------------------------------------------------------ one arm, inverse
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
