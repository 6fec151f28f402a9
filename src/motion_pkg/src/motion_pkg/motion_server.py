"""ROS node ``motion_server``: owns the Modbus TCP connection to the multi-axis controller.

A poll thread (``~poll_rate``, ROS time) reads the controller, publishes ``joint_states``,
advances the goal monitors, keeps ``motion_status`` and the diagnostics up to date and
reconnects with back-off after a lost connection. Action goals are handled in goal callbacks
(commands are written at once; the poll thread finishes the goal), so a goal costs no
actionlib polling latency. ``move_robot`` is a plain ActionServer that runs one goal per arm at
the same time (a waist goal belongs to both arms; ``motion_goals.ArmGoals``); ``move_base`` and
``end_effector`` run one goal at a time (SimpleActionServer).

Publications:  joint_states (sensor_msgs/JointState), motion_status (diagnostic_msgs/
               DiagnosticStatus, latched, on change), /diagnostics (diagnostic_updater)
Subscriptions: emergency_stop (std_msgs/Bool): every true halts every axis and aborts the move
               goals with motion_goals.ESTOP_HALT_TEXT, so a stop halts the robot even while
               the executive is down (it also halts through halt_all, and pauses the mission)
Services:      halt_all, enable_all (std_srvs/Trigger)
Actions:       move_robot (harvest_msgs/MoveRobot), move_base (harvest_msgs/MoveBase),
               end_effector (harvest_msgs/EndEffector)
Parameters:    see config/motion_server.yaml (all private).
"""

import functools
import math
import os
import threading

import actionlib
import diagnostic_updater
import rospkg
import rospy
from actionlib_msgs.msg import GoalStatus
from diagnostic_msgs.msg import DiagnosticStatus, KeyValue
from harvest_msgs.msg import (EndEffectorAction, EndEffectorFeedback, EndEffectorGoal,
                              EndEffectorResult, MoveBaseAction, MoveBaseFeedback,
                              MoveBaseResult, MoveRobotAction, MoveRobotFeedback,
                              MoveRobotResult)
from sensor_msgs.msg import JointState
from std_msgs.msg import Bool
from std_srvs.srv import Trigger, TriggerResponse

from motion_pkg import motion_goals as mg
from motion_pkg.modbus_driver import ConnectionLost, ControllerRefused, DriverError, ModbusDriver
from motion_pkg.modbus_map import RegisterMap, parse_serial_number
from harvest_description import robot_config

POLL_RATE_TOLERANCE = 0.2          # diagnostics: poll rate within +-20 % of ~poll_rate is OK
POLL_RATE_WINDOW = 10              # diagnostics: averaging window (updates)
LEVEL_NAMES = {0: 'OK', 1: 'WARN', 2: 'ERROR'}


def _package_file(package, *parts):
    return os.path.join(rospkg.RosPack().get_path(package), *parts)


def _internal_error(action, exc):
    """Outcome of a goal that failed on an unexpected error (logged with its traceback)."""
    rospy.logerr('%s goal failed on an internal error: %r', action, exc, exc_info=True)
    return mg.Outcome(False, mg.FAILURE, 'internal error: %s' % exc)


class _Active(object):
    """One running goal: its server, goal handle, monitor and how to finish it."""

    def __init__(self, key, handle, monitor, finish, feedback, resend=None):
        self.key = key
        self.handle = handle
        self.monitor = monitor
        self.finish = finish        # callable(handle, outcome, state)
        self.feedback = feedback    # callable(handle, monitor, state) or None
        self.resend = resend        # callable(): writes the goal's commands again after a link
        #                             outage (absolute targets, a valve state); None: aborted then


class MotionServer(object):
    """Modbus driver + action servers + status of the motion system."""

    def __init__(self):
        self.regmap = RegisterMap.from_file(
            rospy.get_param('~register_map', '') or
            _package_file('motion_pkg', 'config', 'register_map.yaml'))
        # a bad robot.yaml: one fatal line naming file and field, exit 1 (nothing connects)
        self.limits = mg.limits_from_robot_config(robot_config.load_or_exit(
            rospy.get_param('~robot_config', '') or
            _package_file('harvest_description', 'config', 'robot.yaml'), rospy.logfatal))
        missing = [a for a in self.regmap.axis_names if a not in self.limits]
        if missing:
            raise ValueError('axes %s of the register map are not in robot.yaml' % missing)
        try:          # the one controller this robot drives (identity block, serial number)
            serial_number = parse_serial_number(rospy.get_param('~controller_serial', 1))
        except ValueError as exc:
            rospy.logfatal('~controller_serial: %s', exc)     # one fatal line, exit 1
            raise SystemExit(1)
        self.driver = ModbusDriver(
            self.regmap, rospy.get_param('~host', '127.0.0.1'), rospy.get_param('~port', 502),
            rospy.get_param('~unit_id', 1), rospy.get_param('~response_timeout', 0.25),
            rospy.get_param('~reconnect_backoff_min', 0.1),
            rospy.get_param('~reconnect_backoff_max', 2.0), serial_number)
        self._refusal_logged = ''
        self.endpoint = '%s:%d' % (self.driver.host, self.driver.port)
        self.poll_rate = float(rospy.get_param('~poll_rate', 60.0))
        self.stale_timeout = float(rospy.get_param('~stale_timeout', 0.5))
        self.auto_enable = bool(rospy.get_param('~auto_enable', True))
        self.tol_linear = float(rospy.get_param('~tolerance_linear', 0.001))
        self.tol_angular = float(rospy.get_param('~tolerance_angular', math.radians(0.2)))
        self.timeout_factor = float(rospy.get_param('~move_timeout_factor', 1.5))
        self.timeout_margin = float(rospy.get_param('~move_timeout_margin', 2.0))
        self.suction_timeout = float(rospy.get_param('~suction_timeout', 2.0))
        self.shear_timeout = float(rospy.get_param('~shear_timeout', 2.0))
        # a lost Modbus link: running goals wait this long (ROS time) for the driver to connect
        # again, then their commands are written again and they go on (0: aborted at once)
        self.link_grace = float(rospy.get_param('~link_grace', 5.0))
        if not math.isfinite(self.link_grace) or self.link_grace < 0.0:
            raise ValueError('~link_grace must be finite and >= 0, got %r' % self.link_grace)
        self._link_lost_at = None             # ROS time the link was lost, until it is back
        self._link_error = ''                 # why it was lost
        self.points_param = rospy.get_param('~picking_points_param', '/track/picking_points')

        self._lock = threading.Lock()          # guards _active, _arm_goals, _state, _poll_index
        self._poll_lock = threading.Lock()     # one poll at a time (poll thread, goal callbacks)
        self._active = {}                      # move_base, end_effector: server name -> _Active
        self._arm_goals = mg.ArmGoals()        # move_robot: a running goal per arm
        self._deferred = []                    # (server, call) left to the poll thread
        self._state = None
        self._poll_index = 0
        self._last_good = None
        self._poll_error = ''
        self._last_status = None
        self._status_lock = threading.Lock()
        self._stop = threading.Event()

        self.joint_pub = rospy.Publisher('joint_states', JointState, queue_size=10)
        self.status_pub = rospy.Publisher('motion_status', DiagnosticStatus, queue_size=1,
                                          latch=True)
        self._setup_diagnostics()
        self._publish_status()
        rospy.Service('halt_all', Trigger, self._on_halt_all)
        rospy.Subscriber('emergency_stop', Bool, self._on_emergency_stop, queue_size=10)
        rospy.Service('enable_all', Trigger, self._on_enable_all)
        self.move_robot = actionlib.ActionServer('move_robot', MoveRobotAction,
                                                 self._goal_move_robot, self._cancel_move_robot,
                                                 auto_start=False)
        self.move_robot.start()
        self.move_base = self._action('move_base', MoveBaseAction, self._goal_move_base)
        self.end_effector = self._action('end_effector', EndEffectorAction,
                                         self._goal_end_effector)
        self._thread = threading.Thread(target=self._poll_loop, name='motion_poll')
        self._thread.daemon = True
        self._thread.start()
        rospy.on_shutdown(self.shutdown)

    # --- set-up --------------------------------------------------------------------------
    def _action(self, name, spec, goal_cb):
        server = actionlib.SimpleActionServer(name, spec, auto_start=False)
        server.register_goal_callback(goal_cb)
        server.register_preempt_callback(lambda: self._on_preempt(name, server))
        server.start()
        return server

    def _setup_diagnostics(self):
        self.updater = diagnostic_updater.Updater()
        self.updater.setHardwareID('modbus %s unit %d' % (self.endpoint, self.driver.unit))
        self.updater.add('Modbus connection', self._diag_connection)
        self.poll_freq = diagnostic_updater.FrequencyStatus(
            diagnostic_updater.FrequencyStatusParam(
                {'min': self.poll_rate, 'max': self.poll_rate}, POLL_RATE_TOLERANCE,
                POLL_RATE_WINDOW))
        self.updater.add(self.poll_freq)
        for info in self.regmap.axes:
            self.updater.add('Axis %s' % info.name,
                             lambda stat, index=info.index: self._diag_axis(stat, index))

    def shutdown(self):
        self._stop.set()
        if self._thread.is_alive() and threading.current_thread() is not self._thread:
            self._thread.join(2.0)
        self.driver.close()

    # --- poll loop -----------------------------------------------------------------------
    def _poll_loop(self):
        rate = rospy.Rate(self.poll_rate)
        while not rospy.is_shutdown() and not self._stop.is_set():
            self._poll_once()
            self.updater.update()
            try:
                rate.sleep()
            except rospy.ROSInterruptException:
                break
            except rospy.ROSTimeMovedBackwardsException:
                rate = rospy.Rate(self.poll_rate)

    def _poll_once(self, own=None):
        """One poll. Goal handles are only touched after the poll lock is released: a goal
        callback holds actionlib's lock while it waits for the poll lock. `own`: the server
        whose goal callback polls (it holds that server's lock): only that server's goals are
        fed and finished here, the others' by the poll thread (`motion_goals.split_actions`)."""
        with self._poll_lock:
            actions = self._poll_locked()
        now, later = mg.split_actions(actions, own)
        with self._lock:
            if own is None:
                now, self._deferred = [call for _, call in self._deferred] + now, []
            else:
                self._deferred.extend(later)
        for action in now:
            action()
        self._publish_status()

    def _poll_locked(self):
        """Poll the controller; returns the goal feedback / finish calls to make."""
        now = rospy.get_time()
        resumed = []
        if not self.driver.connected:
            if not self.driver.ensure_connected(now):
                if self.driver.refused and self.driver.refused != self._refusal_logged:
                    rospy.logerr('%s (~controller_serial %d); retrying with back-off',
                                 self.driver.refused, self.driver.serial_number)
                self._refusal_logged = self.driver.refused
                return self._outage_expired(now)
            self._refusal_logged = ''
            resumed = self._on_connected(now)
        try:
            state = self.driver.poll()
        except ConnectionLost as exc:
            rospy.logerr('%s', exc)
            if self.link_grace > 0.0:
                self._note_link_lost(exc, now)
                return resumed + self._outage_expired(now)
            return resumed + self._abort_actions(mg.CONNECTION_LOST, str(exc))
        except ControllerRefused as exc:
            self._poll_error = str(exc)
            rospy.logwarn_throttle(2.0, '%s' % exc)
            if self._last_good is None or now - self._last_good > self.stale_timeout:
                with self._lock:
                    self._state = None
                return self._abort_actions(mg.REFUSED, 'no valid data from the motion '
                                           'controller for %.1f s: %s'
                                           % (self.stale_timeout, exc))
            return []
        self._last_good = now
        self._poll_error = ''
        self.poll_freq.tick()
        with self._lock:
            self._poll_index += 1
            index = self._poll_index
            self._state = state
            active = list(self._active.values()) + self._arm_goals.goals()
        msg = JointState(name=self.regmap.joint_names, position=state.positions,
                         velocity=state.velocities)
        msg.header.stamp = rospy.Time.from_sec(now)
        self.joint_pub.publish(msg)
        actions = resumed
        for entry in active:
            outcome = entry.monitor.update(index, state, now)
            if outcome is None:
                if entry.feedback is not None:
                    actions.append((entry.key, functools.partial(
                        entry.feedback, entry.handle, entry.monitor, state)))
            elif self._release(entry):
                actions.append((entry.key, functools.partial(entry.finish, entry.handle,
                                                             outcome, state)))
        return actions

    def _on_connected(self, now):
        """Connected (again): nothing may run that no goal watches. After a link outage the
        goals that waited for it go on (`_resume_goals`); returns the finish calls to make."""
        rospy.loginfo('connected to the motion controller at %s (connection %d)',
                      self.endpoint, self.driver.connects)
        if self._link_lost_at is not None:
            lost_at, self._link_lost_at = self._link_lost_at, None
            return self._resume_goals(now - lost_at)
        try:
            self.driver.halt_all()
            if self.auto_enable:
                self.driver.system('enable_all')
        except DriverError as exc:
            rospy.logwarn('start-up commands failed: %s', exc)
        return []

    def _resume_goals(self, outage):
        """The link is back after `outage` s: every axis no goal holds is halted, each waiting
        goal's commands are written again (absolute targets: where the axes have got to in the
        meantime does not matter) and its deadline moved on by the outage; a goal that cannot be
        written again (a shear stroke) is aborted. Faults are not cleared: a drive that
        faulted meanwhile fails its goal at the next poll."""
        with self._lock:
            entries = list(self._active.values()) + self._arm_goals.goals()
            next_poll = self._poll_index + 1
        held = set(i for e in entries if e.resend is not None
                   for i in getattr(e.monitor, 'indices', ()))
        aborted = [e for e in entries if e.resend is None]
        try:
            idle = [i for i in range(len(self.regmap.axis_names)) if i not in held]
            if idle:
                self.driver.halt(idle)
            for entry in entries:
                if entry.resend is not None:
                    entry.resend()
                    entry.monitor.first_poll = next_poll
                    entry.monitor.deadline += outage
        except DriverError as exc:
            rospy.logerr('link back after %.1f s, but the goals cannot be written again: %s',
                         outage, exc)
            return self._abort_actions(mg.CONNECTION_LOST, 'the link to the motion controller '
                                       'came back, but writing failed: %s' % exc)
        rospy.logwarn('link to the motion controller back after %.1f s: %d goal(s) go on%s',
                      outage, len(entries) - len(aborted),
                      ', %d aborted' % len(aborted) if aborted else '')
        text = 'the link to the motion controller was down for %.1f s (%s)' % (
            outage, self._link_error)
        return [(e.key, functools.partial(e.finish, e.handle,
                                          mg.Outcome(False, mg.CONNECTION_LOST, text), None))
                for e in aborted if self._release(e)]

    def _outage_expired(self, now):
        """While the link is down: the waiting goals are aborted once `link_grace` is over."""
        if self._link_lost_at is None or now - self._link_lost_at <= self.link_grace:
            return []
        with self._lock:
            waiting = bool(self._active) or bool(self._arm_goals.goals())
        if not waiting:
            return []
        return self._abort_actions(mg.CONNECTION_LOST, 'no link to the motion controller at %s '
                                   'for %.1f s (~link_grace): %s' % (
                                       self.endpoint, now - self._link_lost_at,
                                       self.driver.last_error or self._link_error))

    def _note_link_lost(self, exc, now=None):
        """The link broke (a poll or a goal's write found it): goals wait `link_grace`."""
        if self.link_grace > 0.0 and self._link_lost_at is None:
            self._link_lost_at = rospy.get_time() if now is None else now
            self._link_error = str(exc)
            rospy.logwarn('goals wait up to %.1f s for the link to the motion controller',
                          self.link_grace)

    def _write_through_outage(self, write):
        """A goal's write(); when the link breaks during it, the goal waits for the link
        (`_await_link`) and writes everything again (absolute targets, a valve state)."""
        try:
            write()
        except ConnectionLost as exc:
            self._note_link_lost(exc)
            if not self._await_link():
                raise
            with self._poll_lock:
                write()

    def _await_link(self):
        """A goal that comes while the link is down (lost less than `link_grace` ago) waits for
        it (ROS time) before it is checked: the outage a running goal rides through does not
        fail the next goal either. True when connected."""
        if not self.driver.connected and self._link_lost_at is None and self.driver.connects > 0:
            # lost a moment ago: the poll thread has not noted it yet
            self._note_link_lost(self.driver.last_error or 'connection lost')
        while not self.driver.connected and not rospy.is_shutdown():
            lost_at = self._link_lost_at
            if lost_at is None or rospy.get_time() - lost_at > self.link_grace:
                break
            try:
                rospy.sleep(0.02)
            except rospy.ROSInterruptException:
                break
        if not self.driver.connected:
            return False
        with self._poll_lock:
            pass       # the poll thread has done its reconnection (it halts idle axes) first
        return self.driver.connected

    # --- goal bookkeeping ----------------------------------------------------------------
    def _register(self, entry):
        """Make the goal active and poll at once: quick goals end without waiting a period."""
        with self._lock:
            self._active[entry.key] = entry
        self._poll_once(own=entry.key)

    def _release(self, entry):
        """Remove the entry if it is still an active one; True when removed."""
        with self._lock:
            if entry.key == 'move_robot':
                return self._arm_goals.remove(entry)
            if self._active.get(entry.key) is entry:
                del self._active[entry.key]
                return True
            return False

    def _take(self, key):
        with self._lock:
            return self._active.pop(key, None)

    def _abort_actions(self, code, text, keys=None):
        """Deactivate goals (all, or those of the given servers); returns their abort calls
        as (server name, call) pairs."""
        with self._lock:
            keys = list(self._active) + ['move_robot'] if keys is None else keys
            entries = [self._active.pop(k) for k in keys if k in self._active]
            if 'move_robot' in keys:
                entries.extend(self._arm_goals.clear())      # every arm's goal
            state = self._state
        return [(e.key, functools.partial(e.finish, e.handle, mg.Outcome(False, code, text),
                                          state)) for e in entries]

    def _snapshot(self):
        with self._lock:
            return self._poll_index, self._state

    def _on_preempt(self, key, server):
        if server.is_new_goal_available():
            return                              # the goal callback replaces the goal
        entry = self._take(key)
        if entry is None:
            return
        text = self._halt_entry(entry) if key == 'move_base' else 'preempted'
        entry.finish(entry.handle, mg.Outcome(False, mg.HALTED, text), self._state,
                     preempted=True)

    # --- move_robot ---------------------------------------------------------------------
    def _goal_move_robot(self, handle):
        """A goal per arm (ActionServer callback, under its lock: goals and cancels of
        move_robot come one at a time). An invalid goal is refused before it touches the
        running goals; a valid one takes over the running goals of its arms (both for a waist
        goal): they end preempted, their axes it moves are retargeted by its writes (no halt,
        the controller re-plans from position and speed), their other axes are halted."""
        handle.set_accepted()
        goal = handle.get_goal()
        if handle.get_goal_status().status == GoalStatus.PREEMPTING:    # cancelled before it came
            self._finish_move_robot(handle, mg.Outcome(False, mg.HALTED, 'cancelled before it '
                                                       'started'), None, preempted=True)
            return
        displaced, halted = [], {}
        try:
            names, targets, speeds = mg.validate_arm_goal(
                goal.target_joint.positions, goal.target_joint.velocities, goal.arm, self.limits,
                goal.waist if goal.move_waist else None)
            arms, names, targets, speeds = mg.goal_scope(goal.arm, names, targets, speeds,
                                                         goal.move_waist and
                                                         self._waist_settled(goal.waist))
            plan = self._plan_axes_move(names, targets, speeds)
            with self._lock:
                displaced = self._arm_goals.take_over(arms, names)
            halted = self._halt_displaced(displaced)
            entry = self._write_axes_move('move_robot', handle, plan, self._finish_move_robot,
                                          self._feedback_move_robot)
        except mg.GoalError as exc:
            self._end_displaced(displaced, halted)
            self._finish_move_robot(handle, mg.Outcome(False, mg.INVALID_GOAL, str(exc)), None)
            return
        except DriverError as exc:
            self._end_displaced(displaced, halted)
            code = mg.CONNECTION_LOST if isinstance(exc, ConnectionLost) else mg.REFUSED
            self._finish_move_robot(handle, mg.Outcome(False, code, str(exc)), None)
            return
        except Exception as exc:  # noqa: BLE001 - a goal is always answered
            self._end_displaced(displaced, halted)
            self._finish_move_robot(handle, _internal_error('move_robot', exc), None)
            return
        self._end_displaced(displaced, halted)
        with self._lock:
            others = self._arm_goals.add(entry, arms, names)     # none: taken over above
        self._end_displaced(others, {})
        self._poll_once(own='move_robot')

    def _waist_settled(self, target):
        """The waist rests at `target` (within ~tolerance_angular) and no goal moves it."""
        with self._lock:
            state, held = self._state, self._arm_goals.axis_held('waist')
        if state is None or 'waist' not in self.regmap.axis_names:
            return False
        axis = state.axes[self.regmap.axis('waist').index]
        return mg.waist_settled(target, axis.position, axis.moving, self.tol_angular, held)

    def _halt_displaced(self, displaced):
        """Halt the axes of replaced goals that the new goal does not move; {id: text}."""
        texts = {}
        for d in displaced:
            if not d.halt:
                texts[id(d.goal)] = 'preempted by a new goal for the same arm'
                continue
            try:
                self.driver.halt([self.regmap.axis(n).index for n in d.halt])
                texts[id(d.goal)] = 'preempted by a new goal: axes %s halted' % ', '.join(d.halt)
            except DriverError as exc:
                texts[id(d.goal)] = 'preempted by a new goal, but halting failed: %s' % exc
        return texts

    def _end_displaced(self, displaced, texts):
        state = self._state
        for d in displaced:
            text = texts.get(id(d.goal), 'preempted by a new goal')
            d.goal.finish(d.goal.handle, mg.Outcome(False, mg.HALTED, text), state,
                          preempted=True)

    def _cancel_move_robot(self, handle):
        """Cancel of one goal: halts that goal's axes only (the other arm's goal runs on)."""
        with self._lock:
            entry = next((e for e in self._arm_goals.goals() if e.handle == handle), None)
            if entry is None or not self._arm_goals.remove(entry):
                return                  # already ended (its result is on its way)
        entry.finish(entry.handle, mg.Outcome(False, mg.HALTED, self._halt_entry(entry)),
                     self._state, preempted=True)

    def _halt_entry(self, entry):
        """Halt a preempted goal's axes; the text of its result."""
        try:
            self.driver.halt(entry.monitor.indices)
            return 'preempted: axes %s halted' % ', '.join(entry.monitor.names)
        except DriverError as exc:
            return 'preempted, but halting failed: %s' % exc

    def _start_axes_move(self, key, handle, names, targets, speeds, finish, feedback):
        return self._write_axes_move(key, handle, self._plan_axes_move(names, targets, speeds),
                                     finish, feedback)

    def _plan_axes_move(self, names, targets, speeds):
        """Check a move against the connection and the last poll; nothing is written."""
        self._await_link()
        _, state = self._snapshot()
        if state is None or not self.driver.connected:
            raise ConnectionLost('no connection to the motion controller at %s: %s'
                                 % (self.endpoint, self.driver.last_error or 'not connected'))
        indices = [self.regmap.axis(n).index for n in names]
        # every value checked and encoded before the first write: a goal moves all its axes or none
        budget = mg.plan_axes_move(
            names, targets, speeds, [state.axes[i].position for i in indices], self.limits,
            self.timeout_factor, self.timeout_margin,
            lambda n, *command: self.regmap.encode_move(self.regmap.axis(n).index, *command))
        return names, targets, speeds, indices, state, budget

    def _write_axes_move(self, key, handle, plan, finish, feedback):
        names, targets, speeds, indices, state, budget = plan
        tolerances = [self.tol_linear if self.limits[n].linear else self.tol_angular
                      for n in names]
        units = [self.limits[n].unit for n in names]
        accelerations = [self.limits[n].acceleration for n in names]

        def write():
            for i, target, speed, acceleration in zip(indices, targets, speeds, accelerations):
                self.driver.move(i, target, speed, acceleration)
        self._write_through_outage(write)
        first_poll = self._snapshot()[0] + 1
        deadline = rospy.get_time() + budget
        monitor = mg.AxesMoveMonitor(indices, names, targets,
                                     [state.axes[i].position for i in indices], tolerances,
                                     first_poll, deadline, self.regmap.fault_text, units)
        return _Active(key, handle, monitor, finish, feedback, resend=write)

    def _feedback_move_robot(self, handle, monitor, _state):
        if monitor.percent != getattr(monitor, 'sent', None):
            monitor.sent = monitor.percent
            handle.publish_feedback(MoveRobotFeedback(percent_complete=monitor.percent))

    def _finish_move_robot(self, handle, outcome, _state, preempted=False):
        result = MoveRobotResult(succeed=outcome.code)
        if outcome.success:
            handle.publish_feedback(MoveRobotFeedback(percent_complete=100))
            handle.set_succeeded(result, outcome.text)
        elif preempted:
            handle.set_canceled(result, outcome.text)
        else:
            rospy.logwarn('move_robot aborted: %s', outcome.text)
            handle.set_aborted(result, outcome.text)

    # --- move_base -----------------------------------------------------------------------
    def picking_points(self):
        if rospy.has_param('~picking_points'):
            return list(rospy.get_param('~picking_points'))
        return list(rospy.get_param(self.points_param, []))

    def _goal_move_base(self):
        server = self.move_base
        goal = server.accept_new_goal()
        handle = server.current_goal
        self._take('move_base')
        try:
            points = self.picking_points()
            if not points:
                raise mg.GoalError('no picking points: set %s (or ~picking_points)'
                                   % self.points_param)
            if not 0 <= goal.picking_point < len(points):
                raise mg.GoalError('picking point %d does not exist (%d points: 0..%d)'
                                   % (goal.picking_point, len(points), len(points) - 1))
            target = float(points[goal.picking_point])
            if not math.isfinite(target):
                raise mg.GoalError('picking point %d position is not finite' % goal.picking_point)
            mg.check_range(self.limits['cart'], target)
            entry = self._start_axes_move('move_base', handle, ['cart'], [target],
                                          [self.limits['cart'].speed], self._finish_move_base,
                                          self._feedback_move_base)
        except (mg.GoalError, DriverError) as exc:
            self._finish_move_base(handle, mg.Outcome(False, mg.INVALID_GOAL, str(exc)),
                                   self._state)
            return
        except Exception as exc:  # noqa: BLE001 - a goal is always answered
            self._finish_move_base(handle, _internal_error('move_base', exc), self._state)
            return
        self._register(entry)

    def _feedback_move_base(self, handle, monitor, _state):
        if monitor.percent != getattr(monitor, 'sent', None):
            monitor.sent = monitor.percent
            handle.publish_feedback(MoveBaseFeedback(track_position=monitor.positions[0],
                                                     percent_complete=monitor.percent))

    def _finish_move_base(self, handle, outcome, state, preempted=False):
        cart = self.regmap.axis('cart').index
        position = state.axes[cart].position if state is not None else float('nan')
        result = MoveBaseResult(success=outcome.success, track_position=position,
                                message=outcome.text)
        if outcome.success:
            handle.set_succeeded(result, outcome.text)
        elif preempted:
            handle.set_canceled(result, outcome.text)
        else:
            rospy.logwarn('move_base aborted: %s', outcome.text)
            handle.set_aborted(result, outcome.text)

    # --- end_effector --------------------------------------------------------------------
    def _goal_end_effector(self):
        server = self.end_effector
        goal = server.accept_new_goal()
        handle = server.current_goal
        self._take('end_effector')
        try:
            entry = self._start_end_effector(handle, goal)
        except (mg.GoalError, DriverError) as exc:
            self._finish_end_effector(handle, mg.Outcome(False, mg.INVALID_GOAL, str(exc)),
                                      self._state)
            return
        except Exception as exc:  # noqa: BLE001 - a goal is always answered
            self._finish_end_effector(handle, _internal_error('end_effector', exc), self._state)
            return
        handle.publish_feedback(EndEffectorFeedback(state=entry.monitor.state_text))
        self._register(entry)

    def _start_end_effector(self, handle, goal):
        if not math.isfinite(goal.timeout) or goal.timeout < 0.0:
            raise mg.GoalError('timeout must be finite and >= 0, got %r' % goal.timeout)
        self._await_link()
        _, state = self._snapshot()
        if state is None or not self.driver.connected:
            raise ConnectionLost('no connection to the motion controller at %s: %s'
                                 % (self.endpoint, self.driver.last_error or 'not connected'))
        now = rospy.get_time()
        resend = None
        finish = self._finish_end_effector
        if goal.command == EndEffectorGoal.SUCTION_ON:
            timeout = goal.timeout or self.suction_timeout
            resend = functools.partial(self.driver.set_suction, True)
            self._write_through_outage(resend)
            monitor = mg.SuctionOnMonitor(self._snapshot()[0] + 1, rospy.get_time() + timeout,
                                          timeout)
        elif goal.command == EndEffectorGoal.SUCTION_OFF:
            timeout = goal.timeout or self.suction_timeout
            finish = functools.partial(self._finish_end_effector,
                                       released_empty=not state.vacuum_ok)
            resend = functools.partial(self.driver.set_suction, False)
            self._write_through_outage(resend)
            monitor = mg.SuctionOffMonitor(self._snapshot()[0] + 1, rospy.get_time() + timeout)
        elif goal.command == EndEffectorGoal.SHEAR_CUT:
            timeout = goal.timeout or self.shear_timeout
            if state.shear_busy:
                raise mg.GoalError('a shear stroke is still running')
            self.driver.shear()
            monitor = mg.ShearMonitor(self._snapshot()[0] + 1, now + timeout, state.shear_count,
                                      timeout)
        else:
            raise mg.GoalError('unknown end effector command %d (1 SUCTION_ON, 2 SUCTION_OFF, '
                               '3 SHEAR_CUT)' % goal.command)
        return _Active('end_effector', handle, monitor, finish, None, resend=resend)

    def _finish_end_effector(self, handle, outcome, state, preempted=False, released_empty=False):
        """released_empty: SUCTION_OFF came with no vacuum on the cup (the last poll's)."""
        if (not outcome.success and isinstance(handle.get_goal(), EndEffectorGoal) and
                handle.get_goal().command == EndEffectorGoal.SUCTION_ON and
                outcome.code == mg.TIMEOUT):
            try:
                self.driver.set_suction(False)      # no fruit held: do not keep blowing air
                outcome.text += '; valve closed again'
            except DriverError as exc:
                outcome.text += '; closing the valve failed: %s' % exc
        result = EndEffectorResult(success=outcome.success, message=outcome.text,
                                   vacuum_ok=bool(state is not None and state.vacuum_ok),
                                   released_empty=bool(released_empty))
        if outcome.success:
            handle.set_succeeded(result, outcome.text)
        elif preempted:
            handle.set_canceled(result, outcome.text)
        else:
            rospy.logwarn('end_effector aborted: %s', outcome.text)
            handle.set_aborted(result, outcome.text)

    # --- services ------------------------------------------------------------------------
    def _halt_everything(self, text):
        """Halt every axis, then abort the move goals with `text`; (ok, message)."""
        try:
            self.driver.halt_all()
        except DriverError as exc:
            return False, 'halt failed: %s' % exc
        for _, action in self._abort_actions(mg.HALTED, text, ['move_robot', 'move_base']):
            action()
        return True, 'every axis halted'

    def _on_halt_all(self, _req):
        ok, message = self._halt_everything('halted by halt_all')
        if ok:
            rospy.logwarn('halt_all: every axis halted')
        else:
            rospy.logerr('halt_all: %s', message)
        return TriggerResponse(success=ok, message=message)

    def _on_emergency_stop(self, msg):
        if not msg.data:
            return          # released: the executive's resume moves the robot again
        ok, message = self._halt_everything(mg.ESTOP_HALT_TEXT)
        (rospy.logwarn if ok else rospy.logerr)('emergency stop topic: %s', message)

    def _on_enable_all(self, _req):
        try:
            self.driver.enable_all()
        except DriverError as exc:
            return TriggerResponse(success=False, message='enable_all failed: %s' % exc)
        rospy.loginfo('enable_all: faults cleared, every axis enabled')
        return TriggerResponse(success=True, message='faults cleared, every axis enabled')

    # --- status and diagnostics ----------------------------------------------------------
    def _summary(self):
        return mg.status_summary(self.driver.connected, self.driver.last_error, self._state,
                                 self.regmap, self.endpoint, self._poll_error)

    def _publish_status(self):
        with self._status_lock:
            level, message = self._summary()
            if (level, message) == self._last_status:
                return
            self._last_status = (level, message)
            values = [KeyValue('endpoint', self.endpoint),
                      KeyValue('controller_serial', str(self.driver.serial_number)),
                      KeyValue('connected', str(self.driver.connected)),
                      KeyValue('connections', str(self.driver.connects))]
            self.status_pub.publish(DiagnosticStatus(
                level=level, name=rospy.get_name(), message=message,
                hardware_id='modbus %s' % self.endpoint, values=values))
        if level == 0:
            rospy.loginfo('motion status OK: %s', message)
        else:
            rospy.logwarn('motion status %s: %s', LEVEL_NAMES[level], message)

    def _diag_connection(self, stat):
        level, message = self._summary()
        stat.summary(2 if not self.driver.connected or self._poll_error else 0,
                     'connected' if self.driver.connected and not self._poll_error else message)
        stat.add('endpoint', self.endpoint)
        stat.add('unit id', self.driver.unit)
        stat.add('controller serial number', self.driver.serial_number)
        stat.add('connections made', self.driver.connects)
        stat.add('connections lost', self.driver.failures)
        stat.add('last error', self.driver.last_error or self._poll_error or '-')
        stat.add('system status', '%s: %s' % (LEVEL_NAMES[level], message))
        return stat

    def _diag_axis(self, stat, index):
        state = self._state
        if state is None or not self.driver.connected:
            stat.summary(2, 'no data (not connected)')
            return stat
        axis = state.axes[index]
        if axis.fault:
            stat.summary(2, 'fault %d: %s' % (axis.fault_code,
                                              self.regmap.fault_text(axis.fault_code)))
        elif not axis.enabled:
            stat.summary(1, 'disabled')
        else:
            stat.summary(0, 'moving' if axis.moving else 'enabled, at rest')
        stat.add('position', '%.5f' % axis.position)
        stat.add('velocity', '%.5f' % axis.velocity)
        stat.add('status word', '0x%04x' % axis.status)
        stat.add('fault code', axis.fault_code)
        stat.add('in position', axis.in_position)
        return stat
