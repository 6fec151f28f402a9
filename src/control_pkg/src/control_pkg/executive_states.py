"""The executive's own SMACH states and the one object they share (see executive.py).

- MissionContext: the mission's explicit shared state besides userdata: configuration,
  progress over the picking points, the mission record, the last scan's scene, the fault text
  and the hooks that publish events and records and halt the axes;
- HarvestActionState: a SimpleActionState with retries, timing into the mission record and a
  failure reason;
- NextPoint, NextTarget, ChoosePull, Decide, EndFruit: the plan's steps
  (executive_plan_states.py, re-exported here);
- DoError, EstopMonitor, DoStop, ResumeRecord: fault, emergency stop and resume
  (executive_stop_states.py, re-exported here).

A state's outcomes and keys are documented in its docstring as
``Outcomes: ...`` / ``Input keys: ...`` / ``Output keys: ...``.
"""
import threading

import rospy

from control_pkg.smach_compat import SimpleActionState
from motion_pkg.motion_goals import ESTOP_HALT_TEXT
from control_pkg import checkpoint as checkpoint_lib
from control_pkg import mission as mission_lib
from control_pkg.executive_plan_states import (  # noqa: F401 - re-exported
    CartAtRest, NextPoint, NextTarget, ChoosePull, Decide, EndFruit, end_fruit)
from control_pkg.executive_stop_states import (  # noqa: F401 - re-exported
    DoError, EstopMonitor, clear_preempts, DoStop, ResumeRecord)


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
        # motion_pkg's robot geometry: the stereo head's eye (stereo_eye) and, in the pipelined
        # schedule (executive_pipelined.py), the collision check of overlapping moves; that
        # schedule also keeps the arms' joint states and the turns of the moves
        self.geometry = None
        self.gate = None
        self._joints = {}
        # (target id, joints) of the cutting hand's standby by a target, once it was sent there
        self.standby = None
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

    def stereo_eye(self, frame='base_link'):
        """(x, y, z) of the stereo head's right eye (stereo_right_optical, where its pick
        points' view rays start) in `frame` (a frame of the robot geometry: the pick points'
        frame; None for another one), from the robot geometry with the waist
        from joint_states (0 until known, as in the paper schedule, which does not subscribe
        them: the head sits 5 cm behind the waist's axis, so half a radian of waist moves it
        2.5 cm, about 3 degrees of the view ray to a fruit half a metre away); None without
        the geometry."""
        if self.geometry is None:
            return None
        poses = self.geometry.frame_transforms({'waist_joint': self.waist() or 0.0})
        # the geometry's root `map` is the cart's start, not where it stands now
        base = poses.get(frame) if frame != 'map' else None
        if base is None:
            return None
        eye = poses['stereo_right_optical'][:3, 3] - base[:3, 3]
        return tuple(float(v) for v in base[:3, :3].T.dot(eye))

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
