"""Progress monitoring of the motion action servers' goals and the motion system's status
summary (pure logic, no ROS); re-exported by motion_goals.

Monitors are fed every controller poll (:class:`motion_pkg.modbus_map.ControllerState`) and
return an :class:`Outcome` once their goal is finished. They ignore polls taken before their
commands were written (``first_poll``), so a stale sample can never end a goal.

MoveRobot ``succeed`` codes (result of ``move_robot``):
  1 success; 0 failure (other); -1 invalid goal (NaN, wrong length, beyond limits, also of
  the optional waist target);
  -2 drive fault; -3 timeout; -4 lost connection to the controller; -5 halted or preempted;
  -6 the controller refused the command (Modbus exception).
"""

import math

SUCCESS = 1
FAILURE = 0
INVALID_GOAL = -1
DRIVE_FAULT = -2
TIMEOUT = -3
CONNECTION_LOST = -4
HALTED = -5
REFUSED = -6


def _plain(value):
    return '%.4g' % value


class Outcome(object):
    """How a goal ended: ``success``, the result ``code`` and an explanatory ``text``."""

    __slots__ = ('success', 'code', 'text')

    def __init__(self, success, code, text):
        self.success = success
        self.code = code
        self.text = text

    def __repr__(self):
        return 'Outcome(%r, %r, %r)' % (self.success, self.code, self.text)


class Monitor(object):
    """Base: skips stale polls, enforces the deadline, reports drive faults."""

    def __init__(self, first_poll, deadline):
        self.first_poll = first_poll
        self.deadline = deadline
        self.percent = 0

    def update(self, poll_index, state, now):
        """Outcome when finished, else None."""
        if now > self.deadline:
            return self.timed_out()
        if poll_index < self.first_poll:
            return None
        return self.check(state)

    def check(self, state):
        raise NotImplementedError

    def timed_out(self):
        return Outcome(False, TIMEOUT, 'timed out')


class AxesMoveMonitor(Monitor):
    """Several axes moving to targets (a MoveRobot arm move or the MoveBase cart move)."""

    def __init__(self, indices, names, targets, starts, tolerances, first_poll, deadline,
                 fault_text, units=None):
        super(AxesMoveMonitor, self).__init__(first_poll, deadline)
        self.units = list(units) if units else [_plain] * len(list(names))
        self.indices = list(indices)
        self.names = list(names)
        self.targets = list(targets)
        self.starts = list(starts)
        self.tolerances = list(tolerances)
        self.fault_text = fault_text
        self.positions = list(starts)

    def progress(self, positions):
        fractions = []
        for start, target, pos, tol in zip(self.starts, self.targets, positions,
                                           self.tolerances):
            span = abs(target - start)
            if span <= tol:
                fractions.append(1.0)
            else:
                fractions.append(min(1.0, max(0.0, 1.0 - abs(target - pos) / span)))
        return int(math.floor(100.0 * min(fractions))) if fractions else 100

    def check(self, state):
        axes = [state.axes[i] for i in self.indices]
        self.positions = [a.position for a in axes]
        for name, axis in zip(self.names, axes):
            if axis.fault:
                return Outcome(False, DRIVE_FAULT, 'drive fault on %s: %s (code %d)' % (
                    name, self.fault_text(axis.fault_code), axis.fault_code))
        done = True
        for name, axis, target, tol, unit in zip(self.names, axes, self.targets,
                                                 self.tolerances, self.units):
            error = abs(axis.position - target)
            if axis.moving:
                done = False
            elif error > tol:
                why = 'disabled' if not axis.enabled else 'halted'
                return Outcome(False, HALTED, '%s stopped %s from its target (%s)'
                               % (name, unit(error), why))
        self.percent = 100 if done else min(99, self.progress(self.positions))
        if done:
            return Outcome(True, SUCCESS, 'target reached')
        return None

    def timed_out(self):
        return Outcome(False, TIMEOUT, 'move not finished before its deadline (axes %s)'
                       % ', '.join(self.names))


class SuctionOnMonitor(Monitor):
    """Valve opened: wait for the vacuum sensor."""

    def __init__(self, first_poll, deadline, timeout):
        super(SuctionOnMonitor, self).__init__(first_poll, deadline)
        self.timeout = timeout
        self.state_text = 'waiting for vacuum'

    def check(self, state):
        if state.vacuum_ok:
            return Outcome(True, SUCCESS, 'vacuum ok')
        return None

    def timed_out(self):
        return Outcome(False, TIMEOUT, 'no vacuum within %.2f s (is the cup on a fruit?)'
                       % self.timeout)


class SuctionOffMonitor(Monitor):
    """Valve closed: wait until the controller reports it closed."""

    state_text = 'closing valve'

    def check(self, state):
        if not state.suction_valve:
            return Outcome(True, SUCCESS, 'valve closed')
        return None

    def timed_out(self):
        return Outcome(False, TIMEOUT, 'suction valve still reported open')


class ShearMonitor(Monitor):
    """Shear stroke started: wait for the closure (stroke counter advances)."""

    state_text = 'cutting'

    def __init__(self, first_poll, deadline, count_before, timeout):
        super(ShearMonitor, self).__init__(first_poll, deadline)
        self.count_before = count_before
        self.timeout = timeout

    def check(self, state):
        if state.shear_count != self.count_before:
            return Outcome(True, SUCCESS, 'shear closed')
        return None

    def timed_out(self):
        return Outcome(False, TIMEOUT, 'shear-closed sensor not seen within %.2f s'
                       % self.timeout)


def status_summary(connected, last_error, state, regmap, endpoint, poll_error=''):
    """(level, message) of the motion system: 0 OK, 1 WARN, 2 ERROR (DiagnosticStatus levels).

    OK needs a connection, valid polls and every axis enabled without fault.
    """
    if connected and poll_error:
        return 2, 'motion controller at %s answers with errors: %s' % (endpoint, poll_error)
    if not connected or state is None:
        return 2, 'no connection to the motion controller at %s: %s' % (
            endpoint, last_error or 'not connected')
    faults = ['%s: %s (code %d)' % (regmap.axes[i].name, regmap.fault_text(a.fault_code),
                                    a.fault_code)
              for i, a in enumerate(state.axes) if a.fault]
    if faults:
        return 2, 'drive fault: ' + '; '.join(faults)
    disabled = [regmap.axes[i].name for i, a in enumerate(state.axes) if not a.enabled]
    if disabled:
        return 1, 'axes not enabled: ' + ', '.join(disabled)
    return 0, 'connected, all %d axes enabled' % len(state.axes)
