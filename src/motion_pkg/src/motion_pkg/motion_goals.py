"""Goal validation and progress monitoring of the motion action servers (pure logic, no ROS).

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

from harvest_description import robot_config

SUCCESS = 1
FAILURE = 0
INVALID_GOAL = -1
DRIVE_FAULT = -2
TIMEOUT = -3
CONNECTION_LOST = -4
HALTED = -5
REFUSED = -6

#: the text of a move goal aborted because the emergency stop topic halted the axes; the
#: executive (control_pkg) takes a goal aborted with it for the stop itself, even when the
#: topic reached motion_server before it reached the executive
ESTOP_HALT_TEXT = 'halted by the emergency stop'

ARM_JOINTS = ('lift', 'boom', 'forearm')
LINEAR_KINDS = ('cart', 'lift')


class GoalError(ValueError):
    """A goal that cannot be executed; the text says why."""


class AxisLimits(object):
    """Position range and default speed / acceleration of one axis (SI units)."""

    __slots__ = ('name', 'minimum', 'maximum', 'speed', 'acceleration', 'linear')

    def __init__(self, name, minimum, maximum, speed, acceleration, linear):
        self.name = name
        self.minimum = float(minimum)
        self.maximum = float(maximum)
        self.speed = float(speed)
        self.acceleration = float(acceleration)
        self.linear = linear

    def unit(self, value):
        """Readable value with unit (mm or deg)."""
        return '%.1f mm' % (value * 1000.0) if self.linear else '%.2f deg' % math.degrees(value)


def limits_from_robot_config(robot_yaml):
    """{axis name: AxisLimits} from the parsed robot.yaml (RobotConfigError when it is bad)."""
    robot_config.validate(robot_yaml)
    robot = robot_yaml['robot']
    motion = robot_yaml['motion']
    limits = {}
    for name in robot_yaml['axes']:
        if name == 'cart':
            kind, lo, hi = 'cart', robot['track']['min'], robot['track']['max']
        elif name == 'waist':
            kind, lo, hi = 'waist', robot['waist']['min'], robot['waist']['max']
        else:
            kind = name.split('_', 1)[1]
            lo, hi = robot['joint_limits'][kind]['min'], robot['joint_limits'][kind]['max']
        limits[name] = AxisLimits(name, lo, hi, motion['speed'][kind],
                                  motion['acceleration'][kind], kind in LINEAR_KINDS)
    return limits


def arm_axes(left):
    """Axis names of one arm: arm False = right (suction), True = left (cutting)."""
    side = 'left' if left else 'right'
    return ['%s_%s' % (side, j) for j in ARM_JOINTS]


def _finite(values):
    return all(isinstance(v, (int, float)) and math.isfinite(v) for v in values)


def validate_arm_goal(positions, velocities, left, limits, waist=None):
    """Check a MoveRobot goal; returns (axis names, targets, speeds) or raises GoalError.

    positions: [lift, boom, forearm]; velocities: empty or 3 per-joint speed limits (>= 0,
    0 = default speed; values above the default are reduced to it). waist: None (the goal
    leaves the waist alone) or the waist angle to turn to in the same move (axis `waist`, at
    its default speed); with a waist, empty positions (and velocities) move the waist alone.
    """
    positions = list(positions)
    velocities = list(velocities)
    if waist is not None:
        if not _finite([waist]):
            raise GoalError('waist target is not a finite number: %r' % (waist,))
        if 'waist' not in limits:
            raise GoalError('this robot has no waist axis')
        check_range(limits['waist'], waist)
        if not positions:
            if velocities:
                raise GoalError('target_joint.velocities must be empty for a waist-only goal')
            return ['waist'], [float(waist)], [limits['waist'].speed]
        names, targets, speeds = validate_arm_goal(positions, velocities, left, limits)
        return names + ['waist'], targets + [float(waist)], speeds + [limits['waist'].speed]
    names = arm_axes(left)
    arm = 'left' if left else 'right'
    if len(positions) != 3:
        raise GoalError('target_joint.positions needs 3 values [lift, boom, forearm] for the %s '
                        'arm, got %d' % (arm, len(positions)))
    if not _finite(positions):
        raise GoalError('target_joint.positions contains NaN or infinity: %s' % positions)
    if velocities and len(velocities) != 3:
        raise GoalError('target_joint.velocities must be empty or hold 3 speed limits, got %d'
                        % len(velocities))
    if not _finite(velocities) or any(v < 0.0 for v in velocities):
        raise GoalError('target_joint.velocities must be finite and >= 0: %s' % velocities)
    speeds = []
    for i, name in enumerate(names):
        lim = limits[name]
        check_range(lim, positions[i])
        speed = lim.speed
        if velocities and velocities[i] > 0.0:
            speed = min(speed, velocities[i])
        speeds.append(speed)
    return names, positions, speeds


def check_range(lim, value):
    if not lim.minimum <= value <= lim.maximum:
        raise GoalError('%s target %s is beyond the joint limits [%s, %s]' % (
            lim.name, lim.unit(value), lim.unit(lim.minimum), lim.unit(lim.maximum)))


def move_duration(distance, speed, acceleration):
    """Rest-to-rest trapezoid (or triangle) duration over |distance|."""
    dist = abs(distance)
    if dist == 0.0:
        return 0.0
    if dist >= speed * speed / acceleration:
        return dist / speed + speed / acceleration
    return 2.0 * math.sqrt(dist / acceleration)


def plan_axes_move(names, targets, speeds, starts, limits, timeout_factor, timeout_margin,
                   encode=None):
    """Check every value of a multi-axis move before anything is written; returns the time
    budget (s: slowest profile * factor + margin) or raises GoalError.

    names/targets/speeds/starts: per axis (SI units); limits: {name: AxisLimits}. Every target,
    speed, acceleration and start must be finite, speeds and accelerations > 0, the budget
    finite. ``encode(name, target, speed, acceleration)``, when given, converts the command to
    registers (e.g. RegisterMap.encode_move); its ValueError or OverflowError (a value that does
    not fit) becomes a GoalError too. So no NaN or overflow reaches the integer conversion of the registers and
    no axis of a goal starts unless every axis of it can.
    """
    durations = []
    for name, target, speed, start in zip(names, targets, speeds, starts):
        lim = limits[name]
        values = (('target', target), ('speed', speed), ('acceleration', lim.acceleration),
                  ('current position', start))
        for what, value in values:
            if not _finite([value]):
                raise GoalError('%s %s is not a finite number: %r' % (name, what, value))
        if not speed > 0.0 or not lim.acceleration > 0.0:
            raise GoalError('%s needs speed and acceleration > 0, got %r and %r'
                            % (name, speed, lim.acceleration))
        durations.append(move_duration(target - start, speed, lim.acceleration))
    if not durations:
        raise GoalError('a move needs at least one axis')
    budget = max(durations) * timeout_factor + timeout_margin
    if not (_finite([timeout_factor, timeout_margin, budget]) and budget > 0.0):
        raise GoalError('move deadline is not a finite positive time (factor %r, margin %r)'
                        % (timeout_factor, timeout_margin))
    if encode is not None:
        for name, target, speed in zip(names, targets, speeds):
            try:
                encode(name, target, speed, limits[name].acceleration)
            except (ValueError, OverflowError) as exc:    # does not fit the registers
                raise GoalError('%s command cannot be sent: %s' % (name, exc))
    return budget


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


# --- move_robot goals per arm ------------------------------------------------------------------
ARMS = ('right', 'left')


def goal_arms(left, move_waist):
    """The arms a MoveRobot goal belongs to: its own arm, or both when it turns the waist (the
    waist carries both arms' bases, so a waist goal moves both of them)."""
    if move_waist:
        return ARMS
    return ('left',) if left else ('right',)


def goal_scope(left, names, targets, speeds, waist_settled):
    """(arms, names, targets, speeds) of a valid MoveRobot goal (validate_arm_goal's axes).

    An arm goal that also gives a waist angle (``move_waist``) where the waist already rests
    (``waist_settled``: the caller's verdict, see ``waist_settled``) does not turn the base: the
    waist axis is left out and the goal belongs to its arm alone. Any other waist goal, and a
    waist-only goal always, belongs to both arms (``goal_arms``)."""
    names, targets, speeds = list(names), list(targets), list(speeds)
    if 'waist' not in names:
        return goal_arms(left, False), names, targets, speeds
    if waist_settled and len(names) > 1:
        i = names.index('waist')
        del names[i], targets[i], speeds[i]
        return goal_arms(left, False), names, targets, speeds
    return goal_arms(left, True), names, targets, speeds


def waist_settled(target, position, moving, tolerance, held):
    """True when a waist target needs no move: the waist rests (not ``moving``, no running goal
    ``held`` it) within ``tolerance`` (rad) of ``target``. Unknown position (None): False."""
    if held or moving or position is None:
        return False
    return abs(float(target) - float(position)) <= tolerance


class Displaced(object):
    """A running goal a new one takes over: ``goal`` ends preempted; ``halt`` lists its axes the
    new goal does not command (to halt: nobody would watch them), in the old goal's order."""

    __slots__ = ('goal', 'halt')

    def __init__(self, goal, halt):
        self.goal = goal
        self.halt = halt

    def __repr__(self):
        return 'Displaced(%r, halt=%r)' % (self.goal, self.halt)


class ArmGoals(object):
    """Which running move_robot goal each arm belongs to (pure bookkeeping, no ROS).

    A goal holds one arm, or both (a waist goal). Every arm has at most one goal; a new goal
    takes over the running goals of its arms (they end preempted; those of their axes the new
    goal does not command are halted, the ones it commands are retargeted by its own writes) and
    leaves the other arm's goal alone. Goals are any hashable objects, compared by identity.
    """

    def __init__(self):
        self._arms = {}          # arm name -> goal
        self._axes = {}          # id(goal) -> axis names

    def goals(self):
        """The running goals, each once (right arm's first)."""
        seen = []
        for arm in ARMS:
            goal = self._arms.get(arm)
            if goal is not None and not any(goal is g for g in seen):
                seen.append(goal)
        return seen

    def goal_of(self, arm):
        return self._arms.get(arm)

    def arms_of(self, goal):
        return tuple(a for a in ARMS if self._arms.get(a) is goal)

    def axis_held(self, name):
        """True when a running goal commands axis ``name``."""
        return any(name in axes for axes in self._axes.values())

    def holds(self, goal):
        return any(g is goal for g in self._arms.values())

    def displaced_by(self, arms, axes):
        """What a new goal for ``arms`` commanding ``axes`` would take over (nothing changes)."""
        axes = set(axes)
        out = []
        for arm in arms:
            if arm not in ARMS:
                raise ValueError('unknown arm %r (one of %s)' % (arm, ', '.join(ARMS)))
            old = self._arms.get(arm)
            if old is not None and not any(d.goal is old for d in out):
                out.append(Displaced(old, [a for a in self._axes[id(old)] if a not in axes]))
        return out

    def take_over(self, arms, axes):
        """Remove the goals a new goal for ``arms`` displaces; returns them (``Displaced``).
        An old goal holding both arms ends even when the new goal is for one of them."""
        out = self.displaced_by(arms, axes)
        for d in out:
            self.remove(d.goal)
        return out

    def add(self, goal, arms, axes):
        """Make ``goal`` the running goal of ``arms``; returns what it displaced."""
        out = self.take_over(arms, axes)
        for arm in arms:
            self._arms[arm] = goal
        self._axes[id(goal)] = list(axes)
        return out

    def remove(self, goal):
        """Forget ``goal``; True when it was running (False: already ended or displaced)."""
        arms = self.arms_of(goal)
        for arm in arms:
            del self._arms[arm]
        if arms:
            del self._axes[id(goal)]
        return bool(arms)

    def clear(self):
        """Forget every goal; returns them (each once)."""
        goals = self.goals()
        self._arms.clear()
        self._axes.clear()
        return goals


def split_actions(actions, own):
    """Which goal-handle calls a thread may make now: ``actions`` are (server name, call)
    pairs, ``own`` the server whose callback runs in this thread (holding that server's lock),
    or None (a thread holding no action server lock: the poll thread, a service). Returns
    (now, later): a callback makes only its own server's calls; the others wait for the poll
    thread. Two servers' callbacks each finishing the other's goals would each wait for the
    other's lock for ever."""
    if own is None:
        return [call for _, call in actions], []
    now = [call for key, call in actions if key == own]
    later = [(key, call) for key, call in actions if key != own]
    return now, later
