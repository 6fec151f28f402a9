"""One drive of the simulated multi-axis motion controller (pure logic, no ROS): the axis limits
from robot.yaml (AxisConfig, axes_from_robot_config) and SimAxis, its command registers, its
enable and fault state and its running profile (controller_profile). controller_model's
ControllerModel holds one per axis and re-exports these names.
"""

from harvest_sim import controller_map as cm
from harvest_sim.controller_profile import plan_move, plan_stop
from harvest_description import robot_config

HALF_COUNT = 0.5


class AxisConfig(object):
    """Limits and motion maxima of one axis, SI units (m or rad, per second)."""

    def __init__(self, name, minimum, maximum, max_speed, max_acceleration, initial=0.0):
        if not minimum <= initial <= maximum:
            raise ValueError('initial position %g of axis %s outside [%g, %g]'
                             % (initial, name, minimum, maximum))
        if max_speed <= 0.0 or max_acceleration <= 0.0:
            raise ValueError('axis %s needs positive maximum speed and acceleration' % name)
        self.name = name
        self.minimum = float(minimum)
        self.maximum = float(maximum)
        self.max_speed = float(max_speed)
        self.max_acceleration = float(max_acceleration)
        self.initial = float(initial)
        self.counts = cm.counts_per_unit(name)


def axes_from_robot_config(robot_yaml, initial=None):
    """AxisConfig list in controller order from the parsed robot.yaml dictionary.

    The dictionary is validated first (harvest_description.robot_config): a NaN limit or speed
    raises RobotConfigError naming the field instead of a model that cannot move."""
    robot_config.validate(robot_yaml)
    initial = initial or {}
    robot = robot_yaml['robot']
    motion = robot_yaml['motion']
    configs = []
    for name in robot_yaml['axes']:
        if name == 'cart':
            lo, hi, kind = robot['track']['min'], robot['track']['max'], 'cart'
        elif name == 'waist':
            lo, hi, kind = robot['waist']['min'], robot['waist']['max'], 'waist'
        else:
            kind = name.split('_', 1)[1]          # right_lift -> lift
            lim = robot['joint_limits'][kind]
            lo, hi = lim['min'], lim['max']
        start = float(initial.get(name, min(max(0.0, lo), hi)))
        configs.append(AxisConfig(name, lo, hi, motion['speed'][kind],
                                  motion['acceleration'][kind], start))
    return configs


class SimAxis(object):
    """One drive: command registers, enable/fault state and the running profile."""

    def __init__(self, config):
        self.cfg = config
        self.command = [0] * cm.COMMAND_STRIDE      # raw command registers
        self.enable_cmd = False
        self.fault = cm.FAULT_NONE
        self.rest_position = config.initial
        self.profile = None
        self._set_int32(cm.CMD_TARGET_POSITION, self.to_counts(config.initial))

    # --- units -------------------------------------------------------------------------
    def to_counts(self, value):
        return cm.clamp_int32(round(value * self.cfg.counts))

    def _int32(self, offset):
        return cm.join_int32(self.command[offset], self.command[offset + 1])

    def _set_int32(self, offset, value):
        self.command[offset:offset + 2] = cm.split_int32(value)

    # --- state ---------------------------------------------------------------------------
    def settle(self, t):
        if self.profile is not None and self.profile.done(t):
            self.rest_position = self.profile.end_position
            self.profile = None

    def state(self, t):
        """(position, velocity) in SI units."""
        self.settle(t)
        if self.profile is None:
            return self.rest_position, 0.0
        return self.profile.state(t)

    @property
    def enabled(self):
        return self.enable_cmd and self.fault == cm.FAULT_NONE

    def moving(self, t):
        self.settle(t)
        return self.profile is not None

    def status_word(self, t):
        pos, _ = self.state(t)
        moving = self.profile is not None
        in_pos = (not moving and abs(self.to_counts(pos) - self._int32(cm.CMD_TARGET_POSITION))
                  <= cm.IN_POSITION_WINDOW)
        return ((self.enabled << cm.SW_ENABLED) | (moving << cm.SW_MOVING)
                | (in_pos << cm.SW_IN_POSITION) | ((self.fault != 0) << cm.SW_FAULT))

    def feedback(self, t):
        pos, vel = self.state(t)
        regs = [0] * cm.FEEDBACK_STRIDE
        regs[cm.FB_ACTUAL_POSITION:cm.FB_ACTUAL_POSITION + 2] = cm.split_int32(self.to_counts(pos))
        regs[cm.FB_ACTUAL_VELOCITY:cm.FB_ACTUAL_VELOCITY + 2] = cm.split_int32(self.to_counts(vel))
        regs[cm.FB_STATUS_WORD] = self.status_word(t)
        regs[cm.FB_FAULT_CODE] = self.fault
        return regs

    # --- commands ------------------------------------------------------------------------
    def halt(self, t):
        pos, vel = self.state(t)
        if self.profile is not None:
            self.profile = plan_stop(t, pos, vel, self.cfg.max_acceleration)
            self.rest_position = self.profile.end_position
            self.settle(t)

    def raise_fault(self, code, t):
        self.fault = int(code)
        self.halt(t)

    def set_enable(self, flag, t):
        if self.enable_cmd and not flag:
            self.halt(t)
        self.enable_cmd = bool(flag)

    def start(self, t):
        if self.fault != cm.FAULT_NONE:
            return
        if not self.enable_cmd:
            self.raise_fault(cm.FAULT_NOT_ENABLED, t)
            return
        target = self._int32(cm.CMD_TARGET_POSITION) / self.cfg.counts
        half = HALF_COUNT / self.cfg.counts
        if not self.cfg.minimum - half <= target <= self.cfg.maximum + half:
            self.raise_fault(cm.FAULT_TARGET_OUT_OF_RANGE, t)
            return
        target = min(max(target, self.cfg.minimum), self.cfg.maximum)
        speed = self._limit(self._int32(cm.CMD_SPEED), self.cfg.max_speed)
        accel = self._limit(self._int32(cm.CMD_ACCELERATION), self.cfg.max_acceleration)
        if speed is None or accel is None:
            self.raise_fault(cm.FAULT_BAD_PROFILE, t)
            return
        pos, vel = self.state(t)
        self.profile = plan_move(t, pos, vel, target, speed, accel)
        self.rest_position = self.profile.end_position
        self.settle(t)

    def _limit(self, counts, maximum):
        """Register value (counts/s) -> SI, 0 = maximum, clipped; None when negative."""
        if counts < 0:
            return None
        if counts == 0:
            return maximum
        return min(counts / self.cfg.counts, maximum)

    def write_command(self, offset, value, t):
        """One command register written (registers of a block arrive in address order)."""
        if offset != cm.CMD_CONTROL_WORD:
            self.command[offset] = value & 0xFFFF
            return
        self.command[offset] = value & (1 << cm.CW_ENABLE)    # pulse bits read back as 0
        if value & (1 << cm.CW_CLEAR_FAULT):
            self.fault = cm.FAULT_NONE
        self.set_enable(bool(value & (1 << cm.CW_ENABLE)), t)
        if value & (1 << cm.CW_HALT):
            self.halt(t)
        if value & (1 << cm.CW_START):
            self.start(t)
