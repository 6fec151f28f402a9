"""The ``end_effector`` action of ``motion_server`` (``EndEffectorMixin``, mixed into
``motion_server.MotionServer``): suction on (waits for vacuum), suction off, one shear stroke."""

import functools
import math

import rospy
from harvest_msgs.msg import EndEffectorFeedback, EndEffectorGoal, EndEffectorResult

from motion_pkg import motion_goals as mg
from motion_pkg.modbus_driver import ConnectionLost, DriverError
from motion_pkg.motion_active_goals import _Active, answer


class EndEffectorMixin(object):
    """end_effector goal handling of MotionServer."""

    # --- end_effector --------------------------------------------------------------------
    def _goal_end_effector(self):
        server = self.end_effector
        goal = server.accept_new_goal()
        handle = server.current_goal
        self._take('end_effector')
        entry = self._start_or_answer('end_effector', handle,
                                      lambda: self._start_end_effector(handle, goal),
                                      self._finish_end_effector)
        if entry is None:
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
        answer(handle, 'end_effector', result, outcome, preempted)
