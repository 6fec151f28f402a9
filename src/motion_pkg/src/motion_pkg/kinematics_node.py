"""ROS glue of the `kinematics` action server (DO_KINEMATICS); the maths is in kinematics.py.

Action server ``kinematics`` (harvest_msgs/Kinematics): inverse kinematics of one arm. The goal's
target point is transformed into ``~base_frame`` with tf2 when it is given in another frame; the
current ``joint_states`` give the waist angle, the other arm's pose (clearance check) and this
arm's pose (the IK branch with the smallest joint motion is chosen). Goals are answered directly
in the goal callback (no execute_cb polling); the IK itself takes well under a millisecond.

Waist (goal `solve_waist`, optional): a target out of reach at the current waist angle is solved
with the smallest waist rotation that brings it in (kinematics.RobotGeometry.inverse_waist); with
`check_other` the other arm must reach `other_target` at that angle too. The result's
`move_waist`/`waist` say which angle the joints are for. Goals without these fields are solved at
the current waist angle exactly as before. With ~base_frame waist_link the waist is not solved.

Outcomes: succeeded with reachable=true and joint_goal.positions = [lift, boom, forearm]
(time_from_start = slowest axis at robot.yaml speeds); succeeded with reachable=false and a reason
when the point is geometrically unreachable; aborted (reason in result and status text) for
invalid goals: NaN, negative standoff, no transform (of the target or, with check_other, of
other_target).

Subscribed: joint_states (sensor_msgs/JointState; partial messages are merged).
Params:
  ~robot_description_yaml  robot.yaml path (default: harvest_description/config/robot.yaml);
                           a bad file ends the node at start (one fatal line, exit code 1)
  ~base_frame              frame the IK works in: base_link (default; waist angle from
                           joint_states) or waist_link (waist angle taken as 0)
  ~tf_timeout              seconds to wait for a transform of the goal point (default 0.2)
"""

import math
import os
import threading

import actionlib
import rospy
import tf2_geometry_msgs  # noqa: F401  (registers PointStamped with tf2)
import tf2_ros
from geometry_msgs.msg import PointStamped
from harvest_msgs.msg import KinematicsAction, KinematicsFeedback, KinematicsResult
from sensor_msgs.msg import JointState

from motion_pkg.kinematics import HOME_JOINTS, OTHER_ARM, RobotGeometry
from harvest_description import robot_config

ACTION_NAME = 'kinematics'
JOINT_STATES_TOPIC = 'joint_states'
WAIST_JOINT = 'waist_joint'
WAIST_FRAME = 'waist_link'
ARM_JOINTS = ('lift', 'boom', 'forearm')


def default_robot_yaml():
    """harvest_description's config/robot.yaml, found with rospkg."""
    import rospkg
    return os.path.join(rospkg.RosPack().get_path('harvest_description'), 'config', 'robot.yaml')


def arm_joint_names(arm):
    return ['%s_%s_joint' % (arm, j) for j in ARM_JOINTS]


class KinematicsServer(object):
    """Answers Kinematics goals with RobotGeometry.inverse."""

    def __init__(self):
        path = rospy.get_param('~robot_description_yaml', '') or default_robot_yaml()
        # a bad robot.yaml: one fatal line naming file and field, exit 1
        self.geometry = RobotGeometry(robot_config.load_or_exit(path, rospy.logfatal))
        self.base_frame = rospy.get_param('~base_frame', 'base_link')
        self.tf_timeout = rospy.Duration(float(rospy.get_param('~tf_timeout', 0.2)))
        self._lock = threading.Lock()
        self._positions = {}
        self.tf_buffer = tf2_ros.Buffer()
        self.tf_listener = tf2_ros.TransformListener(self.tf_buffer)
        self.joint_sub = rospy.Subscriber(JOINT_STATES_TOPIC, JointState, self._on_joint_states,
                                          queue_size=10)
        self.server = actionlib.SimpleActionServer(ACTION_NAME, KinematicsAction,
                                                   auto_start=False)
        self.server.register_goal_callback(self._on_goal)
        self.server.start()
        rospy.loginfo('kinematics: serving action %s in frame %s (robot description %s)',
                      rospy.resolve_name(ACTION_NAME), self.base_frame, path)

    def shutdown(self):
        self.joint_sub.unregister()

    def _on_joint_states(self, msg):
        if len(msg.position) != len(msg.name):
            rospy.logwarn_throttle(10.0, 'kinematics: joint_states with %d names and %d '
                                   'positions ignored' % (len(msg.name), len(msg.position)))
            return
        with self._lock:
            self._positions.update(zip(msg.name, msg.position))

    def _arm_state(self, positions, arm):
        """(lift, boom, forearm) of an arm from joint_states, or None when not all known."""
        values = [positions.get(n) for n in arm_joint_names(arm)]
        if any(v is None or not math.isfinite(v) for v in values):
            return None
        return tuple(values)

    def _on_goal(self):
        goal = self.server.accept_new_goal()
        if goal is None:
            return
        try:
            result = self.solve(goal)
        except Exception as err:    # never leave a goal active
            rospy.logerr('kinematics: internal error: %r' % (err,))
            self._abort('internal error: %s' % (err,))
            return
        if result is None:          # aborted inside solve
            return
        self.server.set_succeeded(result, result.reason)

    def _abort(self, reason):
        rospy.logwarn_throttle(1.0, 'kinematics: goal rejected: %s' % reason)
        self.server.set_aborted(KinematicsResult(reachable=False, reason=reason), reason)

    def _other_target(self, goal):
        """(xyz, standoff) of the other arm's target of a waist goal, or (None, 0); raises
        ValueError for an invalid one."""
        if not (goal.solve_waist and goal.check_other):
            return None, 0.0
        p = goal.other_target.point
        if not all(math.isfinite(v) for v in (p.x, p.y, p.z)):
            raise ValueError('NaN in other_target')
        if not math.isfinite(goal.other_standoff) or goal.other_standoff < 0.0:
            raise ValueError('other_standoff %r must be >= 0' % goal.other_standoff)
        return self._point_in_base(goal.other_target), float(goal.other_standoff)

    def _point_in_base(self, target):
        """xyz of the goal point in base_frame, or raise ValueError with a reason."""
        frame = target.header.frame_id.lstrip('/')
        p = target.point
        if not frame or frame == self.base_frame:
            return (p.x, p.y, p.z)
        try:
            out = self.tf_buffer.transform(target, self.base_frame, self.tf_timeout)
        except tf2_ros.ExtrapolationException:
            # stamp outside the buffer (old detection, sim clock jumps): use the latest transform
            latest = PointStamped(header=target.header, point=target.point)
            latest.header.stamp = rospy.Time(0)
            try:
                out = self.tf_buffer.transform(latest, self.base_frame, self.tf_timeout)
            except tf2_ros.TransformException as err:
                raise ValueError('cannot transform target from %s to %s: %s'
                                 % (frame, self.base_frame, err))
            rospy.logwarn_throttle(5.0, 'kinematics: no transform %s->%s at the goal stamp, '
                                   'used the latest' % (frame, self.base_frame))
        except tf2_ros.TransformException as err:
            raise ValueError('cannot transform target from %s to %s: %s'
                             % (frame, self.base_frame, err))
        return (out.point.x, out.point.y, out.point.z)

    def solve(self, goal):
        """KinematicsResult for a goal; aborts the goal and returns None if it is invalid."""
        p = goal.target.point
        if not all(math.isfinite(v) for v in (p.x, p.y, p.z)):
            self._abort('NaN in target')
            return None
        if not math.isfinite(goal.standoff) or goal.standoff < 0.0:
            self._abort('standoff %r must be >= 0' % goal.standoff)
            return None
        try:
            xyz = self._point_in_base(goal.target)
            other_xyz, other_standoff = self._other_target(goal)
        except ValueError as err:
            self._abort(str(err))
            return None
        arm = 'left' if goal.arm else 'right'
        with self._lock:
            positions = dict(self._positions)
        waist = 0.0 if self.base_frame == WAIST_FRAME else positions.get(WAIST_JOINT, 0.0)
        other = self._arm_state(positions, OTHER_ARM[arm])
        if other is None:
            rospy.logwarn_throttle(10.0, 'kinematics: %s arm state unknown, clearance checked '
                                   'against its home pose' % OTHER_ARM[arm])
        current = self._arm_state(positions, arm)
        if goal.solve_waist and self.base_frame == WAIST_FRAME:
            rospy.logwarn_throttle(10.0, 'kinematics: solve_waist ignored: targets are taken in '
                                   '%s, which turns with the waist' % WAIST_FRAME)
        if goal.solve_waist and self.base_frame != WAIST_FRAME:
            sol = self.geometry.inverse_waist(
                arm, xyz, standoff=goal.standoff, other_arm_joints=other, current=current,
                waist=waist, other_xyz=other_xyz, other_standoff=other_standoff,
                other_current=other)
            ik, new_waist, moved = sol.ik, sol.waist, sol.moved
            if sol.other is not None and not sol.other.reachable and ik.reachable:
                rospy.logwarn_throttle(1.0, 'kinematics: no waist angle lets the %s arm reach '
                                       'its target too (%s); %s arm solved where the waist is'
                                       % (OTHER_ARM[arm], sol.other.reason, arm))
        else:
            ik = self.geometry.inverse(arm, xyz, standoff=goal.standoff, other_arm_joints=other,
                                       current=current, waist=waist)
            new_waist, moved = waist, False
        self.server.publish_feedback(KinematicsFeedback(branches_checked=len(ik.candidates)))
        result = KinematicsResult(reachable=ik.reachable, branch=ik.branch, reason=ik.reason,
                                  move_waist=bool(ik.reachable and moved),
                                  waist=float(new_waist))
        if ik.reachable:
            result.joint_goal.positions = list(ik.joints)
            start = current if current is not None else HOME_JOINTS[arm]
            seconds = self.motion_time(start, ik.joints)
            if moved and self.geometry.speed.get('waist'):
                seconds = max(seconds, abs(new_waist - waist) / self.geometry.speed['waist'])
                rospy.loginfo('kinematics: %s arm reaches (%.3f, %.3f, %.3f) with the waist '
                              'turned %.1f -> %.1f deg' % (arm, xyz[0], xyz[1], xyz[2],
                                                           math.degrees(waist),
                                                           math.degrees(new_waist)))
            result.joint_goal.time_from_start = rospy.Duration(seconds)
        else:
            rospy.logwarn_throttle(1.0, 'kinematics: %s arm cannot reach (%.3f, %.3f, %.3f): %s'
                                   % (arm, xyz[0], xyz[1], xyz[2], ik.reason))
        return result

    def motion_time(self, start, end):
        """Seconds for the slowest axis to move start -> end at robot.yaml speeds."""
        times = [abs(b - a) / self.geometry.speed[j]
                 for j, a, b in zip(ARM_JOINTS, start, end) if self.geometry.speed.get(j)]
        return max(times) if times else 0.0
