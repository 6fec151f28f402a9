"""The executive's own SMACH states and the one object they share (see executive.py).

- MissionContext: the mission's explicit shared state besides userdata: configuration,
  progress over the picking points, the mission record, the last scan's scene, the fault text
  and the hooks that publish events and records and halt the axes;
- HarvestActionState: a SimpleActionState with retries, timing into the mission record and a
  failure reason;
- NextPoint, NextTarget, ChoosePull, EndFruit: the plan's steps;
- DoError, EstopMonitor, DoStop: fault, emergency stop and resume.

A state's outcomes and keys are documented in its docstring as
``Outcomes: ...`` / ``Input keys: ...`` / ``Output keys: ...``.
"""
import threading

import rospy

from control_pkg.smach_compat import smach, SimpleActionState
from motion_pkg.motion_goals import ESTOP_HALT_TEXT
from control_pkg import checkpoint as checkpoint_lib
from control_pkg import mission as mission_lib


class MissionContext(object):
    """What the states share besides userdata: configuration, progress, record and logging hooks."""

    def __init__(self, config, progress, recorder, publish_event=None, publish_record=None, halt=None,
                 checkpoint=None):
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
        # the pipelined schedule (executive_pipelined.py): motion_pkg's robot geometry for the
        # collision check of overlapping moves, the arms' joint states, the turns of the moves
        self.geometry = None
        self.gate = None
        self._joints = {}
        # crash-safe continuation (checkpoint.py): the progress as it goes (published at every
        # transition that matters), the plan of a resumed mission and the targets recorded
        # before the restart, per picking point (positions, skipped after the scan there)
        self.checkpoint = checkpoint or checkpoint_lib.CheckpointKeeper(recorder.mission_id)
        self.resume = None
        self.resume_snapshot = None
        self.skip = {}
        # true while an emergency stop is requested (executive_node: its stop event): a goal the
        # stop's halt aborted is the stop's, not a fault (no retry, no DO_ERROR)
        self.stopping = lambda: False
        # called with a source when a goal comes back aborted by the emergency stop topic's
        # halt (motion_server heard the stop before this node did): the stop is then taken
        # here as well (executive_node: request_stop), so the abort is the stop's, not a fault
        self.request_stop = lambda source: None
        # why the fruit being placed was not on the cup when the valve closed over the box (set
        # by that SUCTION_OFF's result, executive_goals.dropped_on_the_way): its record, picked
        # by the graph's outcome, is then `dropped` (EndFruit, ResumeRecord); None otherwise
        self.dropped = None

    def set_joints(self, names, positions):
        """Merge a (partial) joint_states message."""
        with self.lock:
            self._joints.update(zip(names, positions))

    def waist(self):
        """The waist angle (rad) from joint_states, None until known."""
        with self.lock:
            value = self._joints.get('waist_joint')
        return None if value is None else float(value)

    def arm_joints(self, arm):
        """(lift, boom, forearm) of arm 'left' / 'right' from joint_states, None until known."""
        names = ['%s_%s_joint' % (arm, j) for j in ('lift', 'boom', 'forearm')]
        with self.lock:
            values = [self._joints.get(n) for n in names]
        if any(v is None for v in values):
            return None
        return tuple(float(v) for v in values)

    def now(self):
        return rospy.get_time()

    def fail(self, reason):
        with self.lock:
            self.last_error = reason
        self.recorder.note_error(reason)

    def close_interrupted(self, why, keep_point=None, record=None):
        """Close and publish the records an emergency stop left open (MissionRecorder
        .close_interrupted), but those of `keep_point`: `failed`, INTERRUPTED and `why`."""
        for fruit in self.recorder.close_interrupted(
                '%s; %s' % (mission_lib.INTERRUPTED, why), keep_point, record):
            self.publish_record(fruit)
            rospy.loginfo('executive: target %d %s (%s)', fruit.target_id, fruit.outcome,
                          fruit.reason)


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


class MoveGate(object):
    """Arm moves that must take turns. With `per_arm` (concurrent_arm_moves: motion_pkg's
    move_robot runs one goal per arm at once) an arm's moves, and the visual servo's moves of
    the left arm, wait only for that arm; without it (a one-goal motion server, where a second
    goal replaces the first) every arm move waits until no other one runs.
    A waiting state is woken by its preemption (`wake`), never polled."""

    def __init__(self, per_arm=False):
        self.per_arm = bool(per_arm)
        self._cond = threading.Condition()
        self._busy = set()
        self._first = None

    def _key(self, arm):
        return arm if self.per_arm else 'arms'

    def first(self, arm):
        """Taking turns: `arm` moves first (an overlap's start; its other arm waits for that
        move even when it asks first); None: whoever asks first. Nothing with `per_arm`."""
        with self._cond:
            self._first = None if self.per_arm else arm
            self._cond.notify_all()

    def acquire(self, arm, cancelled):
        """Wait for `arm`'s turn; False (nothing taken) as soon as `cancelled()` is true."""
        key = self._key(arm)
        with self._cond:
            while key in self._busy or self._first not in (None, arm):
                if cancelled():
                    return False
                self._cond.wait()
            if cancelled():
                return False
            self._busy.add(key)
            self._first = None
            return True

    def release(self, arm):
        with self._cond:
            self._busy.discard(self._key(arm))
            self._cond.notify_all()

    def wake(self):
        with self._cond:
            self._cond.notify_all()


class HarvestActionState(SimpleActionState):
    """A SimpleActionState with retries, timing into the mission record and a failure reason.

    Outcomes: succeeded, aborted, preempted, plus the extra ones given.
    Retries re-send the goal after an `aborted` outcome (not after a preemption or another outcome).
    With a `gate` (MoveGate) the state waits for `gate_arm`'s turn before its first goal (the
    wait counts in its time) and gives it back when it ends.
    """

    def __init__(self, context, label, action_name, action_spec, retries, exec_timeout,
                 server_wait_timeout, gate=None, gate_arm=None, **kwargs):
        SimpleActionState.__init__(
            self, action_name, action_spec,
            exec_timeout=rospy.Duration(exec_timeout),
            server_wait_timeout=rospy.Duration(server_wait_timeout),
            preempt_timeout=rospy.Duration(5.0), **kwargs)
        self._context = context
        self._label = label
        self._retries = max(0, int(retries))
        self._action_name = action_name
        self._gate = gate
        self._gate_arm = gate_arm

    def request_preempt(self):
        SimpleActionState.request_preempt(self)
        if self._gate is not None:
            self._gate.wake()

    def execute(self, ud):
        if self._gate is None:
            return self._execute(ud)
        start = self._context.now()
        if not self._gate.acquire(self._gate_arm,
                                  lambda: self.preempt_requested() or rospy.is_shutdown()):
            self.service_preempt()
            self._context.recorder.add_state(self._label, max(0.0, self._context.now() - start))
            return 'preempted'
        try:
            return self._execute(ud, start)
        finally:
            self._gate.release(self._gate_arm)

    def _execute(self, ud, start=None):
        start = self._context.now() if start is None else start
        errors_before = len(self._context.recorder.errors)
        outcome = 'aborted'
        for attempt in range(self._retries + 1):
            outcome = SimpleActionState.execute(self, ud)
            if outcome == 'aborted' and ESTOP_HALT_TEXT in _status_text(self):
                self._context.request_stop('%s (%s: %s)' % (self._label, self._action_name,
                                                            ESTOP_HALT_TEXT))
            if outcome != 'aborted' or self.preempt_requested() or rospy.is_shutdown() or \
                    self._context.stopping():
                break
            if attempt < self._retries:
                rospy.logwarn('%s: %s aborted (%s), retry %d of %d', self._label, self._action_name,
                              _status_text(self) or 'no reason given', attempt + 1, self._retries)
        if outcome == 'aborted' and len(self._context.recorder.errors) == errors_before and \
                not self._context.stopping():
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

    Outcomes: as given. Input keys: as given.
    """

    def __init__(self, decide, outcomes, input_keys=()):
        smach.State.__init__(self, outcomes=list(outcomes), input_keys=list(input_keys))
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
