"""The task-planning executive: the hierarchical, concurrent state machine of continuous picking.

Section 3.4.2 of the paper, Figure 14. Every module is driven through an actionlib
SimpleActionState; the ten state labels of the paper name the states:

ROOT (StateMachine)
  RUN (Concurrence)                      the mission, watched by the emergency-stop monitor
    MISSION (StateMachine)
      DO_START                           Start.action: self-test of every component
      NEXT_POINT                         next picking point of the plan, or mission complete
      DO_MOVEBASE                        MoveBase.action: cart to the picking point
      SCAN (Concurrence)
        DO_TOMATO_SCAN                   TomatoScan.action: pickable tomatoes, in picking order
        DO_SPATIAL_TEMPORAL              SpatialTemporal.action: observations into the database
      NEXT_TARGET                        next target of the planned order, or next point
      PICK_TARGET (StateMachine)         one tomato
        RIGHT_ARM: DO_KINEMATICS -> DO_MOVE_ROBOT -> DO_MOVE_ENDEFFECTOR (suction on)
                   -> CHOOSE_PULL -> DO_KINEMATICS_PULL -> DO_MOVE_ROBOT_PULL (draw the held fruit
                   out of its cluster, clear of the other fruit, so the left arm's camera and
                   shear can get at it; `right_pulls`)
                   -> DO_TOMATO_SCAN_HELD (the stereo head locates the presented fruit again,
                   now clear of the leaves and fruit that hid part of it)
        LEFT_ARM:  DO_KINEMATICS -> DO_MOVE_ROBOT -> DO_VISUALSERVOING -> DO_MOVE_ENDEFFECTOR (cut)
        PLACE:     DO_MOVE_ROBOT (left arm home) -> DO_MOVE_ROBOT_BOX (right arm to the box)
                   -> DO_MOVE_ENDEFFECTOR (suction off)
        RECOVER:   DO_MOVE_ENDEFFECTOR (suction off) -> DO_MOVE_ROBOT (left arm home)
      DO_ERROR                           halt every axis, record the reason; mission aborted
    ESTOP_MONITOR                        ends when an emergency stop is requested
  DO_STOP                                emergency stop: axes halted, mission paused until resume

A state's outcomes and keys are documented in its docstring as
``Outcomes: ...`` / ``Input keys: ...`` / ``Output keys: ...``.
"""
import copy
import math
import threading

import rospy
from geometry_msgs.msg import PointStamped
from std_srvs.srv import Trigger
from trajectory_msgs.msg import JointTrajectoryPoint

from harvest_msgs.msg import (StartAction, StartGoal, MoveBaseAction, MoveBaseGoal,
                              TomatoScanAction, TomatoScanGoal, SpatialTemporalAction,
                              SpatialTemporalGoal, KinematicsAction, KinematicsGoal,
                              MoveRobotAction, MoveRobotGoal, EndEffectorAction, EndEffectorGoal,
                              VisualServoAction, VisualServoGoal)
from control_pkg.smach_compat import smach, SimpleActionState
from control_pkg import mission as mission_lib

ARM_RIGHT = False   # MoveRobot/Kinematics `arm`: false = right (suction) arm
ARM_LEFT = True     # true = left (cutting) arm


class MissionContext(object):
    """What the states share besides userdata: configuration, progress, record and logging hooks."""

    def __init__(self, config, progress, recorder, publish_event=None, publish_record=None, halt=None):
        self.config = config
        self.progress = progress
        self.recorder = recorder
        self.publish_event = publish_event or (lambda kind, state, detail: None)
        self.publish_record = publish_record or (lambda record: None)
        self.halt = halt or (lambda: (True, 'no halt service configured'))
        self.last_error = ''
        self.lock = threading.Lock()
        self.scene = []            # (id, (x, y, z), radius) of every located tomato at this point
        self.gone = set()          # ids picked since that scan

    def now(self):
        return rospy.get_time()

    def fail(self, reason):
        with self.lock:
            self.last_error = reason
        self.recorder.note_error(reason)


def _status_text(state):
    """The text the action server gave with its last goal status, when the client exposes it."""
    text = getattr(state, 'goal_status_text', None)   # control_pkg's fallback SimpleActionState
    if text:
        return text
    client = getattr(state, '_action_client', None)     # smach_ros
    if client is None:
        return ''
    try:
        return client.get_goal_status_text() or ''
    except Exception:  # noqa: BLE001 - a missing goal handle just means no text
        return ''


class HarvestActionState(SimpleActionState):
    """A SimpleActionState with retries, timing into the mission record and a failure reason.

    Outcomes: succeeded, aborted, preempted, plus the extra ones given.
    Retries re-send the goal after an `aborted` outcome (not after a preemption or another outcome).
    """

    def __init__(self, context, label, action_name, action_spec, retries=0, exec_timeout=30.0,
                 server_wait_timeout=5.0, **kwargs):
        SimpleActionState.__init__(
            self, action_name, action_spec,
            exec_timeout=rospy.Duration(exec_timeout),
            server_wait_timeout=rospy.Duration(server_wait_timeout),
            preempt_timeout=rospy.Duration(5.0), **kwargs)
        self._context = context
        self._label = label
        self._retries = max(0, int(retries))
        self._action_name = action_name

    def execute(self, ud):
        start = self._context.now()
        errors_before = len(self._context.recorder.errors)
        outcome = 'aborted'
        for attempt in range(self._retries + 1):
            outcome = SimpleActionState.execute(self, ud)
            if outcome != 'aborted' or self.preempt_requested() or rospy.is_shutdown():
                break
            if attempt < self._retries:
                rospy.logwarn('%s: %s aborted (%s), retry %d of %d', self._label, self._action_name,
                              _status_text(self) or 'no reason given', attempt + 1, self._retries)
        if outcome == 'aborted' and len(self._context.recorder.errors) == errors_before:
            reason = _status_text(self) or ('%s did not succeed (server missing, timed out or aborted)'
                                            % self._action_name)
            self._context.fail('%s: %s' % (self._label, reason))
        self._context.recorder.add_state(self._label, max(0.0, self._context.now() - start))
        return outcome


class NextPoint(smach.State):
    """Choose the next picking point of the plan.

    Outcomes: point (one more point to visit), done (the last point has been harvested),
      error (no usable plan of picking points)
    Output keys: picking_point
    """

    def __init__(self, context):
        smach.State.__init__(self, outcomes=['point', 'done', 'error'], output_keys=['picking_point'])
        self._context = context

    def execute(self, ud):
        try:
            point = self._context.progress.advance()
        except ValueError as exc:
            self._context.fail('NEXT_POINT: %s' % exc)
            return 'error'
        if point is None:
            return 'done'
        ud.picking_point = point
        self._context.recorder.visit_point()
        self._context.publish_event('state', 'NEXT_POINT', 'picking point %d' % point)
        rospy.loginfo('executive: picking point %d', point)
        return 'point'


class NextTarget(smach.State):
    """Take the next target of the planned picking order.

    Outcomes: target (a tomato to pick), done (no target left at this point).
    Input keys: targets, picking_point
    Output keys: targets, target
    """

    def __init__(self, context):
        smach.State.__init__(self, outcomes=['target', 'done'], input_keys=['targets', 'picking_point'],
                             output_keys=['targets', 'target'])
        self._context = context

    def execute(self, ud):
        targets = list(ud.targets or [])
        if not targets:
            return 'done'
        target = targets.pop(0)
        ud.targets = targets
        ud.target = target
        p = target.pick_point.point
        self._context.recorder.begin_fruit(ud.picking_point, target.id, (p.x, p.y, p.z), self._context.now())
        rospy.loginfo('executive: target %d (order %d) at (%.3f, %.3f, %.3f) in %s', target.id,
                      target.pick_order, p.x, p.y, p.z, target.pick_point.header.frame_id)
        return 'target'


class ChoosePull(smach.State):
    """Choose how to draw the held fruit out of its cluster: the first of the configured pulls
    that keeps it (and the cut point above it) clear of the other tomatoes of the last scan.

    Outcomes: pull, none (no pull is clear: the fruit is cut where it hangs)
    Input keys: target
    Output keys: pull
    """

    def __init__(self, context, candidates, clearance, cut_height, cut_clearance):
        smach.State.__init__(self, outcomes=['pull', 'none'], input_keys=['target'], output_keys=['pull'])
        self._context = context
        self._candidates = candidates
        self._clearance = clearance
        self._cut_height = cut_height
        self._cut_clearance = cut_clearance

    def execute(self, ud):
        t = ud.target
        p = t.pick_point.point
        obstacles = [(xyz, r) for tid, xyz, r in self._context.scene
                     if tid != t.id and tid not in self._context.gone]
        pull = mission_lib.choose_pull((p.x, p.y, p.z), t.radius, obstacles, self._candidates,
                                       self._clearance, self._cut_height, self._cut_clearance)
        near = ', '.join('(%.3f, %.3f, %.3f) r %.3f' % (xyz[0], xyz[1], xyz[2], r) for xyz, r in obstacles
                         if mission_lib.distance(xyz, (p.x, p.y, p.z)) < 0.15)
        if pull is None:
            rospy.loginfo('executive: no clear way to draw target %d out of its cluster (fruit near it: %s); '
                          'cutting it in place', t.id, near or 'none')
            return 'none'
        rospy.loginfo('executive: drawing target %d out by (%.3f, %.3f, %.3f) m (fruit near it: %s)',
                      t.id, pull[0], pull[1], pull[2], near or 'none')
        ud.pull = pull
        return 'pull'


class EndFruit(smach.State):
    """Close the current fruit's record with a fixed outcome.

    Outcomes: done
    """

    def __init__(self, context, outcome):
        smach.State.__init__(self, outcomes=['done'])
        self._context = context
        self._outcome = outcome

    def execute(self, ud):
        reason = '' if self._outcome == mission_lib.OUTCOME_PICKED else self._context.last_error
        record = self._context.recorder.end_fruit(self._outcome, self._context.now(), reason)
        if record is not None and self._outcome == mission_lib.OUTCOME_PICKED:
            self._context.gone.add(record.target_id)
        if record is not None:
            self._context.publish_record(record)
            rospy.loginfo('executive: target %d %s after %.1f s%s', record.target_id, record.outcome,
                          record.cycle_time, (' (%s)' % reason) if reason else '')
        return 'done'


class DoError(smach.State):
    """DO_ERROR: bring the robot to a safe state (halt every axis) and record why.

    Outcomes: aborted
    """

    def __init__(self, context):
        smach.State.__init__(self, outcomes=['aborted'])
        self._context = context

    def execute(self, ud):
        reason = self._context.last_error or 'unknown fault'
        ok, message = self._context.halt()
        rospy.logerr('executive: DO_ERROR: %s; axes halted: %s (%s)', reason, ok, message)
        if self._context.recorder.current is not None:
            record = self._context.recorder.end_fruit(mission_lib.OUTCOME_FAILED, self._context.now(), reason)
            self._context.publish_record(record)
        self._context.publish_event('fault', 'DO_ERROR', reason)
        return 'aborted'


class EstopMonitor(smach.State):
    """Waits for an emergency stop request; ends the mission's Concurrence when one comes.

    Outcomes: estop (a stop was requested), preempted (the mission ended first)
    """

    def __init__(self, estop_event):
        smach.State.__init__(self, outcomes=['estop', 'preempted'])
        self._estop = estop_event
        self._wake = threading.Event()

    def execute(self, ud):
        self._wake.clear()
        while not rospy.is_shutdown():
            if self._estop.is_set():
                return 'estop'
            if self.preempt_requested():
                self.service_preempt()
                return 'preempted'
            self._wake.wait(0.5)
        return 'preempted'

    def request_preempt(self):
        smach.State.request_preempt(self)
        self._wake.set()

    def wake(self):
        self._wake.set()


class DoStop(smach.State):
    """DO_STOP: emergency stop. Halts every axis and pauses the mission until a resume command.

    Outcomes: resume (continue from the interrupted picking point and target), shutdown
    """

    def __init__(self, context, estop_event, resume_event):
        smach.State.__init__(self, outcomes=['resume', 'shutdown'])
        self._context = context
        self._estop = estop_event
        self._resume = resume_event

    def execute(self, ud):
        ok, message = self._context.halt()
        rospy.logwarn('executive: DO_STOP: emergency stop, axes halted: %s (%s); paused until resume', ok, message)
        self._context.publish_event('estop', 'DO_STOP', 'axes halted: %s' % message)
        if self._context.recorder.current is not None:
            record = self._context.recorder.end_fruit(mission_lib.OUTCOME_FAILED, self._context.now(),
                                                      'interrupted by emergency stop')
            self._context.publish_record(record)
        self._context.progress.mark_interrupted()
        while not rospy.is_shutdown():
            if self._resume.wait(0.5):
                self._resume.clear()
                self._estop.clear()
                self._context.publish_event('resume', 'DO_STOP', 'mission resumed')
                rospy.loginfo('executive: resumed')
                return 'resume'
        return 'shutdown'


def _located(tomato, frame):
    """(x, y, z) of a tomato located in `frame` with a finite point and a radius, else None."""
    p = tomato.pick_point.point
    if tomato.pick_point.header.frame_id != frame or not tomato.radius > 0.0 or \
            not all(math.isfinite(v) for v in (p.x, p.y, p.z)):
        return None
    return (p.x, p.y, p.z)


def _point_goal(point_stamped, dx=0.0, dy=0.0, dz=0.0):
    out = PointStamped()
    out.header = point_stamped.header
    out.point.x = point_stamped.point.x + dx
    out.point.y = point_stamped.point.y + dy
    out.point.z = point_stamped.point.z + dz
    return out


def _joint_point(positions):
    return JointTrajectoryPoint(positions=list(positions))


def build_state_machine(context, estop_event, resume_event):
    """Build the ROOT state machine. `context.config` is a dict (see config/executive.yaml)."""
    cfg = context.config
    names = cfg['actions']
    timeouts = cfg['timeouts']
    retries = cfg['retries']
    peduncle_gap = float(cfg['peduncle_gap'])
    approach = float(cfg['left_approach_standoff'])
    pulls = [tuple(float(v) for v in p) for p in cfg.get('right_pulls', [])]
    do_pull = bool(pulls)
    pull_clearance = float(cfg.get('pull_clearance', 0.0))
    cut_clearance = float(cfg.get('cut_clearance', 0.01))
    relocate_tolerance = float(cfg.get('relocate_tolerance', 0.0))

    def action(label, key, spec, **kwargs):
        return HarvestActionState(context, label, names[key], spec, retries=retries.get(key, 0),
                                  exec_timeout=timeouts.get(key, 30.0),
                                  server_wait_timeout=cfg['server_wait_timeout'], **kwargs)

    # --- goal and result callbacks ------------------------------------------------------------
    def start_goal_cb(ud, goal):
        return StartGoal(components=list(cfg.get('self_test_components', [])))

    def start_result_cb(ud, status, result):
        if result is not None and not result.success:
            reasons = ['%s: %s' % (c, r) for c, r in zip(result.failed, result.reasons)]
            context.fail('DO_START: self-test failed: %s' % ('; '.join(reasons) or result.message))
            return 'aborted'
        context.recorder.start(context.now())
        context.publish_event('state', 'DO_START', 'self-test passed')
        return None

    def movebase_goal_cb(ud, goal):
        return MoveBaseGoal(picking_point=int(ud.picking_point))

    def movebase_result_cb(ud, status, result):
        if result is not None:
            ud.track_position = result.track_position
        return None

    def scan_goal_cb(ud, goal):
        return TomatoScanGoal(picking_point=int(ud.picking_point), target_frame=cfg['base_frame'])

    def scan_result_cb(ud, status, result):
        if result is None or not result.success:
            return None
        pickable = sorted([t for t in result.tomatoes.tomatoes if t.pickable], key=lambda t: t.pick_order)
        context.scene = [(t.id, _located(t, cfg['base_frame']), t.radius) for t in result.tomatoes.tomatoes
                         if _located(t, cfg['base_frame']) is not None]
        context.gone = set()
        ud.targets = pickable
        rospy.loginfo('executive: %d pickable of %d tomatoes at picking point %d', len(pickable),
                      len(result.tomatoes.tomatoes), ud.picking_point)
        return 'none' if not pickable else None

    def st_goal_cb(ud, goal):
        return SpatialTemporalGoal(mission_id=context.recorder.mission_id, picking_point=int(ud.picking_point),
                                   track_position=float(ud.track_position))

    def kin_goal_cb(arm):
        def cb(ud, goal):
            t = ud.target
            if arm == ARM_RIGHT:
                # suction sleeve on the fruit surface that faces the arm
                return KinematicsGoal(target=t.pick_point, arm=ARM_RIGHT, standoff=float(t.radius))
            # cutting hand near the peduncle; the visual servo does the last centimetres
            return KinematicsGoal(target=_point_goal(t.pick_point, dz=t.radius + peduncle_gap),
                                  arm=ARM_LEFT, standoff=approach)
        return cb

    def pull_goal_cb(ud, goal):
        t = ud.target
        return KinematicsGoal(target=_point_goal(t.pick_point, *ud.pull), arm=ARM_RIGHT,
                              standoff=float(t.radius))

    def pull_kin_result_cb(ud, status, result):
        if result is None:
            return None
        if not result.reachable:
            # not an error: the left arm then works on the fruit where it hangs
            rospy.logwarn('executive: cannot draw the fruit out (%s); cutting it in place',
                          result.reason)
            return 'unreachable'
        ud.joint_goal = list(result.joint_goal.positions)
        return None

    def pull_move_result_cb(ud, status, result):
        verdict = move_result_cb(ud, status, result)
        if verdict is None and status == 3:
            # the held fruit moved with the suction sleeve: the left arm aims at its new place
            moved = copy.deepcopy(ud.target)
            moved.pick_point = _point_goal(ud.target.pick_point, *ud.pull)
            ud.target = moved
        return verdict

    def held_scan_goal_cb(ud, goal):
        return TomatoScanGoal(picking_point=-1, target_frame=cfg['base_frame'])

    def held_scan_result_cb(ud, status, result):
        if result is None or not result.success:
            return None            # keep the estimate from the first scan
        t = ud.target
        best, best_d = None, relocate_tolerance
        expected = _located(t, t.pick_point.header.frame_id)
        if expected is None:
            return None            # nothing to compare with: keep the first estimate
        for cand in result.tomatoes.tomatoes:
            xyz = _located(cand, t.pick_point.header.frame_id)
            if xyz is None:
                continue
            d = mission_lib.distance(xyz, expected)
            if d <= best_d:
                best, best_d = cand, d
        if best is None:
            rospy.loginfo('executive: held fruit not found again within %.0f mm; keeping its first estimate',
                          relocate_tolerance * 1e3)
            return None
        if best.radius < t.radius:
            # occlusion only shrinks a fitted circle: the first view saw more of this fruit
            rospy.loginfo('executive: held fruit seen again %.1f mm from where it was expected but smaller '
                          '(radius %.1f mm, first scan %.1f mm); keeping its first estimate',
                          best_d * 1e3, best.radius * 1e3, t.radius * 1e3)
            return None
        moved = copy.deepcopy(t)
        moved.pick_point = best.pick_point
        moved.radius = best.radius
        rospy.loginfo('executive: held fruit located again %.1f mm from where it was expected, radius %.1f mm '
                      '(first scan %.1f mm)', best_d * 1e3, best.radius * 1e3, t.radius * 1e3)
        ud.target = moved
        return None

    def kin_result_cb(ud, status, result):
        if result is None:
            return None
        if not result.reachable:
            context.fail('DO_KINEMATICS: unreachable: %s' % result.reason)
            return 'unreachable'
        ud.joint_goal = list(result.joint_goal.positions)
        return None

    def move_goal_cb(arm):
        def cb(ud, goal):
            return MoveRobotGoal(target_joint=_joint_point(ud.joint_goal), arm=arm)
        return cb

    def move_fixed_goal(arm, positions):
        return MoveRobotGoal(target_joint=_joint_point(positions), arm=arm)

    def move_result_cb(ud, status, result):
        if result is not None and result.succeed != 1 and status == 3:
            context.fail('DO_MOVE_ROBOT: move finished with code %d' % result.succeed)
            return 'aborted'
        return None

    def ee_result_cb(ud, status, result):
        if result is not None and not result.success and status == 3:
            context.fail('DO_MOVE_ENDEFFECTOR: %s' % result.message)
            return 'aborted'
        return None

    def servo_goal_cb(ud, goal):
        t = ud.target
        return VisualServoGoal(target=t.pick_point, target_radius=float(t.radius))

    def servo_result_cb(ud, status, result):
        if result is not None and not result.success and status == 3:
            context.fail('DO_VISUALSERVOING: %s' % result.message)
            return 'aborted'
        return None

    home_left = cfg['home']['left']
    box_right = cfg['collection_box_right']

    # --- one target ---------------------------------------------------------------------------
    def right_arm():
        sm = smach.StateMachine(outcomes=['succeeded', 'unreachable', 'lost', 'aborted', 'preempted'],
                                input_keys=['target'], output_keys=['target'])
        sm.userdata.joint_goal = []
        sm.userdata.pull = (0.0, 0.0, 0.0)
        with sm:
            smach.StateMachine.add('DO_KINEMATICS', action(
                'DO_KINEMATICS', 'kinematics', KinematicsAction, goal_cb=kin_goal_cb(ARM_RIGHT),
                input_keys=['target'], output_keys=['joint_goal'], result_cb=kin_result_cb,
                outcomes=['unreachable']),
                transitions={'succeeded': 'DO_MOVE_ROBOT', 'unreachable': 'unreachable'})
            smach.StateMachine.add('DO_MOVE_ROBOT', action(
                'DO_MOVE_ROBOT', 'move_robot', MoveRobotAction, goal_cb=move_goal_cb(ARM_RIGHT),
                input_keys=['joint_goal'], result_cb=move_result_cb),
                transitions={'succeeded': 'DO_MOVE_ENDEFFECTOR'})
            smach.StateMachine.add('DO_MOVE_ENDEFFECTOR', action(
                'DO_MOVE_ENDEFFECTOR', 'end_effector', EndEffectorAction,
                goal=EndEffectorGoal(command=EndEffectorGoal.SUCTION_ON), result_cb=ee_result_cb),
                transitions={'aborted': 'lost',
                             'succeeded': 'CHOOSE_PULL' if do_pull else 'succeeded'})
            if do_pull:
                smach.StateMachine.add('CHOOSE_PULL', ChoosePull(context, pulls, pull_clearance,
                                                                 peduncle_gap, cut_clearance),
                                       transitions={'pull': 'DO_KINEMATICS_PULL', 'none': 'succeeded'})
                smach.StateMachine.add('DO_KINEMATICS_PULL', action(
                    'DO_KINEMATICS', 'kinematics', KinematicsAction, goal_cb=pull_goal_cb,
                    input_keys=['target', 'pull'], output_keys=['joint_goal'], result_cb=pull_kin_result_cb,
                    outcomes=['unreachable']),
                    transitions={'succeeded': 'DO_MOVE_ROBOT_PULL', 'unreachable': 'succeeded'})
                smach.StateMachine.add('DO_MOVE_ROBOT_PULL', action(
                    'DO_MOVE_ROBOT', 'move_robot', MoveRobotAction, goal_cb=move_goal_cb(ARM_RIGHT),
                    input_keys=['joint_goal', 'target', 'pull'], output_keys=['target'],
                    result_cb=pull_move_result_cb),
                    transitions={'succeeded': 'DO_TOMATO_SCAN_HELD' if relocate_tolerance > 0.0
                                 else 'succeeded'})
                if relocate_tolerance > 0.0:
                    # a failed look is not a fault: the left arm works with the first estimate
                    smach.StateMachine.add('DO_TOMATO_SCAN_HELD', action(
                        'DO_TOMATO_SCAN', 'tomato_scan', TomatoScanAction, goal_cb=held_scan_goal_cb,
                        input_keys=['target'], output_keys=['target'], result_cb=held_scan_result_cb),
                        transitions={'aborted': 'succeeded'})
        return sm

    def left_arm():
        sm = smach.StateMachine(outcomes=['succeeded', 'unreachable', 'lost', 'aborted', 'preempted'],
                                input_keys=['target'])
        sm.userdata.joint_goal = []
        with sm:
            smach.StateMachine.add('DO_KINEMATICS', action(
                'DO_KINEMATICS', 'kinematics', KinematicsAction, goal_cb=kin_goal_cb(ARM_LEFT),
                input_keys=['target'], output_keys=['joint_goal'], result_cb=kin_result_cb,
                outcomes=['unreachable']),
                transitions={'succeeded': 'DO_MOVE_ROBOT', 'unreachable': 'unreachable'})
            smach.StateMachine.add('DO_MOVE_ROBOT', action(
                'DO_MOVE_ROBOT', 'move_robot', MoveRobotAction, goal_cb=move_goal_cb(ARM_LEFT),
                input_keys=['joint_goal'], result_cb=move_result_cb),
                transitions={'succeeded': 'DO_VISUALSERVOING'})
            smach.StateMachine.add('DO_VISUALSERVOING', action(
                'DO_VISUALSERVOING', 'visual_servo', VisualServoAction, goal_cb=servo_goal_cb,
                input_keys=['target'], result_cb=servo_result_cb),
                transitions={'succeeded': 'DO_MOVE_ENDEFFECTOR', 'aborted': 'lost'})
            smach.StateMachine.add('DO_MOVE_ENDEFFECTOR', action(
                'DO_MOVE_ENDEFFECTOR', 'end_effector', EndEffectorAction,
                goal=EndEffectorGoal(command=EndEffectorGoal.SHEAR_CUT), result_cb=ee_result_cb))
        return sm

    def place():
        sm = smach.StateMachine(outcomes=['succeeded', 'aborted', 'preempted'])
        with sm:
            smach.StateMachine.add('DO_MOVE_ROBOT', action(
                'DO_MOVE_ROBOT', 'move_robot', MoveRobotAction, goal=move_fixed_goal(ARM_LEFT, home_left),
                result_cb=move_result_cb), transitions={'succeeded': 'DO_MOVE_ROBOT_BOX'})
            smach.StateMachine.add('DO_MOVE_ROBOT_BOX', action(
                'DO_MOVE_ROBOT', 'move_robot', MoveRobotAction, goal=move_fixed_goal(ARM_RIGHT, box_right),
                result_cb=move_result_cb), transitions={'succeeded': 'DO_MOVE_ENDEFFECTOR'})
            smach.StateMachine.add('DO_MOVE_ENDEFFECTOR', action(
                'DO_MOVE_ENDEFFECTOR', 'end_effector', EndEffectorAction,
                goal=EndEffectorGoal(command=EndEffectorGoal.SUCTION_OFF), result_cb=ee_result_cb))
        return sm

    def recover():
        sm = smach.StateMachine(outcomes=['succeeded', 'aborted', 'preempted'])
        with sm:
            smach.StateMachine.add('DO_MOVE_ENDEFFECTOR', action(
                'DO_MOVE_ENDEFFECTOR', 'end_effector', EndEffectorAction,
                goal=EndEffectorGoal(command=EndEffectorGoal.SUCTION_OFF), result_cb=ee_result_cb),
                transitions={'succeeded': 'DO_MOVE_ROBOT'})
            smach.StateMachine.add('DO_MOVE_ROBOT', action(
                'DO_MOVE_ROBOT', 'move_robot', MoveRobotAction, goal=move_fixed_goal(ARM_LEFT, home_left),
                result_cb=move_result_cb))
        return sm

    def pick_target():
        sm = smach.StateMachine(outcomes=['picked', 'unreachable', 'lost', 'aborted', 'preempted'],
                                input_keys=['target'])
        with sm:
            smach.StateMachine.add('RIGHT_ARM', right_arm(), transitions={
                'succeeded': 'LEFT_ARM', 'unreachable': 'unreachable', 'lost': 'RECOVER_LOST'})
            smach.StateMachine.add('LEFT_ARM', left_arm(), transitions={
                'succeeded': 'PLACE', 'unreachable': 'RECOVER_UNREACHABLE', 'lost': 'RECOVER_LOST'})
            smach.StateMachine.add('PLACE', place(), transitions={'succeeded': 'picked'})
            smach.StateMachine.add('RECOVER_LOST', recover(), transitions={'succeeded': 'lost'})
            smach.StateMachine.add('RECOVER_UNREACHABLE', recover(), transitions={'succeeded': 'unreachable'})
        return sm

    # --- scanning -----------------------------------------------------------------------------
    def scan():
        def outcome_cb(outcomes):
            if 'preempted' in outcomes.values():
                return 'preempted'
            if outcomes.get('DO_TOMATO_SCAN') == 'aborted' or outcomes.get('DO_SPATIAL_TEMPORAL') == 'aborted':
                return 'aborted'
            if outcomes.get('DO_TOMATO_SCAN') == 'none':
                return 'none'
            return 'targets'
        cc = smach.Concurrence(outcomes=['targets', 'none', 'aborted', 'preempted'], default_outcome='aborted',
                               input_keys=['picking_point', 'track_position'], output_keys=['targets'],
                               outcome_cb=outcome_cb)
        cc.userdata.targets = []
        with cc:
            smach.Concurrence.add('DO_TOMATO_SCAN', action(
                'DO_TOMATO_SCAN', 'tomato_scan', TomatoScanAction, goal_cb=scan_goal_cb,
                input_keys=['picking_point'], output_keys=['targets'], result_cb=scan_result_cb,
                outcomes=['none']))
            smach.Concurrence.add('DO_SPATIAL_TEMPORAL', action(
                'DO_SPATIAL_TEMPORAL', 'spatial_temporal', SpatialTemporalAction, goal_cb=st_goal_cb,
                input_keys=['picking_point', 'track_position']))
        return cc

    # --- the mission --------------------------------------------------------------------------
    mission = smach.StateMachine(outcomes=['succeeded', 'aborted', 'preempted'])
    mission.userdata.picking_point = -1
    mission.userdata.track_position = 0.0
    mission.userdata.targets = []
    mission.userdata.target = None
    with mission:
        smach.StateMachine.add('DO_START', action(
            'DO_START', 'self_test', StartAction, goal_cb=start_goal_cb, result_cb=start_result_cb),
            transitions={'succeeded': 'NEXT_POINT', 'aborted': 'DO_ERROR'})
        smach.StateMachine.add('NEXT_POINT', NextPoint(context),
                               transitions={'point': 'DO_MOVEBASE', 'done': 'succeeded', 'error': 'DO_ERROR'})
        smach.StateMachine.add('DO_MOVEBASE', action(
            'DO_MOVEBASE', 'move_base', MoveBaseAction, goal_cb=movebase_goal_cb,
            input_keys=['picking_point'], output_keys=['track_position'], result_cb=movebase_result_cb),
            transitions={'succeeded': 'SCAN', 'aborted': 'DO_ERROR'})
        smach.StateMachine.add('SCAN', scan(),
                               transitions={'targets': 'NEXT_TARGET', 'none': 'NEXT_POINT', 'aborted': 'DO_ERROR'})
        smach.StateMachine.add('NEXT_TARGET', NextTarget(context),
                               transitions={'target': 'PICK_TARGET', 'done': 'NEXT_POINT'})
        smach.StateMachine.add('PICK_TARGET', pick_target(), transitions={
            'picked': 'END_PICKED', 'unreachable': 'END_UNREACHABLE', 'lost': 'END_LOST',
            'aborted': 'DO_ERROR'})
        smach.StateMachine.add('END_PICKED', EndFruit(context, mission_lib.OUTCOME_PICKED),
                               transitions={'done': 'NEXT_TARGET'})
        smach.StateMachine.add('END_UNREACHABLE', EndFruit(context, mission_lib.OUTCOME_UNREACHABLE),
                               transitions={'done': 'NEXT_TARGET'})
        smach.StateMachine.add('END_LOST', EndFruit(context, mission_lib.OUTCOME_LOST),
                               transitions={'done': 'NEXT_TARGET'})
        smach.StateMachine.add('DO_ERROR', DoError(context), transitions={'aborted': 'aborted'})

    monitor = EstopMonitor(estop_event)

    def child_termination_cb(outcomes):
        return True  # whichever ends first (mission or emergency stop) ends the other

    def run_outcome_cb(outcomes):
        if outcomes.get('ESTOP_MONITOR') == 'estop':
            return 'estop'
        if outcomes.get('MISSION') == 'succeeded':
            return 'succeeded'
        if outcomes.get('MISSION') == 'preempted':
            return 'preempted'
        return 'aborted'

    run = smach.Concurrence(outcomes=['succeeded', 'aborted', 'preempted', 'estop'], default_outcome='aborted',
                            child_termination_cb=child_termination_cb, outcome_cb=run_outcome_cb)
    with run:
        smach.Concurrence.add('MISSION', mission)
        smach.Concurrence.add('ESTOP_MONITOR', monitor)

    root = smach.StateMachine(outcomes=['succeeded', 'aborted', 'preempted'])
    with root:
        smach.StateMachine.add('RUN', run, transitions={'estop': 'DO_STOP'})
        smach.StateMachine.add('DO_STOP', DoStop(context, estop_event, resume_event),
                               transitions={'resume': 'RUN', 'shutdown': 'preempted'})
    root.estop_monitor = monitor
    return root

