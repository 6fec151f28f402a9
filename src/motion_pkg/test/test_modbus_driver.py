"""Modbus driver against a plain pymodbus server (no simulator, no ROS): polling, commands,
lost connections, back-off and Modbus exceptions."""

import asyncio
import os
import sys
import threading

import pytest
from pymodbus.datastore import ModbusSequentialDataBlock, ModbusServerContext, ModbusSlaveContext
from pymodbus.pdu import ExceptionResponse
from pymodbus.server import ModbusTcpServer

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(HERE, '..', 'src'))

from harvest_test_utils.net import free_port  # noqa: E402
from motion_pkg.modbus_driver import (Backoff, ConnectionLost, ControllerRefused,  # noqa: E402
                                      ModbusDriver)
from motion_pkg.modbus_map import RegisterMap, split_int32, split_uint32  # noqa: E402

MAP = RegisterMap.from_file(os.path.join(HERE, '..', 'config', 'register_map.yaml'))


class PlainServer(object):
    """A register bank on a loopback port, served from a thread."""

    def __init__(self, identity=0x4843, serial_number=1):
        self.port = free_port()
        self.hr = ModbusSequentialDataBlock(0, [0] * 200)
        self.co = ModbusSequentialDataBlock(0, [False] * 8)
        self.hr.setValues(0, [identity, 1, 8])
        self.hr.setValues(7, split_uint32(serial_number))      # 0: no identity block
        self.context = ModbusServerContext(slaves={1: ModbusSlaveContext(
            hr=self.hr, co=self.co, di=ModbusSequentialDataBlock(0, [False] * 8),
            ir=ModbusSequentialDataBlock(0, [0] * 8), zero_mode=True)}, single=False)
        self.exception = 0
        self.loop = asyncio.new_event_loop()
        self.thread = threading.Thread(target=self.loop.run_forever, daemon=True)
        self.thread.start()
        self.server = None
        self.listen(True)

    def _manipulate(self, response):
        if self.exception:
            refusal = ExceptionResponse(response.function_code & 0x7F, self.exception)
            refusal.transaction_id = response.transaction_id
            refusal.slave_id = response.slave_id
            return refusal, False
        return response, False

    def listen(self, flag):
        async def go():
            if flag:
                self.server = ModbusTcpServer(self.context, address=('127.0.0.1', self.port),
                                              response_manipulator=self._manipulate)
                assert await self.server.listen()
            else:
                await self.server.shutdown()
        asyncio.run_coroutine_threadsafe(go(), self.loop).result(5.0)

    def stop(self):
        self.listen(False)
        self.loop.call_soon_threadsafe(self.loop.stop)
        self.thread.join(5.0)


@pytest.fixture
def server():
    srv = PlainServer()
    yield srv
    srv.stop()


def make_driver(port, serial_number=None):
    return ModbusDriver(MAP, '127.0.0.1', port, 1, timeout=0.5, backoff_first=0.1,
                        backoff_max=0.4, serial_number=serial_number)


def test_backoff_schedule():
    b = Backoff(0.1, 0.5)
    assert b.due(0.0)
    delays = []
    for _ in range(5):
        b.failed(10.0)
        delays.append(b.delay)
    assert delays == [0.1, 0.2, 0.4, 0.5, 0.5]
    assert not b.due(10.4) and b.due(10.5)
    b.reset()
    assert b.due(0.0)


def test_poll_decodes_registers(server):
    base = 16 + 8 * 2                                    # right_lift
    server.hr.setValues(base, split_int32(12345) + split_int32(-500) + [0b0101, 0])
    server.hr.setValues(5, [0b0001, 9])
    driver = make_driver(server.port)
    assert driver.ensure_connected(0.0) and driver.connects == 1
    state = driver.poll()
    assert state.axes[2].position == pytest.approx(0.12345)
    assert state.axes[2].velocity == pytest.approx(-0.005)
    assert state.axes[2].enabled and state.axes[2].in_position and not state.axes[2].moving
    assert state.suction_valve and not state.vacuum_ok and state.shear_count == 9
    driver.close()


def test_commands_write_the_map(server):
    driver = make_driver(server.port)
    assert driver.ensure_connected(0.0)
    driver.move(3, 0.5, 1.0, 3.0)                        # right_boom
    block = server.hr.getValues(130, 7)
    assert block[:2] == split_int32(MAP.axis('right_boom').to_counts(0.5))
    assert block[6] == 0b11
    driver.halt([5, 6])
    assert server.hr.getValues(156, 1) == [0b101] and server.hr.getValues(166, 1) == [0b101]
    driver.enable_all()
    assert server.hr.getValues(4, 1) == [0b101]
    driver.halt_all()
    assert server.hr.getValues(4, 1) == [0b010]
    driver.set_suction(True)
    driver.shear()
    assert server.co.getValues(0, 2) == [True, True]
    driver.close()


def test_wrong_controller_is_refused():
    srv = PlainServer(identity=0x1111)
    try:
        driver = make_driver(srv.port)
        assert not driver.ensure_connected(0.0)
        assert 'identity' in driver.last_error
        assert not driver.connected
    finally:
        srv.stop()


def test_lost_connection_and_backoff(server):
    driver = make_driver(server.port)
    assert driver.ensure_connected(0.0)
    server.listen(False)
    with pytest.raises(ConnectionLost) as err:
        driver.poll()
    assert 'lost connection' in str(err.value)
    assert not driver.connected and driver.failures == 1
    with pytest.raises(ConnectionLost):
        driver.move(0, 1.0)
    assert not driver.ensure_connected(1.0)               # refused; back-off 0.1 s
    assert not driver.ensure_connected(1.05)              # not due: no attempt
    assert driver.backoff.delay == 0.1
    assert not driver.ensure_connected(1.1)
    assert driver.backoff.delay == 0.2
    server.listen(True)
    assert not driver.ensure_connected(1.2)               # still backing off
    assert driver.ensure_connected(1.3)
    assert driver.connects == 2 and driver.backoff.delay == 0.0
    driver.poll()
    driver.close()


def test_modbus_exception_keeps_connection(server):
    driver = make_driver(server.port)
    assert driver.ensure_connected(0.0)
    server.exception = 6
    with pytest.raises(ControllerRefused) as err:
        driver.poll()
    assert 'exception 6 (slave device busy)' in str(err.value)
    assert driver.connected
    server.exception = 0
    driver.poll()
    driver.close()


def untouched(srv):
    """Nothing was written: system control, every command block and the coils read 0."""
    return (srv.hr.getValues(4, 1) == [0] and srv.hr.getValues(100, 80) == [0] * 80
            and srv.co.getValues(0, 8) == [False] * 8)


def test_configured_controller_is_accepted():
    srv = PlainServer(serial_number=0xC0FFEE01)
    try:
        driver = make_driver(srv.port, '0xC0FFEE01')
        assert driver.ensure_connected(0.0)
        assert driver.refused == '' and driver.last_error == ''
        driver.halt_all()
        assert srv.hr.getValues(4, 1) == [0b010]
        driver.close()
    finally:
        srv.stop()


@pytest.mark.parametrize('reported,expected_text', [
    (4712, 'controller serial number 4712, expected 4711'),
    (0, 'reports no serial number'),              # a controller without the identity block
])
def test_other_controller_is_refused_and_nothing_sent(reported, expected_text):
    srv = PlainServer(serial_number=reported)
    try:
        driver = make_driver(srv.port, 4711)
        assert not driver.ensure_connected(0.0)
        assert not driver.connected and driver.connects == 0
        assert expected_text in driver.refused and expected_text in driver.last_error
        assert 'refused the controller at 127.0.0.1:%d' % srv.port in driver.refused
        assert 'wrong controller' in driver.last_error
        for command in (lambda: driver.move(0, 0.5), driver.enable_all, driver.halt_all,
                        driver.shear, lambda: driver.set_suction(True), driver.poll):
            with pytest.raises(ConnectionLost):
                command()
        assert not driver.ensure_connected(0.1)     # refused again at every attempt
        assert driver.backoff.delay == 0.2 and expected_text in driver.refused
        assert untouched(srv)
    finally:
        srv.stop()


def test_refusal_clears_when_the_right_controller_answers():
    srv = PlainServer(serial_number=5)
    try:
        driver = make_driver(srv.port, 6)
        assert not driver.ensure_connected(0.0) and driver.refused
        srv.hr.setValues(7, split_uint32(6))      # now the configured controller is there
        assert driver.ensure_connected(1.0)
        assert driver.refused == '' and driver.last_error == '' and driver.connects == 1
        driver.close()
    finally:
        srv.stop()


def test_bad_configured_serial_number():
    with pytest.raises(ValueError):
        make_driver(1, 0)
