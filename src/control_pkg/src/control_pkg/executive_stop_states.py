"""The executive's own states of a mission that stops (see executive.py): DO_ERROR (DoError), the
emergency stop (ESTOP_MONITOR: EstopMonitor, DO_STOP: DoStop, clear_preempts for the resume) and
RESUME's record of the fruit held when the task planner restarted (ResumeRecord).

Each takes the mission's shared object (executive_states.MissionContext). A state's outcomes and
keys are documented in its docstring as ``Outcomes: ...``. Re-exported by
control_pkg.executive_states.
"""
import threading

import rospy

from control_pkg.smach_compat import smach
from control_pkg import checkpoint as checkpoint_lib
from control_pkg import mission as mission_lib
from control_pkg.executive_plan_states import end_fruit


class DoError(smach.State):
    """DO_ERROR: bring the robot to a safe state (halt every axis) and record why.

    Outcomes: aborted
    """

    def __init__(self, context):
        smach.State.__init__(self, outcomes=['aborted'])
        self._context = context

    def execute(self, ud):
        if self._context.stopping():
            # the emergency stop's halt ended a move before the stop monitor ended the mission:
            # DO_STOP halts, records the fruit and pauses; this is not a fault
            rospy.loginfo('executive: an emergency stop is under way: DO_ERROR leaves it to DO_STOP')
            return 'aborted'
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
        rospy.on_shutdown(self._wake.set)

    def execute(self, ud):
        # no polling: whoever sets the stop event calls wake() after it; a preempt and rospy's
        # shutdown wake it too
        self._wake.clear()
        while not rospy.is_shutdown():
            if self._estop.is_set():
                return 'estop'
            if self.preempt_requested():
                self.service_preempt()
                return 'preempted'
            self._wake.wait()
            self._wake.clear()
        return 'preempted'

    def request_preempt(self):
        smach.State.request_preempt(self)
        self._wake.set()

    def wake(self):
        self._wake.set()


def clear_preempts(state):
    """Service every pending preempt request in a state's tree (containers' children too).

    A preempt that reaches a state just as it finishes stays pending on it; left there, the
    state would end 'preempted' at once the next time it runs. After an emergency stop, when
    nothing in the mission runs any more, the mission starts again with none pending."""
    if state.preempt_requested():
        state.service_preempt()
    get_children = getattr(state, 'get_children', None)
    if get_children is not None:
        for child in get_children().values():
            clear_preempts(child)


class DoStop(smach.State):
    """DO_STOP: emergency stop. Halts every axis and pauses the mission until a resume command.
    The fruit being picked keeps one record: open until it is taken again after the resume
    (MissionRecorder.interrupt), or closed picked when it was already in the box.

    Outcomes: resume (continue from the interrupted picking point and target), shutdown (the
      node shuts down: its shutdown hook preempts the machine and sets the resume event only to
      wake this state, which then does not resume)
    """

    def __init__(self, context, estop_event, resume_event, resumed=None):
        """resumed: the container that a resume runs again (its stale preempts are cleared)."""
        smach.State.__init__(self, outcomes=['resume', 'shutdown'])
        self._context = context
        self._estop = estop_event
        self._resume = resume_event
        self._resumed = resumed

    def execute(self, ud):
        c = self._context
        ok, message = c.halt()
        rospy.logwarn('executive: DO_STOP: emergency stop, axes halted: %s (%s); paused until resume', ok, message)
        detail = 'axes halted: %s' % message
        phase = c.checkpoint.current.phase
        if c.recorder.current is not None and phase == checkpoint_lib.PHASE_PLACED:
            # the valve had closed over the box: the stop cut nothing short of this pick
            end_fruit(c, mission_lib.OUTCOME_PICKED)
        else:
            # one fruit, one record: it stays open until the fruit is tried again after the
            # resume (MissionRecorder.interrupt), or is closed `failed` if it is not
            record = c.recorder.interrupt(c.now())
            if record is not None:
                detail += '; target %d at picking point %d interrupted (attempt %d)' % (
                    record.target_id, record.picking_point, record.interruptions)
            if record is not None and phase == checkpoint_lib.PHASE_PLACE:
                # cut and on the suction cup: not on the plant, so not tried again
                c.close_interrupted('cut and held when it came', record=record)
                detail += ', cut and held: recorded failed'
            elif record is not None:
                detail += ', its record open until it is tried again'
        c.publish_event('estop', 'DO_STOP', detail)
        c.progress.mark_interrupted()
        self._resume.wait()
        if rospy.is_shutdown() or self.preempt_requested():
            if self.preempt_requested():
                self.service_preempt()
            return 'shutdown'
        self._resume.clear()
        self._estop.clear()
        if self._resumed is not None:
            clear_preempts(self._resumed)
        self._context.publish_event('resume', 'DO_STOP', 'mission resumed')
        rospy.loginfo('executive: resumed')
        return 'resume'


class ResumeRecord(smach.State):
    """After a restart: the record of the fruit the previous run was holding (the resume plan's
    `record`, or `record_if_failed` with `failed`), once; nothing when the plan has none (its
    record was out already, or the fruit went back onto the plant).

    Outcomes: done
    """

    def __init__(self, context, failed=False):
        smach.State.__init__(self, outcomes=['done'])
        self._context = context
        self._failed = failed

    def execute(self, ud):
        c = self._context
        plan, snap = c.resume, c.resume_snapshot
        outcome = None if plan is None else (plan.record_if_failed if self._failed else plan.record)
        if outcome is None or snap is None or snap.target_id < 0 or snap.target_position is None:
            return 'done'
        reason = ('' if outcome == mission_lib.OUTCOME_PICKED else
                  'released after a restart of the task planner: it could not be placed (%s)'
                  % (c.last_error or 'no reason given'))
        if outcome == mission_lib.OUTCOME_PICKED and c.dropped:
            outcome, reason = mission_lib.OUTCOME_DROPPED, c.dropped
        c.dropped = None
        now = c.now()
        c.recorder.begin_fruit(snap.picking_point, snap.target_id, snap.target_position, now)
        record = c.recorder.end_fruit(outcome, now, reason)
        c.publish_record(record)
        c.checkpoint.target_done(record.target_id, record.position)
        # placed or dropped, it is not on the plant any more: the new scan does not try it
        c.skip.setdefault(snap.picking_point, []).append(tuple(record.position))
        c.resume.record = c.resume.record_if_failed = None      # once
        rospy.loginfo('executive: held fruit %d of the previous run %s%s', record.target_id,
                      outcome, (' (%s)' % reason) if reason else '')
        return 'done'
