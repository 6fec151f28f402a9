"""Behaviour of the simulated multi-axis motion controller behind its Modbus registers.

Pure logic, no ROS, no networking. Every call takes the current controller time ``t`` (seconds;
the ROS node passes ROS time, so the model follows /clock). Axis motion is evaluated
analytically from trapezoidal profiles (controller_profile), so a register read returns the
exact state at that instant. The register layout is in controller_map; one axis (drive) is
controller_axis.SimAxis, whose names are re-exported here.

Thread safety: all public methods take one lock (the Modbus server thread and the ROS timer
thread both call in).
"""

import math
import threading

from harvest_sim import controller_map as cm

# re-exported: every controller_model.<name> keeps working
from harvest_sim.controller_axis import (  # noqa: F401
    HALF_COUNT, AxisConfig, SimAxis, axes_from_robot_config)


class ControllerModel(object):
    """All axes plus the suction valve, vacuum sensor and pneumatic shear."""

    def __init__(self, axis_configs, suction_build_up=0.5, shear_stroke=0.3, shear_hold=0.2,
                 t0=0.0, serial_number=cm.DEFAULT_SERIAL_NUMBER):
        """serial_number: what the identity block reports (1..4294967295, int or text)."""
        self._lock = threading.RLock()
        self.serial_number = cm.parse_serial_number(serial_number)
        self._serial_words = cm.split_uint32(self.serial_number)
        self.axes = [SimAxis(c) for c in axis_configs]
        self.names = [c.name for c in axis_configs]
        self.suction_build_up = float(suction_build_up)
        self.shear_stroke = float(shear_stroke)
        self.shear_hold = float(shear_hold)
        self._t = t0
        self.valve_open = False
        self._valve_since = t0
        self.sealed = False
        self._sealed_since = t0
        self._shear_start = None
        self._shear_close_reported = False
        self.shear_count = 0
        self._events = []
        self._closure_pose = None

    # --- time ----------------------------------------------------------------------------
    def _now(self, t):
        """Controller time never runs backwards; also advances the shear."""
        self._t = max(self._t, float(t))
        t = self._t
        if self._shear_start is not None:
            close = self._shear_start + self.shear_stroke
            if not self._shear_close_reported and t >= close:
                self._shear_close_reported = True
                self.shear_count = (self.shear_count + 1) & 0xFFFF
                self._events.append(('shear_cut', close))
                # the axes as nobody has yet seen the closure (no move can have followed it)
                states = [a.state(t) for a in self.axes]
                self._closure_pose = (t, [st[0] for st in states], [st[1] for st in states])
            if t >= close + self.shear_hold:
                self._shear_start = None
        return t

    def update(self, t):
        with self._lock:
            self._now(t)

    # --- I/O -----------------------------------------------------------------------------
    def vacuum_ok(self, t):
        with self._lock:
            t = self._now(t)
            return (self.valve_open and self.sealed and
                    t - max(self._valve_since, self._sealed_since) >= self.suction_build_up - 1e-9)

    def shear_closed(self, t):
        with self._lock:
            t = self._now(t)
            return (self._shear_start is not None and
                    t >= self._shear_start + self.shear_stroke)

    def shear_busy(self, t):
        with self._lock:
            self._now(t)
            return self._shear_start is not None

    def set_valve(self, flag, t):
        with self._lock:
            t = self._now(t)
            flag = bool(flag)
            if flag != self.valve_open:
                self.valve_open = flag
                self._valve_since = t
                self._events.append(('valve', t, flag))
                if not flag and self.sealed:
                    # closing lets go of whatever the cup held (the world releases it and
                    # reports its seal anew under the next opening): a seal still counted when
                    # the world's release is late would read vacuum on an empty cup
                    self.sealed = False
                    self._sealed_since = t

    def start_shear(self, t):
        with self._lock:
            t = self._now(t)
            if self._shear_start is None:
                self._shear_start = t
                self._shear_close_reported = False

    def set_sealed(self, flag, t):
        with self._lock:
            t = self._now(t)
            flag = bool(flag)
            if flag != self.sealed:
                self.sealed = flag
                self._sealed_since = t

    def pop_closure_pose(self):
        """(t, positions, velocities) of every axis when the last shear closure was first
        noticed (by a register read or the clock), then None until the next one. Noticing it is
        what lets anyone react to it, so the arm is still where it closed: a joint state at
        this time lets the world judge the cut even when the controller's next regular joint
        state comes after the arm has moved on (sparse timer ticks on a busy machine)."""
        with self._lock:
            pose, self._closure_pose = self._closure_pose, None
            return pose

    def pop_events(self, t):
        """Events since the last call: ('valve', t, open) and ('shear_cut', t_close)."""
        with self._lock:
            self._now(t)
            events, self._events = self._events, []
            return events

    # --- axes ----------------------------------------------------------------------------
    def axis_index(self, axis):
        if isinstance(axis, str) and not axis.isdigit():
            if axis not in self.names:
                raise ValueError('unknown axis %r (axes: %s)' % (axis, ', '.join(self.names)))
            return self.names.index(axis)
        index = int(axis)
        if not 0 <= index < len(self.axes):
            raise ValueError('axis index %d out of range 0..%d' % (index, len(self.axes) - 1))
        return index

    def inject_axis_fault(self, axis, code, t):
        code = int(code)
        if not 1 <= code <= 0xFFFF:
            raise ValueError('fault code must be 1..65535')
        with self._lock:
            t = self._now(t)
            self.axes[self.axis_index(axis)].raise_fault(code, t)

    def joint_states(self, t):
        """(positions, velocities) of all axes in SI units, controller order."""
        with self._lock:
            t = self._now(t)
            states = [a.state(t) for a in self.axes]
        return [s[0] for s in states], [s[1] for s in states]

    def any_moving(self, t):
        with self._lock:
            t = self._now(t)
            return any(a.moving(t) for a in self.axes)

    def busy_until(self, t):
        """Time until which something is under way: an axis moving (its profile's end), the
        vacuum building up on a sealed cup, the shear closing and holding; t when all is at
        rest. Only commands (and the seal) change it, so it is known as soon as they come."""
        with self._lock:
            t = self._now(t)
            until = t
            for a in self.axes:
                if a.moving(t):
                    until = max(until, a.profile.end_time)
            if self.valve_open and self.sealed:
                until = max(until, max(self._valve_since, self._sealed_since) +
                            self.suction_build_up)
            if self._shear_start is not None:
                until = max(until, self._shear_start + self.shear_stroke + self.shear_hold)
            return until

    # --- Modbus data model ---------------------------------------------------------------
    @staticmethod
    def writable_holding(address, count):
        """Only the system control register and the axis command area accept writes."""
        end = address + count
        if address == cm.REG_SYSTEM_CONTROL and count == 1:
            return True
        return cm.COMMAND_BASE <= address and end <= cm.COMMAND_BASE + cm.COMMAND_STRIDE * 8

    def valid(self, table, address, count, write=False):
        """table: 'h' holding registers, 'c' coils, 'd' discrete inputs, 'i' input registers."""
        if count < 1 or address < 0:
            return False
        end = address + count
        if table == 'h':
            if end > cm.HOLDING_REGISTER_COUNT:
                return False
            return self.writable_holding(address, count) if write else True
        if table == 'c':
            return end <= cm.COIL_COUNT
        if table == 'd':
            return not write and end <= cm.DI_COUNT
        return False

    def _holding(self, address, t):
        n_axes = len(self.axes)
        if address < cm.SYSTEM_BLOCK_SIZE:
            return {
                cm.REG_IDENTITY: cm.IDENTITY,
                cm.REG_MAP_VERSION: cm.MAP_VERSION,
                cm.REG_AXIS_COUNT: n_axes,
                cm.REG_HEARTBEAT: int(math.floor(t * 100.0)) & 0xFFFF,
                cm.REG_IO_STATUS: self._io_status(t),
                cm.REG_SHEAR_COUNT: self.shear_count,
                cm.REG_SERIAL_NUMBER: self._serial_words[0],
                cm.REG_SERIAL_NUMBER + 1: self._serial_words[1],
            }.get(address, 0)
        if cm.FEEDBACK_BASE <= address < cm.FEEDBACK_BASE + cm.FEEDBACK_STRIDE * n_axes:
            axis, offset = divmod(address - cm.FEEDBACK_BASE, cm.FEEDBACK_STRIDE)
            return self.axes[axis].feedback(t)[offset]
        if cm.COMMAND_BASE <= address < cm.COMMAND_BASE + cm.COMMAND_STRIDE * n_axes:
            axis, offset = divmod(address - cm.COMMAND_BASE, cm.COMMAND_STRIDE)
            return self.axes[axis].command[offset]
        return 0

    def _io_status(self, t):
        return ((self.valve_open << cm.IO_SUCTION_VALVE)
                | (self.vacuum_ok(t) << cm.IO_VACUUM_OK)
                | (self.shear_busy(t) << cm.IO_SHEAR_BUSY)
                | (self.shear_closed(t) << cm.IO_SHEAR_CLOSED))

    def read_holding(self, address, count, t):
        with self._lock:
            t = self._now(t)
            feedback_cache = {}
            out = []
            feedback_end = cm.FEEDBACK_BASE + cm.FEEDBACK_STRIDE * len(self.axes)
            for addr in range(address, address + count):
                if cm.FEEDBACK_BASE <= addr < feedback_end:
                    axis, offset = divmod(addr - cm.FEEDBACK_BASE, cm.FEEDBACK_STRIDE)
                    if axis not in feedback_cache:       # one consistent sample per axis
                        feedback_cache[axis] = self.axes[axis].feedback(t)
                    out.append(feedback_cache[axis][offset])
                else:
                    out.append(self._holding(addr, t))
            return out

    def halts_in(self, address, values):
        """What a write of `values` to holding registers from `address` halts: ['all'] for the
        system control register's halt-all bit, else the names of the axes whose control word
        carries the halt bit; [] when it halts nothing (the halt event of ``sim_controller``)."""
        halted = []
        n_axes = len(self.axes)
        for i, value in enumerate(values):
            addr = address + i
            if addr == cm.REG_SYSTEM_CONTROL and int(value) & (1 << cm.SYS_HALT_ALL):
                return ['all']
            if cm.COMMAND_BASE <= addr < cm.COMMAND_BASE + cm.COMMAND_STRIDE * n_axes:
                axis, offset = divmod(addr - cm.COMMAND_BASE, cm.COMMAND_STRIDE)
                if offset == cm.CMD_CONTROL_WORD and int(value) & (1 << cm.CW_HALT):
                    halted.append(self.names[axis])
        return halted

    def write_holding(self, address, values, t):
        with self._lock:
            t = self._now(t)
            for i, value in enumerate(values):
                addr = address + i
                value = int(value) & 0xFFFF
                if addr == cm.REG_SYSTEM_CONTROL:
                    self._system_control(value, t)
                elif cm.COMMAND_BASE <= addr < cm.COMMAND_BASE + cm.COMMAND_STRIDE * len(self.axes):
                    axis, offset = divmod(addr - cm.COMMAND_BASE, cm.COMMAND_STRIDE)
                    self.axes[axis].write_command(offset, value, t)

    def _system_control(self, value, t):
        for axis in self.axes:
            if value & (1 << cm.SYS_CLEAR_FAULTS):
                axis.fault = cm.FAULT_NONE
            if value & (1 << cm.SYS_HALT_ALL):
                axis.halt(t)
            if value & (1 << cm.SYS_DISABLE_ALL):
                axis.set_enable(False, t)
                axis.command[cm.CMD_CONTROL_WORD] = 0
            if value & (1 << cm.SYS_ENABLE_ALL):
                axis.set_enable(True, t)
                axis.command[cm.CMD_CONTROL_WORD] = 1 << cm.CW_ENABLE

    def read_coils(self, address, count, t):
        with self._lock:
            t = self._now(t)
            coils = [0] * cm.COIL_COUNT
            coils[cm.COIL_SUCTION_VALVE] = int(self.valve_open)
            coils[cm.COIL_SHEAR] = int(self._shear_start is not None)
            return coils[address:address + count]

    def write_coils(self, address, values, t):
        with self._lock:
            for i, value in enumerate(values):
                addr = address + i
                if addr == cm.COIL_SUCTION_VALVE:
                    self.set_valve(bool(value), t)
                elif addr == cm.COIL_SHEAR and value:
                    self.start_shear(t)

    def read_discrete(self, address, count, t):
        with self._lock:
            t = self._now(t)
            inputs = [0] * cm.DI_COUNT
            inputs[cm.DI_VACUUM_OK] = int(self.vacuum_ok(t))
            inputs[cm.DI_SHEAR_CLOSED] = int(self.shear_closed(t))
            inputs[cm.DI_SUCTION_VALVE] = int(self.valve_open)
            return inputs[address:address + count]
