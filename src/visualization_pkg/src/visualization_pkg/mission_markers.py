"""Node `mission_markers`: rviz markers of what the executive is doing.

Subscribes (relative names; the actionlib topics are the executive's own goals and results):
  kinematics/goal, kinematics/result        the current target and whether it is reachable
  move_robot/goal, move_robot/result        the planned arm motion: the arm drawn at its goal joints
  mission/pick_records                      a sphere per finished fruit, coloured by outcome
  mission/events                            the executive's current state, as text over the robot
Publishes: mission/markers (visualization_msgs/MarkerArray, latched; the whole set each time)
Fruit spheres are kept in ~fixed_frame (map): the records are in base_link, which moves with the cart.
Params: ~robot_yaml (default harvest_description's config/robot.yaml; a bad file ends the node at
  start with one fatal line naming the field, exit code 1), ~base_frame (base_link),
  ~fixed_frame (map), ~tf_timeout (s, 0.2),
  ~history (number of fruit spheres kept, 200), ~text_height (m, 0.06)
"""
import os

import rospkg
import rospy
import tf2_geometry_msgs  # noqa: F401 - registers PointStamped with tf2
import tf2_ros
from geometry_msgs.msg import Point
from std_msgs.msg import ColorRGBA
from visualization_msgs.msg import Marker, MarkerArray

from harvest_msgs.msg import (KinematicsActionGoal, KinematicsActionResult, MissionEvent, MoveRobotActionGoal,
                              MoveRobotActionResult, PickRecord)
from harvest_description import robot_config
from visualization_pkg import names
from visualization_pkg.arm_geometry import ArmGeometry

OUTCOME_RGBA = {PickRecord.OUTCOME_PICKED: (0.18, 0.8, 0.25, 0.9), PickRecord.OUTCOME_UNREACHABLE: (1.0, 0.55, 0.0, 0.9),
                PickRecord.OUTCOME_LOST: (0.6, 0.2, 0.8, 0.9), PickRecord.OUTCOME_FAILED: (0.9, 0.1, 0.1, 0.9),
                PickRecord.OUTCOME_DROPPED: (0.45, 0.3, 0.2, 0.9)}
ARM_RGBA = {'left': (0.2, 0.75, 1.0, 0.8), 'right': (1.0, 0.85, 0.2, 0.8)}


def _colour(rgba):
    return ColorRGBA(*rgba)


class MissionMarkers(object):
    def __init__(self):
        path = rospy.get_param('~robot_yaml', '') or os.path.join(
            rospkg.RosPack().get_path('harvest_description'), 'config', 'robot.yaml')
        # a bad robot.yaml: one fatal line naming file and field, exit 1
        self.arm = ArmGeometry.from_robot_yaml(robot_config.load_or_exit(path, rospy.logfatal))
        self.base_frame = rospy.get_param('~base_frame', 'base_link')
        self.fixed_frame = rospy.get_param('~fixed_frame', 'map')
        self.tf_timeout = rospy.Duration(float(rospy.get_param('~tf_timeout', 0.2)))
        self.tf_buffer = tf2_ros.Buffer()
        self.tf_listener = tf2_ros.TransformListener(self.tf_buffer)
        self.history = int(rospy.get_param('~history', 200))
        self.text_height = float(rospy.get_param('~text_height', 0.06))
        self.kin_goals = {}         # goal id -> KinematicsGoal
        self.target = None          # (KinematicsGoal, result or None)
        self.planned = {}           # arm -> (goal id, positions)
        self.records = []
        self.state = ''
        self._pub = rospy.Publisher(names.MARKERS, MarkerArray, queue_size=1, latch=True)
        rospy.Subscriber(names.KINEMATICS + '/goal', KinematicsActionGoal, self._kin_goal, queue_size=10)
        rospy.Subscriber(names.KINEMATICS + '/result', KinematicsActionResult, self._kin_result, queue_size=10)
        rospy.Subscriber(names.MOVE_ROBOT + '/goal', MoveRobotActionGoal, self._move_goal, queue_size=10)
        rospy.Subscriber(names.MOVE_ROBOT + '/result', MoveRobotActionResult, self._move_result, queue_size=10)
        rospy.Subscriber(names.PICK_RECORDS, PickRecord, self._record, queue_size=50)
        rospy.Subscriber(names.EVENTS, MissionEvent, self._event, queue_size=50)
        self.publish()

    # --- callbacks (each republishes the whole set; rospy runs them one topic at a time) ------------
    def _kin_goal(self, msg):
        self.kin_goals[msg.goal_id.id] = msg.goal
        self.target = (msg.goal, None)
        self.publish()

    def _kin_result(self, msg):
        goal = self.kin_goals.pop(msg.status.goal_id.id, None)
        if goal is not None:
            self.target = (goal, msg.result)
            self.publish()

    def _move_goal(self, msg):
        arm = 'left' if msg.goal.arm else 'right'
        positions = list(msg.goal.target_joint.positions)
        if len(positions) == 3:
            self.planned[arm] = (msg.goal_id.id, positions)
            self.publish()

    def _move_result(self, msg):
        for arm, (goal_id, _) in list(self.planned.items()):
            if goal_id == msg.status.goal_id.id:
                del self.planned[arm]
                self.publish()

    def _record(self, msg):
        """Keep the fruit where it was: its pick point in the fixed frame at the record's time."""
        point = msg.pick_point
        point.header.frame_id = point.header.frame_id or self.base_frame
        try:
            point.header.stamp = msg.stamp
            msg.pick_point = self.tf_buffer.transform(point, self.fixed_frame, self.tf_timeout)
        except (tf2_ros.LookupException, tf2_ros.ConnectivityException, tf2_ros.ExtrapolationException,
                tf2_ros.TransformException) as exc:
            rospy.logwarn_throttle(10.0, 'mission_markers: fruit %d kept in %s (no transform to %s: %s)'
                                   % (msg.target_id, point.header.frame_id, self.fixed_frame, exc))
        self.records.append(msg)
        del self.records[:-self.history]
        self.publish()

    def _event(self, msg):
        if msg.kind == 'summary':
            self.state = 'mission ended'
        elif msg.state:
            self.state = '%s: %s' % (msg.state, msg.detail) if msg.detail else msg.state
        self.publish()

    # --- markers -------------------------------------------------------------------------------------
    def markers(self):
        out = MarkerArray()
        out.markers.append(Marker(action=Marker.DELETEALL))
        stamp = rospy.Time(0)       # latest transform: markers follow the robot
        if self.target is not None:
            goal, result = self.target
            frame = goal.target.header.frame_id or self.base_frame
            p = goal.target.point
            ok = result is None or result.reachable
            sphere = Marker(ns='target', id=0, type=Marker.SPHERE, action=Marker.ADD)
            sphere.header.frame_id, sphere.header.stamp = frame, stamp
            sphere.pose.position = Point(p.x, p.y, p.z)
            sphere.pose.orientation.w = 1.0
            sphere.scale.x = sphere.scale.y = sphere.scale.z = 0.045
            sphere.color = _colour((1.0, 0.92, 0.1, 0.95) if ok else (1.0, 0.2, 0.1, 0.95))
            out.markers.append(sphere)
            text = Marker(ns='target', id=1, type=Marker.TEXT_VIEW_FACING, action=Marker.ADD)
            text.header = sphere.header
            text.pose.position = Point(p.x, p.y, p.z + 0.08)
            text.pose.orientation.w = 1.0
            text.scale.z = self.text_height * 0.7
            arm = 'left' if goal.arm else 'right'
            if result is None:
                text.text = 'target (%s arm): planning' % arm
            elif result.reachable:
                text.text = 'target (%s arm): %s' % (arm, result.branch or 'reachable')
            else:
                text.text = 'UNREACHABLE (%s arm): %s' % (arm, result.reason)
            text.color = _colour((1.0, 1.0, 1.0, 1.0) if ok else (1.0, 0.4, 0.3, 1.0))
            out.markers.append(text)
        for i, (arm, (_gid, q)) in enumerate(sorted(self.planned.items())):
            line = Marker(ns='planned_arm', id=i, type=Marker.LINE_STRIP, action=Marker.ADD)
            line.header.frame_id, line.header.stamp = '%s_arm_base' % arm, stamp
            line.pose.orientation.w = 1.0
            line.scale.x = 0.025
            line.color = _colour(ARM_RGBA[arm])
            line.points = [Point(*xyz) for xyz in self.arm.polyline(*q)]
            out.markers.append(line)
            tip = Marker(ns='planned_tool', id=i, type=Marker.SPHERE, action=Marker.ADD)
            tip.header = line.header
            tip.pose.position = line.points[-1]
            tip.pose.orientation.w = 1.0
            tip.scale.x = tip.scale.y = tip.scale.z = 0.035
            tip.color = _colour(ARM_RGBA[arm])
            out.markers.append(tip)
        for i, rec in enumerate(self.records):
            m = Marker(ns='fruit_history', id=i, type=Marker.SPHERE, action=Marker.ADD)
            m.header.frame_id = rec.pick_point.header.frame_id or self.base_frame
            m.header.stamp = stamp
            m.pose.position = rec.pick_point.point
            m.pose.orientation.w = 1.0
            m.scale.x = m.scale.y = m.scale.z = 0.025
            m.color = _colour(OUTCOME_RGBA.get(rec.outcome, (0.5, 0.5, 0.5, 0.9)))
            m.frame_locked = False
            out.markers.append(m)
        if self.state:
            t = Marker(ns='state', id=0, type=Marker.TEXT_VIEW_FACING, action=Marker.ADD)
            t.header.frame_id, t.header.stamp = self.base_frame, stamp
            t.pose.position = Point(0.0, 0.0, 1.55)
            t.pose.orientation.w = 1.0
            t.scale.z = self.text_height
            t.color = _colour((1.0, 1.0, 1.0, 1.0))
            t.text = self.state[:80]
            out.markers.append(t)
        return out

    def publish(self):
        self._pub.publish(self.markers())
