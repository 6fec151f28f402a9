"""The executive's own states of the plan's steps (see executive.py): WAIT_CART, NEXT_POINT,
NEXT_TARGET, CHOOSE_PULL, the decisions between branches (Decide) and END_* (EndFruit, end_fruit).

Each takes the mission's shared object (executive_states.MissionContext). A state's outcomes and
keys are documented in its docstring as ``Outcomes: ...`` / ``Input keys: ...`` /
``Output keys: ...``. Re-exported by control_pkg.executive_states.
"""
import threading

import rospy
from actionlib_msgs.msg import GoalStatusArray

from control_pkg.smach_compat import smach
from control_pkg import executive_goals as goals
from control_pkg import mission as mission_lib
from control_pkg import ros_alarms


class CartAtRest(smach.State):
    """WAIT_CART: wait until the cart is at rest, before the mission's first arm move.

    motion_pkg's cart interlock refuses an arm move while the cart moves. A cart move can still
    be running when a mission starts: a restarted task planner's predecessor sent it (the goal
    runs on in motion_server), or the dashboard's manual panel did. This state waits until the
    move_base server's goal statuses (`status_topic`) list no running goal, whoever sent it.
    No status within `status_wait` (ROS time; the server is not up): go on (DO_START's self-test
    finds a missing server). Still moving after `timeout` (0: no limit): error.

    Outcomes: at_rest, error, preempted (an emergency stop)
    """

    def __init__(self, context, status_topic, timeout, status_wait=2.0):
        smach.State.__init__(self, outcomes=['at_rest', 'error', 'preempted'])
        self._context = context
        self._timeout = float(timeout)
        self._status_wait = float(status_wait)
        self._cond = threading.Condition()
        self._running = None            # goal ids of the latest status; None: none came yet
        self._expired = None
        self._sub = rospy.Subscriber(status_topic, GoalStatusArray, self._on_status,
                                     queue_size=1)

    def _on_status(self, msg):
        running = goals.running_goals(msg)
        with self._cond:
            self._running = running
            self._cond.notify_all()

    def _alarm(self, which):
        def fire(_event):
            with self._cond:
                if self._expired is None:
                    self._expired = which
                self._cond.notify_all()
        return fire

    def request_preempt(self):
        smach.State.request_preempt(self)
        with self._cond:
            self._cond.notify_all()

    def execute(self, ud):
        with self._cond:
            self._expired = None
        alarms = [ros_alarms.call_after(rospy.Duration.from_sec(self._status_wait),
                                        self._alarm('status'))]
        if self._timeout > 0.0:
            alarms.append(ros_alarms.call_after(rospy.Duration.from_sec(self._timeout),
                                                self._alarm('timeout')))
        logged = False
        try:
            with self._cond:
                while not rospy.is_shutdown() and not self.preempt_requested():
                    if self._running == []:
                        return 'at_rest'
                    if self._running is None and self._expired is not None:
                        rospy.logwarn('executive: no status of the move_base server within '
                                      '%.1f s; going on', self._status_wait)
                        return 'at_rest'
                    if self._expired == 'timeout':
                        self._context.fail('WAIT_CART: the cart still moves after %.0f s (a '
                                           'move_base goal is running: %s)' % (
                                               self._timeout, ', '.join(self._running)))
                        return 'error'
                    if self._running and not logged:
                        logged = True
                        rospy.loginfo('executive: the cart is moving (a move_base goal of '
                                      'another client); the arms wait until it stops')
                    self._cond.wait(0.5)
        finally:
            for alarm in alarms:
                alarm.shutdown()
        self.service_preempt()
        return 'preempted'


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
        # a fruit an emergency stop cut short at the point left behind was not tried again
        self._context.close_interrupted('not tried again after the resume (not among the '
                                        'targets of its picking point)', keep_point=point)
        if point is None:
            return 'done'
        ud.picking_point = point
        progress = self._context.progress
        self._context.checkpoint.point(progress.points, progress.index)
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
        record = self._context.recorder.begin_fruit(ud.picking_point, target.id, (p.x, p.y, p.z),
                                                    self._context.now())
        self._context.checkpoint.target(target.id, (p.x, p.y, p.z))
        rospy.loginfo('executive: target %d (order %d) at (%.3f, %.3f, %.3f) in %s%s', target.id,
                      target.pick_order, p.x, p.y, p.z, target.pick_point.header.frame_id,
                      ', attempt %d: the emergency stop cut the last one short' % record.attempts
                      if record.interruptions else '')
        return 'target'


class ChoosePull(smach.State):
    """Choose how to draw the held fruit out of its cluster: the first of the configured pulls
    that keeps it (and the cut point above it) clear of the other tomatoes of the last scan.

    Outcomes: pull, none (no pull is clear: the fruit is cut where it hangs)
    Input keys: target
    Output keys: pull
    """

    def __init__(self, context, candidates, clearance, cut_height, cut_clearance, clear_key=None):
        """clear_key: an output key set to [] first (the pipelined schedule's pull joints, so
        none is left from the previous fruit when no pull is chosen)."""
        keys = ['pull'] + ([clear_key] if clear_key else [])
        smach.State.__init__(self, outcomes=['pull', 'none'], input_keys=['target'], output_keys=keys)
        self._clear_key = clear_key
        self._context = context
        self._candidates = candidates
        self._clearance = clearance
        self._cut_height = cut_height
        self._cut_clearance = cut_clearance

    def execute(self, ud):
        if self._clear_key:
            ud[self._clear_key] = []
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


class Decide(smach.State):
    """A decision between branches of the graph: `decide(ud)` (the executive's callbacks, over
    pure functions) returns one of `outcomes`.

    Outcomes: as given. Input and output keys: as given.
    """

    def __init__(self, decide, outcomes, input_keys=(), output_keys=()):
        smach.State.__init__(self, outcomes=list(outcomes), input_keys=list(input_keys),
                             output_keys=list(output_keys))
        self._decide = decide

    def execute(self, ud):
        return self._decide(ud)


class EndFruit(smach.State):
    """Close the current fruit's record with a fixed outcome.

    Outcomes: done
    """

    def __init__(self, context, outcome):
        smach.State.__init__(self, outcomes=['done'])
        self._context = context
        self._outcome = outcome

    def execute(self, ud):
        end_fruit(self._context, self._outcome)
        return 'done'


def end_fruit(context, outcome):
    """Close the current fruit's record with `outcome` (picked becomes dropped when the valve
    closed over the box with no vacuum), publish it and mark it done in the checkpoint."""
    dropped = context.dropped
    context.dropped = None
    reason = '' if outcome == mission_lib.OUTCOME_PICKED else context.last_error
    if outcome == mission_lib.OUTCOME_PICKED and dropped:
        outcome, reason = mission_lib.OUTCOME_DROPPED, dropped
    record = context.recorder.end_fruit(outcome, context.now(), reason)
    if record is not None and outcome in (mission_lib.OUTCOME_PICKED, mission_lib.OUTCOME_DROPPED):
        context.gone.add(record.target_id)       # off the plant either way
    if record is not None:
        context.publish_record(record)
        # after the record: a restart between the two finds the record in the store
        context.checkpoint.target_done(record.target_id, record.position)
        rospy.loginfo('executive: target %d %s after %.1f s%s', record.target_id, record.outcome,
                      record.cycle_time, (' (%s)' % reason) if reason else '')
    return record
