#!/usr/bin/env python3
"""Test fixture: mock action servers for every module the executive drives.

Params:
  ~points (int): number of picking points (sets /track/picking_points)
  ~targets (dict: point index as string -> list of {id, unreachable?, unreachable_left?,
      unreachable_right_later?, lose?}): pickable tomatoes (unreachable_left: only the cutting
      arm cannot reach it; unreachable_right_later: the suction arm's first solution for it is
      found, the later ones are not, as when the other arm waits in the way)
  ~missing (list of action names): servers NOT started (a component missing at start)
  ~move_duration (float, s): how long a MoveRobot goal takes (preemptable)
  ~per_arm_moves (bool, false): move_robot runs one goal per arm at once (else one goal: a
      second replaces the first, as motion_pkg's); publishes "move_robot overlap" on mock/goals
      when goals of both arms run at the same time
  ~checkpoint (dict, optional): what get_checkpoint serves as the robot's unfinished checkpoint
      (mission_id, points, point_index, target_id, target_y, phase, holding, done_y: list of
      [target_id, y]; tomatoes at x 0.5, z 0.9 as the scan puts them) until a finished checkpoint of
      that mission comes; none: get_checkpoint finds nothing
  ~records (list of [picking_point, target_id, y], optional): get_mission_records' picked records
  ~held_view (dict, optional): {shift, radius, across} (m): the look at the held fruit (a scan of
      picking point -1) sees the fruit where the suction arm's last kinematics goal put it,
      `shift` farther along the stereo head's view ray (robot.yaml's right eye, waist 0), with
      a circle of `radius` (its centre that much nearer than the first estimate's radius, as a
      smaller circle ranges it) and `across` to the side (square to the ray, horizontal);
      noted "held_view x y z" (the suction target it started from); none: it sees nothing
Subscribes to mock/hold_moves (std_msgs/Bool): while the last one said true, a MoveRobot goal of
the one-goal server waits (preemptable) before it starts its move_duration, so a test can look
at the mission while one state stays active; notes "hold_moves on|off" on mock/goals.
  ~hold_after_moves (int, 0): so many MoveRobot goals after the hold goes on still pass (a
      mission's PARK_ARMS, two moves, before the right arm's first DO_MOVE_ROBOT).
Serves get_checkpoint and get_mission_records (database_pkg's), notes every checkpoint on mock/goals
("checkpoint <phase> <holding> <finished>").
move_base is refused (aborted, noted "move_base refused <point>") as motion_pkg's cart interlock
refuses it: with an arm out of the cart's stowed space after its last finished move, or moving;
and a MoveRobot goal while a move_base goal runs (noted "move_robot refused").
  ~hold_cart (bool, false): the first move_base goal (a test's, as another client's: a manual cart
      move, or a restarted task planner's predecessor's) runs until mock/cart_stop (std_msgs/Bool
      true) comes; noted "move_base held <point>", then "move_base stopped".
Notes "summary <outcome>" on mock/goals for every mission/summary it hears: on the one ordered
connection of mock/goals, a test that has seen it has seen every goal of that mission (the
summary itself comes from another node, on a connection of its own).
Publishes mock/halt_count (std_msgs/Int32, latched), mock/goals (std_msgs/String: "<action> <detail>")
and joint_states (the waist at 0, the arms at their home poses, then at the goal of every finished
move).
"""
import json
import threading

import actionlib
import rospy
from diagnostic_msgs.msg import DiagnosticStatus
from sensor_msgs.msg import JointState
from std_msgs.msg import Bool, Int32, String
from std_srvs.srv import Trigger, TriggerResponse

from geometry_msgs.msg import Point
from harvest_msgs.msg import Checkpoint, PickRecord
from harvest_msgs.srv import (GetCheckpoint, GetCheckpointResponse, GetMissionRecords,
                              GetMissionRecordsResponse)
from harvest_msgs.msg import (StartAction, StartResult, MoveBaseAction, MoveBaseResult, TomatoScanAction,
                              TomatoScanResult, SpatialTemporalAction, SpatialTemporalResult,
                              KinematicsAction, KinematicsResult, MoveRobotAction, MoveRobotResult,
                              EndEffectorAction, EndEffectorResult, VisualServoAction, VisualServoResult,
                              Tomato)


class MockServers(object):
    def __init__(self):
        self.points = int(rospy.get_param('~points', 2))
        rospy.set_param('/track/picking_points', [0.6 * i for i in range(self.points)])
        self.targets = {int(k): v for k, v in rospy.get_param('~targets', {}).items()}
        self.held_view = rospy.get_param('~held_view', None)
        self.right_target = None     # (x, y, z) of the suction arm's last kinematics goal
        self.missing = set(rospy.get_param('~missing', []))
        self.move_duration = float(rospy.get_param('~move_duration', 0.05))
        self.per_arm_moves = bool(rospy.get_param('~per_arm_moves', False))
        self.point = 0
        self.halts = 0
        self.halt_event = threading.Event()
        self.picked = set()
        self.by_position = {}
        self.right_solved = {}       # y -> suction-arm kinematics goals for that target
        self._halt_pub = rospy.Publisher('mock/halt_count', Int32, queue_size=1, latch=True)
        self._goal_pub = rospy.Publisher('mock/goals', String, queue_size=100)
        self._status_pub = rospy.Publisher('motion_status', DiagnosticStatus, queue_size=1, latch=True)
        self._status_pub.publish(DiagnosticStatus(level=DiagnosticStatus.OK, name='motion', message='ok'))
        self._halt_pub.publish(Int32(data=0))
        self._joints_pub = rospy.Publisher('joint_states', JointState, queue_size=10, latch=True)
        self.joints = {'waist_joint': 0.0}
        self.interlock = cart_interlock()
        for arm, home in (('left', (0.0, 0.7854, 2.3562)), ('right', (0.0, -0.7854, -2.3562))):
            self.set_arm(arm, home)
        rospy.Service('halt_all', Trigger, self.halt)
        self.checkpoint = rospy.get_param('~checkpoint', None)
        self.records = rospy.get_param('~records', [])
        rospy.Subscriber('mission/checkpoints', Checkpoint, self.on_checkpoint, queue_size=100)
        rospy.Subscriber('mission/summary', String, self.on_summary, queue_size=10)
        self.hold = threading.Condition()
        self.holding = False
        self.hold_after = int(rospy.get_param('~hold_after_moves', 0))
        self.hold_pass = 0            # moves the hold still lets through
        self.hold_cart = bool(rospy.get_param('~hold_cart', False))
        self.cart_held = False
        self.cart_stopped = False
        rospy.Subscriber('mock/cart_stop', Bool, self.on_cart_stop, queue_size=1)
        rospy.Subscriber('mock/hold_moves', Bool, self.on_hold, queue_size=10)
        rospy.Service('get_checkpoint', GetCheckpoint, self.get_checkpoint)
        rospy.Service('get_mission_records', GetMissionRecords, self.get_records)
        self.servers = []
        for name, spec, cb in [('self_test', StartAction, self.self_test), ('move_base', MoveBaseAction, self.move_base),
                               ('tomato_scan', TomatoScanAction, self.scan),
                               ('spatial_temporal', SpatialTemporalAction, self.spatial_temporal),
                               ('kinematics', KinematicsAction, self.kinematics),
                               ('move_robot', MoveRobotAction, self.move_robot),
                               ('end_effector', EndEffectorAction, self.end_effector),
                               ('visual_servo', VisualServoAction, self.visual_servo)]:
            if name in self.missing:
                continue
            if name == 'move_robot' and self.per_arm_moves:
                self.start_per_arm_moves()
                continue
            server = actionlib.SimpleActionServer(name, spec, execute_cb=cb, auto_start=False)
            setattr(self, name + '_server', server)
            server.start()
            self.servers.append(server)

    def cart_refusal(self):
        """motion_pkg's cart interlock on the arms' last finished moves: why the cart may not
        move ('' when it may)."""
        moving = []
        if self.per_arm_moves:                      # the per-arm server's running goals
            with self.moves_lock:
                moving = sorted(self.moving)
        joints = {arm: tuple(self.joints['%s_%s_joint' % (arm, j)]
                             for j in ('lift', 'boom', 'forearm')) for arm in ('left', 'right')}
        return self.interlock.move_base_refusal(joints, self.joints['waist_joint'], moving)

    def set_arm(self, arm, positions, waist=None):
        if waist is not None:
            self.joints['waist_joint'] = float(waist)
        self.joints.update(zip(['%s_%s_joint' % (arm, j) for j in ('lift', 'boom', 'forearm')],
                               positions))
        names = sorted(self.joints)
        self._joints_pub.publish(JointState(name=names, position=[self.joints[n] for n in names]))

    def on_checkpoint(self, msg):
        self.note('checkpoint %s %d %d' % (msg.phase or '-', msg.holding, msg.finished))
        if msg.finished and self.checkpoint and msg.mission_id == self.checkpoint['mission_id']:
            self.checkpoint = None

    def on_summary(self, msg):
        try:
            outcome = json.loads(msg.data).get('outcome', '?')
        except ValueError:
            outcome = 'unreadable'
        self.note('summary %s' % outcome)

    def get_checkpoint(self, req):
        c = self.checkpoint
        if not c:
            return GetCheckpointResponse(found=False, message='no unfinished mission (mock)')
        msg = Checkpoint(mission_id=c['mission_id'], points=c['points'],
                         point_index=c['point_index'], picking_point=c['points'][c['point_index']],
                         target_id=c.get('target_id', -1), phase=c.get('phase', ''),
                         holding=c.get('holding', False))
        msg.target_position = Point(0.5, c.get('target_y', 0.0), 0.9)
        msg.targets_done = [int(t) for t, _ in c.get('done_y', [])]
        msg.done_positions = [Point(0.5, y, 0.9) for _, y in c.get('done_y', [])]
        return GetCheckpointResponse(found=True, message='mock', checkpoint=msg)

    def get_records(self, req):
        resp = GetMissionRecordsResponse(success=True, mission_id=req.mission_id)
        for point, target, y in self.records:
            rec = PickRecord(mission_id=req.mission_id, picking_point=point, target_id=target,
                             outcome=PickRecord.OUTCOME_PICKED, cycle_time=10.0)
            rec.pick_point.header.frame_id = 'base_link'
            rec.pick_point.point = Point(0.5, y, 0.9)
            resp.records.append(rec)
        return resp

    def note(self, text):
        self._goal_pub.publish(String(data=text))

    def halt(self, req):
        self.halts += 1
        self.halt_event.set()
        self._halt_pub.publish(Int32(data=self.halts))
        return TriggerResponse(success=True, message='halted')

    def self_test(self, goal):
        self.self_test_server.set_succeeded(StartResult(success=True, message='ok'))

    def move_base(self, goal):
        why = self.cart_refusal()
        if why:                     # as motion_pkg's motion_server refuses it
            self.note('move_base refused %d' % goal.picking_point)
            self.move_base_server.set_aborted(MoveBaseResult(success=False, message=why), why)
            return
        with self.hold:
            held = self.hold_cart and not self.cart_held
            self.cart_held = self.cart_held or held
        if held:                    # the first goal runs until mock/cart_stop
            self.note('move_base held %d' % goal.picking_point)
            with self.hold:
                while not self.cart_stopped and not rospy.is_shutdown():
                    self.hold.wait(0.05)
            self.note('move_base stopped')
            self.move_base_server.set_succeeded(MoveBaseResult(success=True, track_position=0.0))
            return
        self.point = goal.picking_point
        self.note('move_base %d' % goal.picking_point)
        self.move_base_server.set_succeeded(MoveBaseResult(success=True, track_position=0.6 * goal.picking_point))

    def scan(self, goal):
        result = TomatoScanResult(success=True)
        if goal.picking_point == -1 and self.held_view and self.right_target is not None:
            self.note('held_view %.6f %.6f %.6f' % self.right_target)
            ray, across = view_ray(self.right_target)
            v = self.held_view
            along = float(v['shift']) - (0.03 - float(v['radius']))
            t = Tomato(id=99, radius=float(v['radius']), ripeness_stage=Tomato.STAGE_RED,
                       ripeness_score=0.9, pickable=True, pick_order=0)
            t.pick_point.header.frame_id = 'base_link'
            t.pick_point.point = Point(*[c + along * r + float(v['across']) * a
                                         for c, r, a in zip(self.right_target, ray, across)])
            result.tomatoes.tomatoes.append(t)
            result.pickable_count = 1
            self.tomato_scan_server.set_succeeded(result)
            return
        order = 0
        for spec in self.targets.get(goal.picking_point, []):
            key = (goal.picking_point, int(spec['id']))
            if key in self.picked:
                continue
            t = Tomato(id=int(spec['id']), radius=0.03, ripeness_stage=Tomato.STAGE_RED, ripeness_score=0.9,
                       pickable=True, pick_order=order)
            t.pick_point.header.frame_id = 'base_link'
            t.pick_point.point.x = 0.5
            t.pick_point.point.y = 0.01 * int(spec['id'])
            t.pick_point.point.z = 0.9
            self.by_position[round(t.pick_point.point.y, 4)] = spec
            result.tomatoes.tomatoes.append(t)
            order += 1
        result.pickable_count = order
        self.tomato_scan_server.set_succeeded(result)

    def spatial_temporal(self, goal):
        self.spatial_temporal_server.set_succeeded(SpatialTemporalResult(success=True, stored=0))

    def kinematics(self, goal):
        y = round(goal.target.point.y, 4)
        spec = self.by_position.get(y, {})
        result = KinematicsResult()
        if not goal.arm:
            self.right_solved[y] = self.right_solved.get(y, 0) + 1
            p = goal.target.point
            self.right_target = (p.x, p.y, p.z)
        refused = not goal.arm and spec.get('unreachable_right_later') and self.right_solved[y] > 1
        if spec.get('unreachable') or (goal.arm and spec.get('unreachable_left')) or refused:
            result.reachable = False
            result.reason = 'beyond reach (mock)'
        else:
            result.reachable = True
            result.joint_goal.positions = [0.1, 0.2, 0.3]
        self.kinematics_server.set_succeeded(result)

    def on_cart_stop(self, msg):
        with self.hold:
            self.cart_stopped = self.cart_stopped or msg.data
            self.hold.notify_all()

    def on_hold(self, msg):
        with self.hold:
            if msg.data and not self.holding:
                self.hold_pass = self.hold_after
            self.holding = msg.data
            self.hold.notify_all()
        self.note('hold_moves %s' % ('on' if msg.data else 'off'))

    def arms_refusal(self):
        """motion_pkg's cart interlock: no arm moves while a move_base goal runs."""
        from motion_pkg.motion_interlock import move_robot_refusal
        server = getattr(self, 'move_base_server', None)        # none: ~missing
        return move_robot_refusal(server is not None and server.is_active())

    def move_robot(self, goal):
        why = self.arms_refusal()
        if why:
            self.note('move_robot refused')
            self.move_robot_server.set_aborted(MoveRobotResult(succeed=-1), why)
            return
        self.note('move_robot %s' % ('left' if goal.arm else 'right'))
        with self.hold:
            passed = self.holding and self.hold_pass > 0
            if passed:
                self.hold_pass -= 1
            while self.holding and not passed and not rospy.is_shutdown():
                if self.move_robot_server.is_preempt_requested():
                    self.move_robot_server.set_preempted(MoveRobotResult(succeed=-3),
                                                         'preempted while held')
                    return
                self.hold.wait(0.05)
        done = threading.Event()
        deadline = rospy.Time.now() + rospy.Duration(self.move_duration)
        while rospy.Time.now() < deadline and not rospy.is_shutdown():
            if self.move_robot_server.is_preempt_requested():
                self.move_robot_server.set_preempted(MoveRobotResult(succeed=-3), 'preempted, axes halted')
                return
            done.wait(0.01)
        self.set_arm('left' if goal.arm else 'right', goal.target_joint.positions,
                     goal.waist if goal.move_waist else None)
        self.move_robot_server.set_succeeded(MoveRobotResult(succeed=1))

    def start_per_arm_moves(self):
        self.moving = {}                  # arm -> goal handle
        self.moves_lock = threading.Lock()
        self.move_server = actionlib.ActionServer('move_robot', MoveRobotAction, self.arm_goal,
                                                  self.arm_cancel, auto_start=False)
        self.move_server.start()

    def arm_goal(self, handle):
        goal = handle.get_goal()
        arm = 'left' if goal.arm else 'right'
        why = self.arms_refusal()
        if why:
            self.note('move_robot refused')
            handle.set_rejected(MoveRobotResult(succeed=-1), why)
            return
        with self.moves_lock:
            if arm in self.moving:
                handle.set_rejected(MoveRobotResult(succeed=-6), 'the %s arm is moving' % arm)
                return
            self.moving[arm] = handle
            both = len(self.moving) == 2
        handle.set_accepted()
        self.note('move_robot %s' % arm)
        if both:
            self.note('move_robot overlap')
        timer = threading.Timer(self.move_duration, self.arm_done, (arm, handle, goal))
        timer.daemon = True
        timer.start()

    def arm_done(self, arm, handle, goal):
        with self.moves_lock:
            if self.moving.get(arm) is not handle:
                return                    # cancelled
            del self.moving[arm]
        self.set_arm(arm, goal.target_joint.positions, goal.waist if goal.move_waist else None)
        handle.set_succeeded(MoveRobotResult(succeed=1))

    def arm_cancel(self, handle):
        with self.moves_lock:
            for arm, h in list(self.moving.items()):
                if h.get_goal_id().id == handle.get_goal_id().id:
                    del self.moving[arm]
                    handle.set_canceled(MoveRobotResult(succeed=-5), 'preempted, axes halted')

    def end_effector(self, goal):
        self.note('end_effector %d' % goal.command)
        self.end_effector_server.set_succeeded(EndEffectorResult(success=True, vacuum_ok=goal.command == 1))

    def visual_servo(self, goal):
        p = goal.target.point
        self.note('visual_servo %.6f %.6f %.6f' % (p.x, p.y, p.z))
        # the held fruit's estimate may have moved a little (the look at it): the nearest target
        near = [y for y in self.by_position if abs(y - p.y) < 0.004]
        spec = self.by_position[min(near, key=lambda y: abs(y - p.y))] if near else {}
        if spec.get('lose'):
            self.visual_servo_server.set_aborted(VisualServoResult(success=False, message='target lost'),
                                                 'target lost')
            return
        self.picked.add((self.point, int(spec.get('id', -1))))
        self.visual_servo_server.set_succeeded(VisualServoResult(success=True, iterations=3, final_error=0.001))


def cart_interlock():
    """motion_pkg's CartInterlock with robot.yaml's geometry and motion_server.yaml's limit."""
    import os
    import rospkg
    import yaml
    from motion_pkg.kinematics_geometry import ForwardKinematics
    from motion_pkg.motion_interlock import CartInterlock
    pack = rospkg.RosPack()
    with open(os.path.join(pack.get_path('motion_pkg'), 'config', 'motion_server.yaml')) as f:
        max_x = yaml.safe_load(f)['stowed_max_x']
    return CartInterlock(ForwardKinematics.from_yaml(os.path.join(
        pack.get_path('harvest_description'), 'config', 'robot.yaml')), max_x)


def view_ray(point):
    """(unit ray from the stereo head's right eye to `point`, a horizontal unit vector square
    to it), base_link, waist 0; the eye from harvest_description's robot.yaml."""
    import math
    import os
    import rospkg
    from motion_pkg.kinematics import RobotGeometry
    geometry = RobotGeometry.from_yaml(os.path.join(
        rospkg.RosPack().get_path('harvest_description'), 'config', 'robot.yaml'))
    eye = geometry.stereo_xyz                   # waist_link -> the right eye; waist 0
    ray = [c - e for c, e in zip(point, eye)]
    norm = math.sqrt(sum(c * c for c in ray))
    ray = [c / norm for c in ray]
    side = math.hypot(ray[0], ray[1])
    return ray, (ray[1] / side, -ray[0] / side, 0.0)


if __name__ == '__main__':
    rospy.init_node('mock_harvest_servers')
    MockServers()
    rospy.spin()
