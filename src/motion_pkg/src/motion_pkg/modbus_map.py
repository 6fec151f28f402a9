"""Register map of the multi-axis motion controller: addresses, scaling, bits, fault texts.

Pure logic (no ROS, no networking): loads config/register_map.yaml and encodes commands /
decodes register blocks. The map is documented in harvest_sim/docs/register_map.md.
"""

import yaml

MAX_READ_REGISTERS = 125        # Modbus limit of one read holding registers request


def split_int32(value):
    """Signed int32 -> [high word, low word]."""
    value = int(value)
    if not -2 ** 31 <= value < 2 ** 31:
        raise ValueError('value %d does not fit in int32' % value)
    raw = value & 0xFFFFFFFF
    return [raw >> 16, raw & 0xFFFF]


def join_int32(high, low):
    """[high word, low word] -> signed int32."""
    raw = join_uint32(high, low)
    return raw - 2 ** 32 if raw >= 2 ** 31 else raw


def split_uint32(value):
    """Unsigned int32 -> [high word, low word]."""
    value = int(value)
    if not 0 <= value <= 0xFFFFFFFF:
        raise ValueError('value %d does not fit in uint32' % value)
    return [value >> 16, value & 0xFFFF]


def join_uint32(high, low):
    """[high word, low word] -> unsigned int32."""
    return ((int(high) & 0xFFFF) << 16) | (int(low) & 0xFFFF)


def parse_serial_number(value):
    """A controller serial number from a parameter: int, or text in decimal or 0x hex.

    1..4294967295 (the uint32 of the identity block; 0 is what a controller without one reads).
    Text lets launch files pass values beyond XML-RPC's signed 32-bit integers.
    """
    try:
        number = value if isinstance(value, int) else int(str(value).strip(), 0)
    except ValueError:
        raise ValueError('serial number %r is not an integer (decimal or 0x hex)' % (value,))
    if isinstance(number, bool) or not 1 <= number <= 0xFFFFFFFF:
        raise ValueError('serial number %r is outside 1..4294967295' % (value,))
    return number


class AxisInfo(object):
    """Name, URDF joint and counts per SI unit (m or rad) of one controller axis."""

    __slots__ = ('index', 'name', 'joint', 'counts')

    def __init__(self, index, name, joint, counts):
        self.index = index
        self.name = name
        self.joint = joint
        self.counts = counts

    def to_counts(self, value):
        counts = int(round(value * self.counts))
        if not -2 ** 31 <= counts < 2 ** 31:
            raise ValueError('%g does not fit the %s register' % (value, self.name))
        return counts

    def to_si(self, counts):
        return counts / self.counts


class AxisState(object):
    """Decoded feedback of one axis (SI units)."""

    __slots__ = ('position', 'velocity', 'status', 'enabled', 'moving', 'in_position', 'fault',
                 'fault_code')

    def __init__(self, position, velocity, status, bits, fault_code):
        self.position = position
        self.velocity = velocity
        self.status = status
        self.enabled = bool(status & (1 << bits['enabled']))
        self.moving = bool(status & (1 << bits['moving']))
        self.in_position = bool(status & (1 << bits['in_position']))
        self.fault = bool(status & (1 << bits['fault'])) or fault_code != 0
        self.fault_code = fault_code


class ControllerState(object):
    """One poll of the controller: system block, I/O and every axis."""

    def __init__(self, heartbeat, io_status, shear_count, axes, io_bits):
        self.heartbeat = heartbeat
        self.io_status = io_status
        self.shear_count = shear_count
        self.axes = axes
        self.suction_valve = bool(io_status & (1 << io_bits['suction_valve']))
        self.vacuum_ok = bool(io_status & (1 << io_bits['vacuum_ok']))
        self.shear_busy = bool(io_status & (1 << io_bits['shear_busy']))
        self.shear_closed = bool(io_status & (1 << io_bits['shear_closed']))

    @property
    def positions(self):
        return [a.position for a in self.axes]

    @property
    def velocities(self):
        return [a.velocity for a in self.axes]


class RegisterMap(object):
    """The controller's register map loaded from YAML."""

    def __init__(self, data):
        rm = data['register_map'] if 'register_map' in data else data
        self.raw = rm
        self.version = int(rm['version'])
        self.identity = int(rm['identity'])
        scaling = rm['scaling']
        self.axes = [AxisInfo(i, a['name'], a['joint'], float(scaling[a['scaling']]))
                     for i, a in enumerate(rm['axes'])]
        self.system = {k: int(v['address']) for k, v in rm['system'].items()}
        self.system_bits = dict(rm['system_control_bits'])
        self.io_bits = dict(rm['io_status_bits'])
        self.fb_base = int(rm['feedback']['base'])
        self.fb_stride = int(rm['feedback']['stride'])
        self.fb = {k: int(v['offset']) for k, v in rm['feedback']['registers'].items()}
        self.cmd_base = int(rm['command']['base'])
        self.cmd_stride = int(rm['command']['stride'])
        self.cmd = {k: int(v['offset']) for k, v in rm['command']['registers'].items()}
        self.cw_bits = dict(rm['control_word_bits'])
        self.sw_bits = dict(rm['status_word_bits'])
        self.coils = dict(rm['coils'])
        self.discrete_inputs = dict(rm['discrete_inputs'])
        self.faults = {int(k): v for k, v in rm['fault_codes'].items()}
        if rm.get('int32_word_order', 'high_first') != 'high_first':
            raise ValueError('only high_first int32 word order is supported')
        start, count = self.poll_span()
        if count > MAX_READ_REGISTERS:
            raise ValueError('poll span of %d registers exceeds one Modbus read' % count)

    @classmethod
    def from_file(cls, path):
        with open(path) as stream:
            return cls(yaml.safe_load(stream))

    # --- names -------------------------------------------------------------------------
    @property
    def axis_names(self):
        return [a.name for a in self.axes]

    @property
    def joint_names(self):
        return [a.joint for a in self.axes]

    def axis(self, name):
        for info in self.axes:
            if info.name == name:
                return info
        raise KeyError('no axis %r in the register map' % name)

    def fault_text(self, code):
        entry = self.faults.get(int(code))
        if entry is None:
            return 'unknown drive fault code %d' % code
        return entry['text']

    def fault_name(self, code):
        entry = self.faults.get(int(code))
        return entry['name'] if entry else 'code_%d' % code

    # --- addresses ---------------------------------------------------------------------
    def feedback_address(self, axis_index, field):
        return self.fb_base + self.fb_stride * axis_index + self.fb[field]

    def command_address(self, axis_index, field):
        return self.cmd_base + self.cmd_stride * axis_index + self.cmd[field]

    def poll_span(self):
        """(start, count) of the one read that covers the system block and all feedback."""
        start = min(self.system.values())
        end = self.fb_base + self.fb_stride * len(self.axes)
        return start, end - start

    # --- decoding ----------------------------------------------------------------------
    def decode_poll(self, registers):
        """Registers of poll_span() -> ControllerState."""
        start, count = self.poll_span()
        if len(registers) < count:
            raise ValueError('poll answer has %d registers, expected %d' % (len(registers), count))

        def reg(address):
            return registers[address - start]

        axes = []
        for info in self.axes:
            pos = self.feedback_address(info.index, 'actual_position')
            vel = self.feedback_address(info.index, 'actual_velocity')
            axes.append(AxisState(
                info.to_si(join_int32(reg(pos), reg(pos + 1))),
                info.to_si(join_int32(reg(vel), reg(vel + 1))),
                reg(self.feedback_address(info.index, 'status_word')), self.sw_bits,
                reg(self.feedback_address(info.index, 'fault_code'))))
        return ControllerState(reg(self.system['heartbeat']), reg(self.system['io_status']),
                               reg(self.system['shear_count']), axes, self.io_bits)

    def identity_span(self):
        """(start, count) of the one read that covers the identity block: identity, map
        version, axis count and the serial number (uint32)."""
        addresses = [self.system[k] for k in ('identity', 'map_version', 'axis_count')]
        if 'serial_number' in self.system:
            addresses.append(self.system['serial_number'] + 1)
        start = min(self.system.values())
        return start, max(addresses) + 1 - start

    def check_identity(self, registers, serial_number=None):
        """Registers of identity_span() -> None or a text saying what is wrong.

        serial_number: the one controller this driver may drive (None: any serial number; the
        register map's own checks only, and then the first three registers suffice).
        """
        ident = registers[self.system['identity']]
        version = registers[self.system['map_version']]
        count = registers[self.system['axis_count']]
        if ident != self.identity:
            return 'controller identity 0x%04x, expected 0x%04x' % (ident, self.identity)
        if version != self.version:
            return 'controller register map version %d, driver expects %d' % (version, self.version)
        if count != len(self.axes):
            return 'controller has %d axes, register map lists %d' % (count, len(self.axes))
        if serial_number is not None:
            if 'serial_number' not in self.system:
                raise ValueError('the register map has no serial_number register')
            address = self.system['serial_number']
            if len(registers) < address + 2:
                raise ValueError('identity check needs registers up to %d' % (address + 1))
            got = join_uint32(registers[address], registers[address + 1])
            if got == 0:
                return ('controller reports no serial number (registers %d-%d read 0), expected '
                        '%d' % (address, address + 1, serial_number))
            if got != serial_number:
                return 'controller serial number %d, expected %d' % (got, serial_number)
        return None

    # --- encoding ----------------------------------------------------------------------
    def control_word(self, *bits):
        value = 0
        for bit in bits:
            value |= 1 << self.cw_bits[bit]
        return value

    def system_word(self, *bits):
        value = 0
        for bit in bits:
            value |= 1 << self.system_bits[bit]
        return value

    def encode_move(self, axis_index, target, speed=0.0, acceleration=0.0):
        """(address, registers) writing target, speed, acceleration and enable+start at once.

        speed / acceleration 0 = the axis maximum. The block must be contiguous in the map.
        """
        info = self.axes[axis_index]
        offsets = self.cmd
        first = min(offsets['target_position'], offsets['speed'], offsets['acceleration'],
                    offsets['control_word'])
        last = max(offsets['target_position'] + 1, offsets['speed'] + 1,
                   offsets['acceleration'] + 1, offsets['control_word'])
        block = [0] * (last - first + 1)
        if speed < 0.0 or acceleration < 0.0:
            raise ValueError('speed and acceleration must be >= 0')
        for field, value in (('target_position', target), ('speed', speed),
                             ('acceleration', acceleration)):
            o = offsets[field] - first
            block[o:o + 2] = split_int32(info.to_counts(value))
        block[offsets['control_word'] - first] = self.control_word('enable', 'start')
        return self.cmd_base + self.cmd_stride * axis_index + first, block
