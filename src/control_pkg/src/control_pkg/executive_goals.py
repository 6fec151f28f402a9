"""Goals the executive sends and what it reads from results: pure functions of messages.

No rospy here: every function takes and returns messages or plain values, so the executive's
decisions about goals and results are unit-tested without a master (test/test_executive_goals.py).
The state machine (executive.py) wires them into its SimpleActionStates.
"""
import copy
import math

from actionlib_msgs.msg import GoalStatus
from geometry_msgs.msg import PointStamped
from trajectory_msgs.msg import JointTrajectoryPoint

from harvest_msgs.msg import (KinematicsGoal, MoveRobotGoal, TomatoScanGoal, VisualServoGoal)
from control_pkg.mission import distance

ARM_RIGHT = False   # MoveRobot/Kinematics `arm`: false = right (suction) arm
ARM_LEFT = True     # true = left (cutting) arm
#: m from the fruit top to the cut point when the suction goal asks the kinematics for a waist
#: angle that serves the cutting hand too (executive.yaml `peduncle_gap`, its default)
PEDUNCLE_GAP = 0.01

# Waist: the suction goal lets the kinematics turn the waist (solve_waist) to an angle where the
# cutting hand reaches the peduncle too; a result that asks for it (move_waist) comes out of
# kinematics_solution as [lift, boom, forearm, waist], and move_goal turns the waist with the arm
# for such a 4-value joint goal. Every other goal keeps the waist where it is (the fruit is held).


# --- points and targets ------------------------------------------------------------------------
def located(tomato, frame):
    """(x, y, z) of a tomato located in `frame` with a finite point and a radius, else None."""
    p = tomato.pick_point.point
    if tomato.pick_point.header.frame_id != frame or not tomato.radius > 0.0 or \
            not all(math.isfinite(v) for v in (p.x, p.y, p.z)):
        return None
    return (p.x, p.y, p.z)


def point_goal(point_stamped, dx=0.0, dy=0.0, dz=0.0):
    """A copy of a PointStamped moved by (dx, dy, dz) in its own frame."""
    out = PointStamped()
    out.header = point_stamped.header
    out.point.x = point_stamped.point.x + dx
    out.point.y = point_stamped.point.y + dy
    out.point.z = point_stamped.point.z + dz
    return out


def joint_point(positions):
    return JointTrajectoryPoint(positions=list(positions))


def scene_of(tomatoes, frame):
    """(id, (x, y, z), radius) of every tomato of a scan located in `frame`."""
    return [(t.id, located(t, frame), t.radius) for t in tomatoes if located(t, frame) is not None]


def pickable_in_order(tomatoes):
    """The pickable tomatoes of a scan in their picking order."""
    return sorted([t for t in tomatoes if t.pickable], key=lambda t: t.pick_order)


def pulled(target, pull):
    """The target as it is once the suction arm has drawn it out by `pull` (x, y, z)."""
    moved = copy.deepcopy(target)
    moved.pick_point = point_goal(target.pick_point, *pull)
    return moved


def target_after_pull(target, pull, pull_goal):
    """The target where the solved pull will leave it (as it is when no pull was solved:
    `pull_goal` empty)."""
    return pulled(target, pull) if pull_goal else target


# --- goals -------------------------------------------------------------------------------------
def suction_kinematics_goal(target, peduncle_gap=PEDUNCLE_GAP, waist=True):
    """Right arm: the suction sleeve on the fruit surface that faces the arm. Out of reach where
    the waist is, the waist may turn (`waist` False: it may not, e.g. while the left arm works
    elsewhere), to an angle where the cutting hand reaches the peduncle (`peduncle_gap` above
    the fruit's top) too."""
    if not waist:
        return KinematicsGoal(target=target.pick_point, arm=ARM_RIGHT,
                              standoff=float(target.radius))
    return KinematicsGoal(target=target.pick_point, arm=ARM_RIGHT, standoff=float(target.radius),
                          solve_waist=True, check_other=True,
                          other_target=point_goal(target.pick_point,
                                                  dz=target.radius + peduncle_gap),
                          other_standoff=0.0)


def cutting_kinematics_goal(target, peduncle_gap, approach):
    """Left arm: the cutting hand `approach` short of the peduncle, `peduncle_gap` above the
    fruit's top; the visual servo does the last centimetres."""
    return KinematicsGoal(target=point_goal(target.pick_point, dz=target.radius + peduncle_gap),
                          arm=ARM_LEFT, standoff=approach)


def cut_check_kinematics_goal(target, peduncle_gap, approach):
    """The cutting hand's goal of the check before suction (`check_cut_before_suction`): like
    cutting_kinematics_goal, but the waist may turn, to an angle where the suction arm reaches
    the fruit too, so a fruit only a turn of the waist brings in reach is not skipped. Only
    whether it is reachable counts: nothing moves on this solution."""
    goal = cutting_kinematics_goal(target, peduncle_gap, approach)
    goal.solve_waist = True
    goal.check_other = True
    goal.other_target = target.pick_point
    goal.other_standoff = float(target.radius)
    return goal


def pull_kinematics_goal(target, pull):
    """Right arm: the held fruit drawn out by `pull`."""
    return KinematicsGoal(target=point_goal(target.pick_point, *pull), arm=ARM_RIGHT,
                          standoff=float(target.radius))


def move_goal(arm, positions):
    """[lift, boom, forearm] of an arm; a 4th value turns the waist there in the same move."""
    positions = list(positions)
    if len(positions) == 4:
        return MoveRobotGoal(target_joint=joint_point(positions[:3]), arm=arm, move_waist=True,
                             waist=float(positions[3]))
    return MoveRobotGoal(target_joint=joint_point(positions), arm=arm)


def waist_goal(angle):
    """The waist alone to `angle` (rad), both arms where they are."""
    return MoveRobotGoal(move_waist=True, waist=float(angle))


def servo_goal(target):
    return VisualServoGoal(target=target.pick_point, target_radius=float(target.radius))


def scan_goal(picking_point, frame):
    return TomatoScanGoal(picking_point=int(picking_point), target_frame=frame)


def held_scan_goal(frame):
    """A scan of the fruit held up by the suction arm (no picking point)."""
    return TomatoScanGoal(picking_point=-1, target_frame=frame)


# --- results -----------------------------------------------------------------------------------
#: goal states of an action server that has not finished the goal yet
RUNNING_STATES = (GoalStatus.PENDING, GoalStatus.ACTIVE, GoalStatus.PREEMPTING,
                  GoalStatus.RECALLING)


def running_goals(status_array):
    """The ids of the goals an action server's status message (actionlib_msgs/GoalStatusArray)
    lists as not finished yet, whoever sent them."""
    return [s.goal_id.id for s in status_array.status_list if s.status in RUNNING_STATES]


def succeeded(status):
    return status == GoalStatus.SUCCEEDED


def self_test_failure(result):
    """Why the self-test failed (text), or None when it passed or gave no result."""
    if result is None or result.success:
        return None
    reasons = ['%s: %s' % (c, r) for c, r in zip(result.failed, result.reasons)]
    return '; '.join(reasons) or result.message


def kinematics_solution(result):
    """(joint positions, None) when the target is reachable, (None, reason) when not,
    (None, None) without a result. The positions are [lift, boom, forearm], with the waist
    angle as a 4th value when the solution needs the waist turned (move_goal moves it)."""
    if result is None:
        return None, None
    if not result.reachable:
        return None, result.reason
    joints = list(result.joint_goal.positions)
    if result.move_waist:
        joints.append(float(result.waist))
    return joints, None


def move_failure(status, result):
    """Why a MoveRobot goal that the server reported done did not reach its joints, or None."""
    if result is not None and result.succeed != 1 and succeeded(status):
        return 'move finished with code %d' % result.succeed
    return None


def report_failure(status, result):
    """Why an EndEffector or VisualServo goal reported done did not succeed (its message),
    or None."""
    if result is not None and not result.success and succeeded(status):
        return result.message
    return None


def dropped_on_the_way(result):
    """Why the fruit placed was not in the box (text), or None: the suction valve closed over
    the box (SUCTION_OFF succeeded) with no vacuum on the cup when the command came
    (`released_empty`), so the fruit had come off it on the way (vacuum lost while carrying)."""
    if result is None or not getattr(result, 'released_empty', False):
        return None
    return ('dropped on the way to the box: no vacuum on the suction cup when the valve closed '
            'over the box (vacuum lost while carrying)')


class Relocation(object):
    """What the look at the held fruit decided: `target` is the new estimate or None (keep the
    first one), `why` one of: no-result, no-estimate, not-found, smaller, depth, moved; for
    `depth`, `shift` is the move along the stereo head's view ray (m, + = farther)."""

    def __init__(self, why, target=None, distance=None, radius=None, shift=None):
        self.why = why
        self.target = target
        self.distance = distance
        self.radius = radius
        self.shift = shift


def relocate(target, tomatoes, tolerance, radius_tolerance=0.0, viewpoint=None):
    """The held fruit among the tomatoes of a scan: the nearest one within `tolerance` of where
    it is expected replaces the first estimate unless it is smaller (occlusion only shrinks a
    fitted circle, so the first view then saw more of it) by more than `radius_tolerance` of
    the first radius (stereo radii of one fruit differ by that much from view to view).

    viewpoint: (x, y, z) of the stereo head's right eye in the target's frame, or None. With
    it, a smaller fruit still corrects the first estimate's depth: an occluder (the suction
    sleeve, a leaf) moves a circle's centre across the view, while block matching errs along
    the view ray (a dim fruit's whole skin mismatched: 15 mm too far, the cut missed). So the
    first estimate moves along its view ray to the depth the new look implies, with the first
    radius (a centre lies a radius behind the surface the stereo head ranged, and the smaller
    circle's radius put it that much nearer), and keeps its place across the view."""
    if tomatoes is None:
        return Relocation('no-result')
    frame = target.pick_point.header.frame_id
    expected = located(target, frame)
    if expected is None:
        return Relocation('no-estimate')
    best, best_d = None, tolerance
    for cand in tomatoes:
        xyz = located(cand, frame)
        if xyz is None:
            continue
        d = distance(xyz, expected)
        if d <= best_d:
            best, best_d = cand, d
    if best is None:
        return Relocation('not-found')
    if best.radius < (1.0 - radius_tolerance) * target.radius:
        ray = None if viewpoint is None else [e - v for e, v in zip(expected, viewpoint)]
        norm = math.sqrt(sum(c * c for c in ray)) if ray is not None else 0.0
        if not norm > 1e-6 or not math.isfinite(norm):
            return Relocation('smaller', distance=best_d, radius=best.radius)
        ray = [c / norm for c in ray]
        seen = located(best, frame)
        shift = sum((s + r * (target.radius - best.radius) - e) * r
                    for s, r, e in zip(seen, ray, expected))
        deeper = copy.deepcopy(target)
        p = deeper.pick_point.point
        p.x, p.y, p.z = (e + shift * r for e, r in zip(expected, ray))
        return Relocation('depth', deeper, best_d, best.radius, shift)
    moved = copy.deepcopy(target)
    moved.pick_point = best.pick_point
    moved.radius = best.radius
    return Relocation('moved', moved, best_d, best.radius)
