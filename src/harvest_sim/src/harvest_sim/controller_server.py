"""Modbus TCP front end of the simulated motion controller (pymodbus 3.6 server, no ROS).

:class:`ControllerServer` serves a :class:`~harvest_sim.controller_model.ControllerModel` on a
loopback address from its own thread and asyncio loop, and can misbehave on request, the way a
real controller or network does (each is observable by any Modbus client):

- ``set_listening(False)``: close the listener and every connection (clients see refused
  connections) until ``set_listening(True)``;
- ``drop_connections()``: close the open connections once, keep listening;
- ``drop_connections_for(duration, now)``: close every connection and refuse new ones until
  controller time ``now + duration``; ``end_outage(now)``, called on every tick, listens again
  once that time has come (the ``~drop_connections`` service of ``sim_controller``);
- ``set_delay(seconds)``: answer every register/coil request late;
- ``set_exception(code)``: answer every register/coil request with Modbus exception ``code``
  (e.g. 4 slave device failure, 6 slave device busy); 0 = normal answers.

``parse_fault_spec`` reads the fault strings of the node's ``~fault`` parameter.
"""

import asyncio
import contextvars
import errno
import logging
import math
import socket
import threading
import time

from pymodbus.datastore import ModbusServerContext
from pymodbus.datastore.context import ModbusBaseSlaveContext
from pymodbus.pdu import ExceptionResponse
from pymodbus.server import ModbusTcpServer

from harvest_sim import controller_map as cm

LOOPBACK_HOSTS = ('127.0.0.1', 'localhost', '::1')
WRITE_FUNCTION_CODES = (5, 6, 15, 16, 22)
TABLE_OF_FUNCTION = {1: 'c', 5: 'c', 15: 'c', 2: 'd', 3: 'h', 6: 'h', 16: 'h', 22: 'h', 23: 'h',
                     4: 'i'}
OP_TIMEOUT = 5.0

_request_delayed = contextvars.ContextVar('request_delayed', default=False)


class _ModelContext(ModbusBaseSlaveContext):
    """pymodbus slave context that forwards to the controller model at the current time."""

    def __init__(self, model, clock, server):
        self._model = model
        self._clock = clock
        self._server = server

    def reset(self):
        """Nothing to reset: the model is the controller."""

    def validate(self, fc_as_hex, address, count=1):
        if self._server.exception_code:
            return False          # becomes the injected exception in _manipulate
        table = TABLE_OF_FUNCTION.get(fc_as_hex)
        if table is None:
            return False
        return self._model.valid(table, address, count, write=fc_as_hex in WRITE_FUNCTION_CODES)

    async def _maybe_delay(self):
        delay = self._server.delay
        if delay > 0.0 and not _request_delayed.get():
            _request_delayed.set(True)
            await asyncio.sleep(delay)

    async def async_getValues(self, fc_as_hex, address, count=1):
        await self._maybe_delay()
        return self.getValues(fc_as_hex, address, count)

    async def async_setValues(self, fc_as_hex, address, values):
        await self._maybe_delay()
        self.setValues(fc_as_hex, address, values)

    def getValues(self, fc_as_hex, address, count=1):
        table = TABLE_OF_FUNCTION[fc_as_hex]
        t = self._clock()
        if table == 'h':
            return self._model.read_holding(address, count, t)
        if table == 'c':
            return [bool(v) for v in self._model.read_coils(address, count, t)]
        if table == 'd':
            return [bool(v) for v in self._model.read_discrete(address, count, t)]
        return [0] * count

    def setValues(self, fc_as_hex, address, values):
        wall = time.time()          # when the write is served (after any injected delay)
        table = TABLE_OF_FUNCTION[fc_as_hex]
        t = self._clock()
        halted = []
        if table == 'h':
            if self._server.on_halt is not None:
                halted = self._model.halts_in(address, values)
            self._model.write_holding(address, values, t)
        elif table == 'c':
            self._model.write_coils(address, values, t)
        if halted:
            self._server.on_halt(t, wall, halted)
        if self._server.on_write is not None:
            self._server.on_write(t)


class BindError(OSError):
    """The controller's Modbus TCP address cannot be bound."""


def bind_problem(host, port):
    """Why host:port cannot be bound, in words (pymodbus only says that listening failed)."""
    try:
        family = socket.AF_INET6 if ':' in host else socket.AF_INET
        with socket.socket(family, socket.SOCK_STREAM) as probe:
            probe.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)   # as asyncio does
            probe.bind((host, port))
    except OSError as exc:
        if exc.errno == errno.EADDRINUSE:
            return 'the port is taken (another simulated controller or program is on it)'
        return exc.strerror or str(exc)
    return 'the listener failed (the address is free now)'


class ControllerServer(object):
    """Serves the model over Modbus TCP from a background thread."""

    def __init__(self, model, clock, host='127.0.0.1', port=5020, unit=1, on_write=None,
                 on_halt=None):
        """on_write(t): called (in the server thread) after every write to the model;
        on_halt(t, wall, halted): after a write that halts axes (controller time, time.time()
        when it was served, ControllerModel.halts_in's list)."""
        if host not in LOOPBACK_HOSTS and not host.startswith('127.'):
            raise ValueError('the simulated controller listens on loopback only, not %r' % host)
        self.host = host
        self.port = int(port)
        self.unit = int(unit)
        self.delay = 0.0
        self.exception_code = 0
        self.on_write = on_write
        self.on_halt = on_halt
        self.outage_until = None       # controller time the drop_connections window ends
        self._context = ModbusServerContext(
            slaves={self.unit: _ModelContext(model, clock, self)}, single=False)
        self._server = None
        self._loop = asyncio.new_event_loop()
        self._thread = threading.Thread(target=self._run_loop, name='modbus_server', daemon=True)
        logging.getLogger('pymodbus').setLevel(logging.CRITICAL)

    # --- lifecycle ---------------------------------------------------------------------
    def _run_loop(self):
        asyncio.set_event_loop(self._loop)
        self._loop.run_forever()

    def _call(self, coro):
        return asyncio.run_coroutine_threadsafe(coro, self._loop).result(OP_TIMEOUT)

    def start(self):
        """Start the thread and listen; raises BindError (an OSError) naming host:port and the
        reason when the address cannot be bound. The thread is stopped again then."""
        self._thread.start()
        if not self.set_listening(True):
            self.stop()
            raise BindError('cannot listen on %s:%d: %s' % (self.host, self.port,
                                                            bind_problem(self.host, self.port)))

    def stop(self):
        """Close everything and end the thread."""
        if not self._thread.is_alive():
            return
        self.set_listening(False)
        self._loop.call_soon_threadsafe(self._loop.stop)
        self._thread.join(OP_TIMEOUT)

    @property
    def listening(self):
        return self._server is not None

    def set_listening(self, flag):
        """Open or close the TCP listener (closing also drops every connection); ends a
        drop_connections_for window."""
        self.outage_until = None
        return self._call(self._set_listening(bool(flag)))

    def drop_connections_for(self, duration, now):
        """Close every client connection and refuse new ones (closed listener: connection
        refused) until controller time now + duration; end_outage(now) listens again after
        that. A new window replaces a running one; duration 0 ends a running window now.
        Returns the number of connections closed."""
        duration = float(duration)
        if math.isnan(duration) or duration < 0.0:
            raise ValueError('duration must be >= 0 s, not %r' % duration)
        if duration == 0.0:
            if self.outage_until is not None:
                self.outage_until = now
                self.end_outage(now)
            return 0
        count = self.connection_count()
        self._call(self._set_listening(False))
        self.outage_until = float(now) + duration
        return count

    def end_outage(self, now):
        """Listen again when the drop_connections_for window is over at controller time now;
        True when it did (False: no window, not over yet, or the port cannot be bound now;
        then it tries again on the next call)."""
        if self.outage_until is None or now < self.outage_until:
            return False
        if not self._call(self._set_listening(True)):
            return False
        self.outage_until = None
        return True

    @property
    def in_outage(self):
        return self.outage_until is not None

    async def _set_listening(self, flag):
        if flag and self._server is None:
            server = ModbusTcpServer(self._context, address=(self.host, self.port),
                                     response_manipulator=self._manipulate)
            if not await server.listen():
                return False
            self._server = server
        elif not flag and self._server is not None:
            server, self._server = self._server, None
            await server.shutdown()
        return True

    def drop_connections(self):
        """Close the open client connections once; returns how many were closed."""
        return self._call(self._drop())

    async def _drop(self):
        if self._server is None:
            return 0
        connections = list(self._server.active_connections.values())
        for conn in connections:
            conn.callback_disconnected(None)
            conn.close()
        return len(connections)

    def connection_count(self):
        return self._call(self._count())

    async def _count(self):
        return len(self._server.active_connections) if self._server is not None else 0

    # --- misbehaviour ------------------------------------------------------------------
    def set_delay(self, seconds):
        self.delay = max(0.0, float(seconds))

    def set_exception(self, code):
        code = int(code)
        if not 0 <= code <= 255:
            raise ValueError('Modbus exception code must be 0..255')
        self.exception_code = code

    def _manipulate(self, response):
        code = self.exception_code
        if code and isinstance(response, ExceptionResponse):
            response.exception_code = code
        return response, False


FAULT_SYNTAX = ('none | server_off | server_on | drop | delay MS | exception CODE | '
                'axis_fault AXIS CODE | clear_axis_faults; several separated by ";"')


def parse_fault_spec(text):
    """Parse a fault string into a list of (operation, args) tuples; ValueError when bad.

    Examples: "delay 300", "exception 6", "axis_fault right_boom 3", "server_off; delay 0".
    """
    ops = []
    for part in (text or '').split(';'):
        words = part.split()
        if not words:
            continue
        op, args = words[0].lower(), words[1:]
        if op in ('none', 'clear', 'server_off', 'server_on', 'drop', 'clear_axis_faults'):
            if args:
                raise ValueError('%s takes no argument' % op)
            ops.append((op, ()))
        elif op == 'delay':
            if len(args) != 1:
                raise ValueError('usage: delay MS')
            ms = float(args[0])
            if ms < 0.0:
                raise ValueError('delay must be >= 0 ms')
            ops.append((op, (ms / 1000.0,)))
        elif op == 'exception':
            if len(args) != 1:
                raise ValueError('usage: exception CODE')
            code = int(args[0])
            if not 0 <= code <= 255:
                raise ValueError('exception code must be 0..255')
            ops.append((op, (code,)))
        elif op == 'axis_fault':
            if len(args) != 2:
                raise ValueError('usage: axis_fault AXIS CODE')
            code = int(args[1])
            if not 1 <= code <= 0xFFFF:
                raise ValueError('axis fault code must be 1..65535')
            ops.append((op, (args[0], code)))
        else:
            raise ValueError('unknown fault %r; syntax: %s' % (op, FAULT_SYNTAX))
    return ops


def apply_faults(ops, model, server, t):
    """Apply parsed fault operations; returns a human-readable summary."""
    done = []
    for op, args in ops:
        if op in ('none', 'clear'):
            server.set_delay(0.0)
            server.set_exception(0)
            server.set_listening(True)
            done.append('normal service')
        elif op == 'server_off':
            server.set_listening(False)
            done.append('server off')
        elif op == 'server_on':
            if not server.set_listening(True):
                raise RuntimeError('cannot listen on %s:%d' % (server.host, server.port))
            done.append('server on')
        elif op == 'drop':
            done.append('dropped %d connection(s)' % server.drop_connections())
        elif op == 'delay':
            server.set_delay(args[0])
            done.append('delay %.0f ms' % (args[0] * 1000.0))
        elif op == 'exception':
            server.set_exception(args[0])
            done.append('exception %d' % args[0])
        elif op == 'axis_fault':
            model.inject_axis_fault(args[0], args[1], t)
            done.append('axis %s fault %d' % args)
        elif op == 'clear_axis_faults':
            model.write_holding(cm.REG_SYSTEM_CONTROL, [1 << cm.SYS_CLEAR_FAULTS], t)
            done.append('axis faults cleared')
    return ', '.join(done) if done else 'nothing to do'
