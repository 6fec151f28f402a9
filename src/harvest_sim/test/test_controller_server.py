"""Modbus TCP front end of the simulated controller: any client, injected faults."""

import os
import socket
import sys
import time

import pytest
import yaml
from pymodbus.client import ModbusTcpClient
from pymodbus.pdu import ExceptionResponse

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(HERE, '..', 'src'))

from harvest_sim import controller_map as cm  # noqa: E402
from harvest_sim.controller_model import ControllerModel, axes_from_robot_config  # noqa: E402
from harvest_sim.controller_server import (BindError, ControllerServer,  # noqa: E402
                                           apply_faults, parse_fault_spec)
from harvest_test_utils.net import free_port  # noqa: E402

ROBOT_YAML = os.path.join(HERE, '..', '..', 'harvest_description', 'config', 'robot.yaml')


class FakeClock(object):
    def __init__(self):
        self.t = 10.0

    def __call__(self):
        return self.t


@pytest.fixture
def rig():
    with open(ROBOT_YAML) as f:
        model = ControllerModel(axes_from_robot_config(yaml.safe_load(f)))
    clock = FakeClock()
    server = ControllerServer(model, clock, port=free_port())
    server.start()
    client = ModbusTcpClient('127.0.0.1', port=server.port, timeout=1.0, retries=0)
    assert client.connect()
    yield model, clock, server, client
    client.close()
    server.stop()


def test_read_write_registers(rig):
    model, clock, server, client = rig
    assert client.read_holding_registers(0, 3, slave=1).registers == [cm.IDENTITY, 1, 8]
    assert not client.write_register(cm.REG_SYSTEM_CONTROL, 1, slave=1).isError()
    block = cm.split_int32(-5000) + [0, 0, 0, 0, 3]
    assert not client.write_registers(cm.command_address(1, 0), block, slave=1).isError()
    clock.t += 60.0
    regs = client.read_holding_registers(cm.feedback_address(1, 0), 6, slave=1).registers
    assert cm.join_int32(regs[0], regs[1]) == -5000
    assert regs[4] == (1 << cm.SW_ENABLED) | (1 << cm.SW_IN_POSITION)


def test_coils_and_inputs(rig):
    model, clock, server, client = rig
    client.write_coil(cm.COIL_SUCTION_VALVE, True, slave=1)
    assert client.read_coils(0, 2, slave=1).bits[:2] == [True, False]
    model.set_sealed(True, clock.t)
    clock.t += 1.0
    assert client.read_discrete_inputs(0, 3, slave=1).bits[:3] == [True, False, True]


def test_illegal_address_and_read_only(rig):
    _, _, _, client = rig
    r = client.read_holding_registers(190, 20, slave=1)
    assert isinstance(r, ExceptionResponse) and r.exception_code == 2
    r = client.write_register(cm.REG_HEARTBEAT, 1, slave=1)
    assert isinstance(r, ExceptionResponse) and r.exception_code == 2


def test_injected_exception_refuses_without_acting(rig):
    model, clock, server, client = rig
    server.set_exception(6)
    r = client.write_coil(cm.COIL_SUCTION_VALVE, True, slave=1)
    assert isinstance(r, ExceptionResponse) and r.exception_code == 6
    assert not model.valve_open
    server.set_exception(0)
    assert client.read_holding_registers(0, 1, slave=1).registers == [cm.IDENTITY]


def test_injected_delay(rig):
    _, _, server, client = rig
    server.set_delay(0.3)
    t = time.monotonic()
    assert not client.read_holding_registers(0, 1, slave=1).isError()
    assert time.monotonic() - t >= 0.29
    server.set_delay(0.0)


def test_drop_and_stop_listening(rig):
    _, _, server, client = rig
    # a served request proves the server has accepted the connection (accept is asynchronous)
    assert not client.read_holding_registers(0, 1, slave=1).isError()
    assert server.connection_count() == 1
    assert server.drop_connections() == 1
    assert client.read_holding_registers(0, 1, slave=1).isError()
    client.close()
    assert client.connect()
    assert not client.read_holding_registers(0, 1, slave=1).isError()
    server.set_listening(False)
    assert client.read_holding_registers(0, 1, slave=1).isError()
    client.close()
    assert not client.connect()
    assert server.set_listening(True)
    assert client.connect()
    assert client.read_holding_registers(0, 1, slave=1).registers == [cm.IDENTITY]


def test_fault_strings(rig):
    model, clock, server, client = rig
    summary = apply_faults(parse_fault_spec('delay 50; exception 4; axis_fault left_boom 2'),
                           model, server, clock.t)
    assert 'delay 50 ms' in summary and 'exception 4' in summary
    assert (server.delay, server.exception_code) == (0.05, 4)
    assert model.axes[6].fault == 2
    apply_faults(parse_fault_spec('none; clear_axis_faults'), model, server, clock.t)
    assert (server.delay, server.exception_code, model.axes[6].fault) == (0.0, 0, 0)


@pytest.mark.parametrize('text', ['delay', 'delay -1', 'exception 300', 'axis_fault 3',
                                  'explode', 'drop now', 'axis_fault waist 0'])
def test_bad_fault_strings(text):
    with pytest.raises(ValueError):
        parse_fault_spec(text)


def test_loopback_only():
    with pytest.raises(ValueError):
        ControllerServer(None, None, host='0.0.0.0')


def test_port_taken_is_a_clear_error():
    """Another program holds the port: start() names host:port and why, and stops its thread."""
    with socket.socket() as other:
        other.bind(('127.0.0.1', 0))
        other.listen(1)
        port = other.getsockname()[1]
        with open(ROBOT_YAML) as f:
            model = ControllerModel(axes_from_robot_config(yaml.safe_load(f)))
        server = ControllerServer(model, FakeClock(), port=port)
        with pytest.raises(BindError) as err:
            server.start()
        assert isinstance(err.value, OSError)
        assert str(err.value) == ('cannot listen on 127.0.0.1:%d: the port is taken (another '
                                  'simulated controller or program is on it)' % port)
        assert not server.listening and not server._thread.is_alive()
