"""Modbus TCP driver of the multi-axis motion controller (pymodbus client, no ROS).

One :class:`ModbusDriver` owns one TCP connection. Every request is serialised by a lock, so
the poll loop, action servers and services may call it from their own threads. Any transport
failure (refused, closed by the peer, no answer within ``timeout``) closes the socket, marks the
driver disconnected and raises :class:`ConnectionLost`; :meth:`ensure_connected` reconnects
with exponential back-off. A Modbus exception answer raises :class:`ControllerRefused` and keeps
the connection.

Every new connection starts with one read of the identity block. A controller that is not the
one the driver is for (identity, map version, axis count, or a serial number other than
``serial_number``) is refused before anything is written: the socket is closed, the driver
stays disconnected, ``refused`` and ``last_error`` say why, and it tries again with back-off
(the right controller may come back on that address).
"""

import logging
import threading

from pymodbus.client import ModbusTcpClient
from pymodbus.exceptions import ModbusException
from pymodbus.pdu import ExceptionResponse

from motion_pkg.modbus_map import RegisterMap, parse_serial_number

MODBUS_EXCEPTIONS = {
    1: 'illegal function', 2: 'illegal data address', 3: 'illegal data value',
    4: 'slave device failure', 5: 'acknowledge', 6: 'slave device busy',
    8: 'memory parity error', 10: 'gateway path unavailable',
    11: 'gateway target device failed to respond',
}


class DriverError(Exception):
    """Base of the driver's errors; the text is meant for operators."""


class ConnectionLost(DriverError):
    """No usable TCP connection to the controller."""


class ControllerRefused(DriverError):
    """The controller answered with a Modbus exception."""


class WrongController(ConnectionLost):
    """The controller at the address is not the one this driver drives."""


class Backoff(object):
    """Exponential back-off schedule for reconnect attempts (times in the caller's clock)."""

    def __init__(self, first=0.1, maximum=2.0):
        self.first = first
        self.maximum = maximum
        self.delay = 0.0
        self.next_time = None

    def due(self, now):
        return self.next_time is None or now >= self.next_time

    def failed(self, now):
        self.delay = self.first if self.delay == 0.0 else min(self.delay * 2.0, self.maximum)
        self.next_time = now + self.delay

    def reset(self):
        self.delay = 0.0
        self.next_time = None


class ModbusDriver(object):
    """Talks to the controller through the register map."""

    def __init__(self, regmap, host, port=502, unit=1, timeout=0.25, backoff_first=0.1,
                 backoff_max=2.0, serial_number=None):
        """serial_number: the serial number the controller must report (int or text, see
        modbus_map.parse_serial_number); None accepts any (the map's own checks only)."""
        if not isinstance(regmap, RegisterMap):
            regmap = RegisterMap.from_file(regmap)
        self.map = regmap
        self.host = host
        self.port = int(port)
        self.unit = int(unit)
        self.timeout = float(timeout)
        self.serial_number = None if serial_number is None else parse_serial_number(serial_number)
        self.backoff = Backoff(backoff_first, backoff_max)
        self._client = ModbusTcpClient(host, port=self.port, timeout=self.timeout, retries=0)
        self._lock = threading.RLock()
        self.connected = False
        self.last_error = 'not connected yet'
        self.refused = ''          # why the last controller reached was refused ('' = it was not)
        self.connects = 0
        self.failures = 0
        logging.getLogger('pymodbus').setLevel(logging.CRITICAL)

    # --- connection --------------------------------------------------------------------
    def ensure_connected(self, now):
        """Connect when disconnected and the back-off allows; True when connected.

        A fresh connection is verified against the map (identity, version, axis count) and the
        serial number before anything is written; a wrong controller is refused.
        """
        with self._lock:
            if self.connected:
                return True
            if not self.backoff.due(now):
                return False
            try:
                if not self._client.connect():
                    raise ConnectionLost('connection refused or host unreachable')
                self.connected = True
                regs = self._read(*self.map.identity_span())
                problem = self.map.check_identity(regs, self.serial_number)
                if problem:
                    error = WrongController('refused the controller at %s:%d: %s; nothing is '
                                            'sent to it' % (self.host, self.port, problem))
                    error.reason = 'wrong controller refused (%s)' % problem
                    raise error
            except DriverError as exc:
                self.connected = False
                self._client.close()
                self.last_error = getattr(exc, 'reason', '') or str(exc)
                self.refused = str(exc) if isinstance(exc, WrongController) else ''
                self.backoff.failed(now)
                return False
            self.backoff.reset()
            self.connects += 1
            self.last_error = ''
            self.refused = ''
            return True

    def close(self):
        with self._lock:
            self._client.close()
            self.connected = False

    def _lost(self, what, error):
        """Close the socket and build the ConnectionLost for a failed request."""
        text = str(error)
        if 'unexpectedly closed' in text:
            reason = 'connection closed by the controller during %s' % what
        elif 'No response received' in text:
            reason = 'no answer within %.2f s to %s' % (self.timeout, what)
        else:
            reason = '%s failed: %s' % (what, text)
        self._client.close()
        self.connected = False
        self.failures += 1
        self.last_error = reason
        error = ConnectionLost('lost connection to the motion controller at %s:%d: %s'
                               % (self.host, self.port, reason))
        error.reason = reason
        return error

    def _check(self, response, what):
        if isinstance(response, ExceptionResponse):
            code = response.exception_code
            raise ControllerRefused('controller refused %s: Modbus exception %d (%s)'
                                    % (what, code, MODBUS_EXCEPTIONS.get(code, 'unknown')))
        if response is None or response.isError():
            raise self._lost(what, response)
        return response

    def _call(self, what, func, *args):
        with self._lock:
            if not self.connected:
                raise ConnectionLost('no connection to the motion controller at %s:%d: %s'
                                     % (self.host, self.port, self.last_error or 'idle'))
            try:
                response = func(*args, slave=self.unit)
            except (ModbusException, OSError) as exc:
                raise self._lost(what, exc)
            return self._check(response, what)

    def _read(self, address, count):
        return self._call('read %d@%d' % (count, address), self._client.read_holding_registers,
                          address, count).registers[:count]

    def _write(self, address, values):
        self._call('write %d@%d' % (len(values), address), self._client.write_registers,
                   address, list(values))

    # --- polling -----------------------------------------------------------------------
    def poll(self):
        """One read of the system block and all axis feedback -> ControllerState."""
        start, count = self.map.poll_span()
        return self.map.decode_poll(self._read(start, count))

    # --- commands ----------------------------------------------------------------------
    def move(self, axis_index, target, speed=0.0, acceleration=0.0):
        """Write target, speed, acceleration and enable+start of one axis in one request."""
        address, block = self.map.encode_move(axis_index, target, speed, acceleration)
        self._write(address, block)

    def halt(self, axis_indices):
        word = self.map.control_word('enable', 'halt')
        with self._lock:
            for index in axis_indices:
                self._write(self.map.command_address(index, 'control_word'), [word])

    def system(self, *bits):
        self._write(self.map.system['system_control'], [self.map.system_word(*bits)])

    def halt_all(self):
        self.system('halt_all')

    def enable_all(self):
        self.system('clear_faults', 'enable_all')

    def clear_faults(self):
        self.system('clear_faults')

    def set_coil(self, name, value):
        self._call('write coil %s' % name, self._client.write_coil, self.map.coils[name],
                   bool(value))

    def set_suction(self, on):
        self.set_coil('suction_valve', on)

    def shear(self):
        """Start one shear stroke."""
        self.set_coil('shear', True)
