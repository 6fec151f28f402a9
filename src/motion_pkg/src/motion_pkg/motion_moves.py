"""The axes moves of ``motion_server`` (``AxesMovesMixin``, mixed into
``motion_server.MotionServer``): the ``move_robot`` goals (one per arm, taking over, cancel) and
the ``move_base`` goal (cart to a picking point); a move is checked, then written to the axes."""

import math

import rospy
from actionlib_msgs.msg import GoalStatus
from harvest_msgs.msg import MoveBaseFeedback, MoveBaseResult, MoveRobotFeedback, MoveRobotResult

from motion_pkg import motion_goals as mg
from motion_pkg.modbus_driver import ConnectionLost, DriverError
from motion_pkg.motion_active_goals import _Active, _internal_error, answer
from motion_pkg.motion_interlock import move_robot_refusal


#: a goal that still reports progress
_RUNNING = (GoalStatus.PENDING, GoalStatus.ACTIVE, GoalStatus.PREEMPTING)


def progress_feedback(handle, monitor, make):
    """Publish `make(percent)` as the goal's feedback when the monitor's percent is above the
    last one it reported. Polls run in the poll thread and in goal callbacks, and each feeds
    its goals after the poll lock is released, so two threads can feed one goal: the check and
    the publication are one step under the goal's action server lock (an RLock that a goal
    callback already holds), and a feedback of an older poll never follows a newer one (nor
    the goal's result)."""
    with handle.action_server.lock:
        percent = monitor.percent
        if percent > getattr(monitor, 'sent', -1) and \
                handle.get_goal_status().status in _RUNNING:
            monitor.sent = percent
            handle.publish_feedback(make(percent))


class AxesMovesMixin(object):
    """move_robot and move_base goal handling of MotionServer."""

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
            self._check_arms_may_move()
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
        progress_feedback(handle, monitor,
                          lambda percent: MoveRobotFeedback(percent_complete=percent))

    def _finish_move_robot(self, handle, outcome, _state, preempted=False):
        result = MoveRobotResult(succeed=outcome.code)
        if outcome.success:
            handle.publish_feedback(MoveRobotFeedback(percent_complete=100))
        answer(handle, 'move_robot', result, outcome, preempted)

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
        entry = self._start_or_answer('move_base', handle,
                                      lambda: self._start_move_base(handle, goal),
                                      self._finish_move_base)
        if entry is not None:
            self._register(entry)

    def _start_move_base(self, handle, goal):
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
        plan = self._plan_axes_move(['cart'], [target], [self.limits['cart'].speed])
        self._check_cart_may_move(plan[4])
        return self._write_axes_move('move_base', handle, plan, self._finish_move_base,
                                     self._feedback_move_base)

    # --- the cart interlock (motion_interlock) ----------------------------------------------
    def _check_cart_may_move(self, state):
        """GoalError unless both arms are stowed (in `state`, the poll the move is planned
        on) and no arm goal runs."""
        if self.interlock is None:
            return
        with self._lock:
            moving = [a for g in self._arm_goals.goals() for a in self._arm_goals.arms_of(g)]
        position = {n: state.axes[self.regmap.axis(n).index].position
                    for n in self.regmap.axis_names}
        joints = {arm: tuple(position.get('%s_%s' % (arm, j), float('nan'))
                             for j in mg.ARM_JOINTS) for arm in mg.ARMS}
        why = self.interlock.move_base_refusal(joints, position.get('waist', 0.0), moving)
        if why:
            raise mg.GoalError(why)

    def _check_arms_may_move(self):
        """GoalError while a move_base goal runs."""
        if self.interlock is None:
            return
        with self._lock:
            cart_moving = self._active.get('move_base') is not None
        why = move_robot_refusal(cart_moving)
        if why:
            raise mg.GoalError(why)

    def _feedback_move_base(self, handle, monitor, _state):
        progress_feedback(handle, monitor, lambda percent: MoveBaseFeedback(
            track_position=monitor.positions[0], percent_complete=percent))

    def _finish_move_base(self, handle, outcome, state, preempted=False):
        cart = self.regmap.axis('cart').index
        position = state.axes[cart].position if state is not None else float('nan')
        result = MoveBaseResult(success=outcome.success, track_position=position,
                                message=outcome.text)
        answer(handle, 'move_base', result, outcome, preempted)
