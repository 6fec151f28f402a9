"""Goal validation of the motion action servers (pure logic, no ROS): axis limits from robot.yaml,
MoveRobot goal checks, the rest-to-rest move duration and the multi-axis move plan.

The goal monitors, the MoveRobot ``succeed`` codes and the status summary are in motion_monitors,
the goals per arm in motion_arm_goals; their names are re-exported here, so every
``motion_goals.<name>`` keeps working.
"""

import math

from harvest_description import robot_config

# re-exported (see the module docstring)
from motion_pkg.motion_arm_goals import (  # noqa: F401
    ARMS, ArmGoals, Displaced, goal_arms, goal_scope, split_actions, waist_settled)
from motion_pkg.motion_monitors import (  # noqa: F401
    CONNECTION_LOST, DRIVE_FAULT, FAILURE, HALTED, INVALID_GOAL, REFUSED, SUCCESS, TIMEOUT,
    AxesMoveMonitor, Monitor, Outcome, ShearMonitor, SuctionOffMonitor, SuctionOnMonitor,
    status_summary)

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
