"""SimpleActionState for hosts without smach_ros (see control_pkg.smach_compat).

Same constructor signature and the same observable behaviour as smach_ros 2.5's
SimpleActionState, written anew for this workspace. Differences, all deliberate:

- list/dict defaults are None (no shared mutable defaults); passing lists works as before;
- the constructor's default goal is copied for each execution, so a goal_cb that edits the
  goal in place does not leak into the next execution;
- waiting (for the server, the result, a timeout, a preempt) is one Condition, woken by the
  action client callbacks, request_preempt, ROS-time alarms (ros_alarms: timeouts follow
  /use_sim_time; one shared thread, not a rospy.Timer per goal, whose thread would outlive
  the goal by its whole timeout) and rospy shutdown; nothing sleep-polls;
- it drives actionlib's ActionClient and its goal handle directly, not SimpleActionClient:
  SimpleActionClient stores the new goal handle only after the goal is published and drops
  (with "Got a transition callback on a goal handle that we're not tracking") any transition
  that a fast server sends before that; seen here about once per few hundred goals near
  start-up. A dropped DONE would leave the state waiting forever. Callbacks here are tied to
  their goal by closure instead;
- while it waits for its server it hands its node the master's current publishers of the
  action's topics (smach_ros_compat_server.py, the base class ServerWait: why, and how);
- a goal whose server dies (its node killed, to be respawned) ends `aborted` ("action server
  lost") once the server's connection to the goal topic has been gone for two checks
  `SERVER_CHECK_PERIOD` apart (ROS time), instead of waiting out exec_timeout: actionlib sends
  no status for it any more, so its goal handle would never change. The next goal waits for
  the server again (a retry reaches the respawned one);
- a goal the server has not acknowledged yet when every connection it went out on is gone and
  the server (the same node name) is back on a new one ends `aborted` too ("restarted before
  it took the goal"): the server was killed and respawned between the goal's send and its ack,
  so the respawned one never got it, and actionlib's client, which gives up only on goals a
  server has listed, would wait for it until exec_timeout (database_pkg's scan goal had the
  same case: a 30 s stall after an image_processing restart).
"""
import copy
import threading
import traceback

import rospy
from actionlib.action_client import ActionClient, CommState
from actionlib_msgs.msg import GoalStatus

from control_pkg import ros_alarms
from control_pkg.smach_compat import smach
from control_pkg.smach_ros_compat_server import (  # noqa: F401 - RECONNECT_PERIOD ... re-exported
    RECONNECT_PERIOD, SERVER_CHECK_PERIOD, _ACTION_TOPICS, ServerWait, resend_publishers,
    server_connected, server_links)

__all__ = ['SimpleActionState']

_SIXTY_SECONDS = rospy.Duration(60.0)

_STATUS_NAMES = dict((value, name) for name, value in vars(GoalStatus).items()
                     if name.isupper() and isinstance(value, int))


def _duration(value):
    """None, a rospy.Duration or seconds -> None or rospy.Duration."""
    if value is None or isinstance(value, rospy.Duration):
        return value
    return rospy.Duration.from_sec(float(value))


def _status_name(status):
    return _STATUS_NAMES.get(status, 'UNKNOWN (%s)' % (status,))


def _cb_interface(cb, input_keys, output_keys, outcomes):
    """Keys and outcomes a callback may use: its @smach.cb_interface, else the state's."""
    if smach.has_smach_interface(cb):
        return (list(cb.get_registered_input_keys()), list(cb.get_registered_output_keys()),
                list(cb.get_registered_outcomes()))
    return list(input_keys), list(output_keys), list(outcomes)


class SimpleActionState(ServerWait, smach.State):
    """Send one actionlib goal and wait for its result.

    Outcomes:
        succeeded: the server reported SUCCEEDED.
        aborted: the server aborted or rejected the goal, or it was lost, or exec_timeout
            expired (the goal is cancelled), or the server did not appear within
            server_wait_timeout, or it did not answer a cancel within preempt_timeout, or a
            goal/result callback raised.
        preempted: a preempt was requested; the goal (if sent) was cancelled and the
            server confirmed (PREEMPTED or RECALLED), or the client marked it LOST (a status
            from before its acceptance came while the cancel waited for its ack).
        plus every outcome a @smach.cb_interface(outcomes=...) result_cb declares, or the
        `outcomes` argument for an undecorated one.
    Input keys: goal_key, goal_slots, input_keys, and the callbacks' declared input keys.
    Output keys: result_key, result_slots, output_keys, and the callbacks' output keys.

    Callbacks (as in smach_ros):
        goal_cb(userdata, goal, *goal_cb_args, **goal_cb_kwargs) -> new goal or None
            (None keeps the goal, possibly edited in place).
        result_cb(userdata, status, result, *result_cb_args, **result_cb_kwargs)
            -> an outcome string or None (None keeps the status-derived outcome).
        feedback_cb(userdata, feedback, *feedback_cb_args, **feedback_cb_kwargs)
    Each sees the userdata through a Remapper limited to its declared keys.
    """

    def __init__(self,
                 action_name,
                 action_spec,
                 goal=None,
                 goal_key=None,
                 goal_slots=None,
                 goal_cb=None,
                 goal_cb_args=None,
                 goal_cb_kwargs=None,
                 result_key=None,
                 result_slots=None,
                 result_cb=None,
                 result_cb_args=None,
                 result_cb_kwargs=None,
                 input_keys=None,
                 output_keys=None,
                 outcomes=None,
                 exec_timeout=None,
                 preempt_timeout=_SIXTY_SECONDS,
                 server_wait_timeout=_SIXTY_SECONDS,
                 feedback_cb=None,
                 feedback_cb_args=None,
                 feedback_cb_kwargs=None):
        smach.State.__init__(self, outcomes=['succeeded', 'aborted', 'preempted'])
        goal_slots = list(goal_slots or [])
        result_slots = list(result_slots or [])
        input_keys = list(input_keys or [])
        output_keys = list(output_keys or [])
        outcomes = list(outcomes or [])

        self._action_name = action_name
        self._action_spec = action_spec
        spec = action_spec()

        if goal is not None and callable(goal):
            raise smach.InvalidStateError(
                "SimpleActionState '%s': goal must be a goal message, not a callable "
                "(use goal_cb)" % action_name)
        for name, cb in (('goal_cb', goal_cb), ('result_cb', result_cb),
                         ('feedback_cb', feedback_cb)):
            if cb is not None and not callable(cb):
                raise smach.InvalidStateError(
                    "SimpleActionState '%s': %s is not callable" % (action_name, name))
        goal_fields = spec.action_goal.goal.__slots__
        bad = [s for s in goal_slots if s not in goal_fields]
        if bad:
            raise smach.InvalidStateError(
                "SimpleActionState '%s': goal_slots %s are not fields of the goal; its "
                "fields are %s" % (action_name, bad, list(goal_fields)))
        result_fields = spec.action_result.result.__slots__
        bad = [s for s in result_slots if s not in result_fields]
        if bad:
            raise smach.InvalidStateError(
                "SimpleActionState '%s': result_slots %s are not fields of the result; its "
                "fields are %s" % (action_name, bad, list(result_fields)))

        self._goal = spec.action_goal.goal if goal is None else goal
        self._goal_key = goal_key
        self._goal_slots = goal_slots
        self._goal_cb = goal_cb
        self._goal_cb_args = list(goal_cb_args or [])
        self._goal_cb_kwargs = dict(goal_cb_kwargs or {})
        self._result_key = result_key
        self._result_slots = result_slots
        self._result_cb = result_cb
        self._result_cb_args = list(result_cb_args or [])
        self._result_cb_kwargs = dict(result_cb_kwargs or {})
        self._feedback_cb = feedback_cb
        self._feedback_cb_args = list(feedback_cb_args or [])
        self._feedback_cb_kwargs = dict(feedback_cb_kwargs or {})

        if goal_key is not None:
            self.register_input_keys([goal_key])
        self.register_input_keys(goal_slots)
        if result_key is not None:
            self.register_output_keys([result_key])
        self.register_output_keys(result_slots)

        # Each callback's userdata interface; decorated ones extend the state's interface.
        self._goal_cb_keys = _cb_interface(goal_cb, input_keys, output_keys, [])
        self._result_cb_keys = _cb_interface(result_cb, input_keys, output_keys, outcomes)
        self._feedback_cb_keys = _cb_interface(feedback_cb, input_keys, output_keys, [])
        for cb, keys in ((goal_cb, self._goal_cb_keys), (result_cb, self._result_cb_keys),
                         (feedback_cb, self._feedback_cb_keys)):
            if smach.has_smach_interface(cb):
                self.register_input_keys(keys[0])
                self.register_output_keys(keys[1])
        if smach.has_smach_interface(result_cb):
            self.register_outcomes(self._result_cb_keys[2])  # only result_cb picks outcomes
        self.register_input_keys(input_keys)
        self.register_output_keys(output_keys)
        self.register_outcomes(outcomes)

        self._exec_timeout = _duration(exec_timeout)
        self._preempt_timeout = _duration(preempt_timeout)
        self._server_wait_timeout = _duration(server_wait_timeout)

        # One condition guards every flag below and wakes execute() for any event.
        self._cond = threading.Condition()
        self._server_ready = False
        self._server_wait_running = False
        self._goal_id = 0            # which execution the callbacks and timers belong to
        self._goal_done = False
        self._goal_status = None
        self._goal_result = None
        self.goal_status_text = ''   # text of the last goal's final status (the server's reason)
        self._exec_expired = False
        self._cancel_expired = False
        self._server_gone = ''      # why the goal's server is gone (lost, restarted), else ''
        self._ud = None

        self._client = ActionClient(action_name, action_spec)
        rospy.on_shutdown(self._wake)
        # Connect in the background so building a machine does not block on servers.
        if rospy.core.is_initialized():
            self._start_server_wait()

    # ----------------------------------------------------------------- smach API
    def request_preempt(self):
        smach.State.request_preempt(self)
        self._wake()

    def execute(self, ud):
        if not self._connect():
            if self.preempt_requested():
                rospy.loginfo("Action state '%s' preempted while waiting for its server"
                              % self._action_name)
                self.service_preempt()
                return 'preempted'
            rospy.logerr("Action server '%s' did not come up within %.1f s"
                         % (self._action_name, self._timeout_sec(self._server_wait_timeout)))
            return 'aborted'
        if self.preempt_requested():
            rospy.loginfo("Action state '%s' preempted before sending its goal"
                          % self._action_name)
            self.service_preempt()
            return 'preempted'

        goal = self._make_goal(ud)
        if goal is None:
            return 'aborted'

        early_outcome = self._run_goal(ud, goal)
        if early_outcome is not None:
            return early_outcome
        return self._finish(ud)

    # ----------------------------------------------------------------- steps
    @staticmethod
    def _timeout_sec(timeout):
        return timeout.to_sec() if timeout else float('inf')

    def _make_goal(self, ud):
        """The goal for this execution, or None (after logging) if it cannot be built."""
        try:
            if self._goal_key is not None:
                goal = ud[self._goal_key]
                if self._goal_slots:
                    goal = copy.copy(goal)
            else:
                goal = copy.deepcopy(self._goal)
            for key in self._goal_slots:
                setattr(goal, key, ud[key])
            if self._goal_cb is not None:
                in_keys, out_keys, _ = self._goal_cb_keys
                update = self._goal_cb(smach.Remapper(ud, in_keys, out_keys, {}), goal,
                                       *self._goal_cb_args, **self._goal_cb_kwargs)
                if update is not None:
                    goal = update
        except Exception:
            rospy.logerr("Action state '%s' could not build its goal: %s"
                         % (self._action_name, traceback.format_exc()))
            return None
        if goal is None:
            rospy.logerr("Action state '%s' has no goal (no goal, goal_key or goal_cb)"
                         % self._action_name)
        return goal

    def _start_timer(self, timeout, flag, goal_id):
        def expire(_event):
            with self._cond:
                if self._goal_id == goal_id:
                    setattr(self, flag, True)
                    self._cond.notify_all()
        return ros_alarms.call_after(timeout, expire)

    def _run_goal(self, ud, goal):
        """Send the goal and wait for its end; an outcome string if it ended without one."""
        with self._cond:
            self._goal_id += 1
            goal_id = self._goal_id
            self._goal_done = False
            self._goal_status = None
            self._goal_result = None
            self.goal_status_text = ''
            self._exec_expired = False
            self._cancel_expired = False
            self._server_gone = ''
            self._ud = ud
        missing = [0]            # consecutive checks that found the server gone
        sent = [frozenset(), None]   # the server links the goal went out on; its goal handle

        def check_server(_event):
            connected = server_connected(self._client)
            missing[0] = missing[0] + 1 if connected is False else 0
            gone = ''
            if missing[0] >= 2:
                gone = 'action server %s lost while it ran the goal' % self._action_name
            elif sent[0] and sent[1] is not None and \
                    sent[1].get_comm_state() == CommState.WAITING_FOR_GOAL_ACK:
                links = server_links(self._client)
                if links and not (links & sent[0]):
                    gone = ('action server %s restarted before it took the goal (sent to its '
                            'predecessor)' % self._action_name)
            if gone:
                with self._cond:
                    if self._goal_id == goal_id and not self._goal_done:
                        self._server_gone = gone
                        self._cond.notify_all()

        def transition_cb(handle):
            if handle.get_comm_state() != CommState.DONE:
                return
            status = handle.get_goal_status()
            result = handle.get_result()
            text = handle.get_goal_status_text()
            with self._cond:
                if self._goal_id == goal_id:
                    self._goal_done = True
                    self._goal_status = status
                    self.goal_status_text = text
                    self._goal_result = result
                    self._cond.notify_all()

        def feedback_cb(_handle, feedback):
            with self._cond:
                ud = self._ud if self._goal_id == goal_id else None
            if ud is not None:
                self._on_feedback(ud, feedback)

        timers = []
        handle = self._client.send_goal(goal, transition_cb, feedback_cb)
        sent[:] = [server_links(self._client), handle]
        if self._exec_timeout:
            timers.append(self._start_timer(self._exec_timeout, '_exec_expired', goal_id))
        timers.append(ros_alarms.call_every(SERVER_CHECK_PERIOD, check_server))
        cancel_sent = False
        outcome = None
        try:
            while True:
                with self._cond:
                    while not (self._goal_done or self._cancel_expired or rospy.is_shutdown()
                               or self._server_gone
                               or (not cancel_sent
                                   and (self._exec_expired or self.preempt_requested()))):
                        self._cond.wait()
                    done = self._goal_done
                    cancel_expired = self._cancel_expired
                    gone = self._server_gone
                if done:
                    break
                if gone:
                    rospy.logerr("Action state: %s" % gone)
                    with self._cond:
                        self.goal_status_text = gone
                        self._server_ready = False     # the next goal waits for it again
                    outcome = 'aborted'
                    break
                if rospy.is_shutdown() or cancel_expired:
                    if cancel_expired:
                        rospy.logerr("Action '%s' did not end within %.1f s of its cancel; "
                                     "giving up on the goal" % (
                                         self._action_name,
                                         self._timeout_sec(self._preempt_timeout)))
                    outcome = 'aborted'   # the handle is dropped below: no more callbacks
                    break
                # Preempt or execution timeout: cancel once, then wait for the result.
                if self.preempt_requested():
                    rospy.loginfo("Action state '%s' preempted: cancelling its goal"
                                  % self._action_name)
                else:
                    rospy.logwarn("Action '%s' timed out after %.1f s: cancelling its goal" % (
                        self._action_name, self._exec_timeout.to_sec()))
                handle.cancel()
                cancel_sent = True
                if self._preempt_timeout:
                    timers.append(self._start_timer(self._preempt_timeout,
                                                    '_cancel_expired', goal_id))
        finally:
            for timer in timers:
                timer.shutdown()
            with self._cond:
                self._goal_id += 1   # late callbacks and timers of this goal are ignored
                self._ud = None
        return outcome

    def _finish(self, ud):
        """Outcome of a goal that ended: result_cb, result keys, status mapping."""
        status = self._goal_status
        result = self._goal_result
        cb_outcome = None
        if self._result_cb is not None:
            in_keys, out_keys, _ = self._result_cb_keys
            try:
                cb_outcome = self._result_cb(smach.Remapper(ud, in_keys, out_keys, {}),
                                             status, result,
                                             *self._result_cb_args, **self._result_cb_kwargs)
            except Exception:
                rospy.logerr("Result callback of action state '%s' raised: %s"
                             % (self._action_name, traceback.format_exc()))
                return 'aborted'
            if cb_outcome is not None and cb_outcome not in self.get_registered_outcomes():
                rospy.logerr("Result callback of action state '%s' returned '%s', which is "
                             "not a registered outcome %s" % (
                                 self._action_name, cb_outcome,
                                 sorted(self.get_registered_outcomes())))
                return 'aborted'

        if self._result_key is not None:
            ud[self._result_key] = result
        if self._result_slots:
            if result is None:
                rospy.logwarn("Action '%s' ended %s without a result: result_slots not set"
                              % (self._action_name, _status_name(status)))
            else:
                for key in self._result_slots:
                    ud[key] = getattr(result, key)

        if status == GoalStatus.SUCCEEDED:
            outcome = 'succeeded'
        elif (status in (GoalStatus.PREEMPTED, GoalStatus.RECALLED)
              and self.preempt_requested()):
            self.service_preempt()
            outcome = 'preempted'
        elif status == GoalStatus.LOST and self.preempt_requested():
            # actionlib's client marks a goal LOST when, with its cancel waiting for an ack, a
            # status array from before the goal's acceptance comes in (a busy machine: the
            # preempt came before the client heard the goal was accepted). The cancel went out
            # and reaches the server, so this is the preempt, not a failure of the action.
            rospy.logwarn("Action '%s': goal LOST after its cancel (status from before its "
                          "acceptance): taken as preempted" % self._action_name)
            self.service_preempt()
            outcome = 'preempted'
        else:
            # Includes a cancel caused by exec_timeout: that is a failure, not a preempt.
            outcome = 'aborted'
            rospy.logwarn("Action '%s' ended %s" % (self._action_name, _status_name(status)))
        return outcome if cb_outcome is None else cb_outcome

    # ----------------------------------------------------------------- feedback
    def _on_feedback(self, ud, feedback):
        if self._feedback_cb is None:
            return
        in_keys, out_keys, _ = self._feedback_cb_keys
        try:
            self._feedback_cb(smach.Remapper(ud, in_keys, out_keys, {}), feedback,
                              *self._feedback_cb_args, **self._feedback_cb_kwargs)
        except Exception:
            rospy.logerr_throttle(5.0, "Feedback callback of action state '%s' raised: %s"
                                  % (self._action_name, traceback.format_exc()))
