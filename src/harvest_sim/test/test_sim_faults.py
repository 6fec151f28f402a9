"""Fault knobs of the simulator (no ROS master): vacuum loss in the world and at the
controller's vacuum sensor, camera silence and the clock, the controller's connection drop as
motion_pkg's ModbusDriver sees it, and the halt event of the e-stop benchmark."""

import os

import numpy as np
import pytest
import yaml
from pymodbus.client import ModbusTcpClient

from sim_fixtures import GEOM

from harvest_sim import controller_map as cm
from harvest_sim import world as w
from harvest_sim.clock import ClockHolds
from harvest_sim.controller_model import ControllerModel, axes_from_robot_config
from harvest_sim.controller_server import ControllerServer
from harvest_sim.frame_timing import CameraSilence
from harvest_test_utils.net import free_port
from motion_pkg.modbus_driver import ConnectionLost, ModbusDriver
from motion_pkg.modbus_map import RegisterMap

from test_sim_world import F0, arm, make_world, suction_at

HERE = os.path.dirname(os.path.abspath(__file__))
ROBOT_YAML = os.path.join(HERE, '..', '..', 'harvest_description', 'config', 'robot.yaml')
REGISTER_MAP = os.path.join(HERE, '..', '..', 'motion_pkg', 'config', 'register_map.yaml')


def make_model():
    with open(ROBOT_YAML) as f:
        return ControllerModel(axes_from_robot_config(yaml.safe_load(f)),
                               suction_build_up=0.5, t0=0.0)


# --- vacuum loss ---------------------------------------------------------------------------

def held_and_cut_world():
    world = make_world()
    joints, rj = suction_at(F0)
    world.set_joints(joints)
    world.set_valve(True)
    f0 = world.fruits[0]
    left, _ = arm('left', f0.peduncle + [0.004, 0.0, 0.0], other=rj)
    world.set_joints(left)
    world.shear_cut()
    assert f0.state == w.HARVESTED and world.sealed
    return world, f0


def test_vacuum_loss_drops_a_harvested_fruit_and_the_sensor_reads_no_vacuum():
    world, f0 = held_and_cut_world()
    model = make_model()
    model.set_valve(True, 0.0)
    model.set_sealed(world.sealed, 0.0)
    assert model.read_discrete(cm.DI_VACUUM_OK, 1, 1.0) == [1]
    events = world.lose_vacuum()
    assert f0.state == w.DROPPED and not world.sealed, events
    assert f0.position[2] == pytest.approx(f0.radius)             # on the floor
    assert world.summary()['dropped'] == 1 and world.summary()['collected'] == 0
    model.set_sealed(world.sealed, 1.1)          # the world's suction_sealed reaches the controller
    assert model.read_discrete(cm.DI_VACUUM_OK, 1, 1.2) == [0]
    assert not model.read_holding(cm.REG_IO_STATUS, 1, 1.2)[0] & (1 << cm.IO_VACUUM_OK)
    # closing the valve now collects nothing: the fruit is gone
    world.set_valve(False)
    assert f0.state == w.DROPPED and world.summary()['collected'] == 0


def test_vacuum_loss_blocks_sealing_until_the_valve_closes():
    world = make_world()
    joints, _ = suction_at(F0)
    world.set_joints(joints)
    world.set_valve(True)
    f0 = world.fruits[0]
    assert f0.state == w.HELD
    world.lose_vacuum()
    assert f0.state == w.HANGING and not world.sealed     # uncut: it stays on its pedicel
    assert np.allclose(f0.position, F0)
    world.set_joints(joints)                              # the cup is still on it
    assert not world.sealed
    world.set_valve(False)
    world.set_valve(True)
    assert world.sealed and f0.state == w.HELD


def test_vacuum_loss_with_nothing_held_changes_nothing():
    world = make_world()
    before = world.summary()
    assert world.lose_vacuum() == ['vacuum lost: the suction held nothing']
    assert world.summary() == before


# --- camera silence ------------------------------------------------------------------------

def test_camera_silence_applies_by_name_or_all():
    hand = CameraSilence('hand')
    assert not hand.set('stereo', 5.0) and not hand.silent(1.0)
    assert hand.set('all', 5.0) and hand.silent(1.0) and not hand.silent(5.0)
    assert hand.set('hand', None) and not hand.silent(1.0)        # ended early


def test_a_silent_camera_never_holds_the_clock():
    """The clock (ClockHolds as sim_clock keeps them) is not stopped by a silenced camera: it
    runs past the silence, and after it the camera holds the clock for its frames again."""
    silence = CameraSilence('stereo')
    holds = ClockHolds(timeout=10.0)
    silence.set('stereo', 12.0)
    t = 10.0
    while t < 12.5:
        # a trigger at t would hold the clock at t until its frame is out
        until = silence.hold(t, t)
        holds.set('/sim_stereo_camera', until if until is not None else 0.0)
        if until is None:
            assert holds.blocking(t, wall_now=0.0) == []
            t += 0.25
        else:
            break
    assert t == pytest.approx(12.0, abs=1e-6)     # the first trigger the camera serves again
    assert holds.blocking(t, wall_now=0.0) == ['/sim_stereo_camera']


# --- connection drop -----------------------------------------------------------------------

class FakeClock(object):
    def __init__(self, t=10.0):
        self.t = t

    def __call__(self):
        return self.t


@pytest.fixture
def controller():
    model = make_model()
    clock = FakeClock()
    halts = []
    server = ControllerServer(model, clock, port=free_port(),
                              on_halt=lambda t, wall, what: halts.append((t, wall, what)))
    server.start()
    yield model, clock, server, halts
    server.stop()


def test_drop_connections_is_connection_lost_then_reconnects_after_the_window(controller):
    _, clock, server, _ = controller
    driver = ModbusDriver(RegisterMap.from_file(REGISTER_MAP), '127.0.0.1', server.port,
                          timeout=0.5, backoff_first=0.1, backoff_max=0.4)
    try:
        assert driver.ensure_connected(clock.t)
        driver.poll()
        assert server.drop_connections_for(2.0, clock.t) == 1
        with pytest.raises(ConnectionLost):
            driver.poll()
        assert not driver.connected
        # refused while the window lasts, whatever the back-off allows
        for dt in (0.5, 1.0, 1.9):
            clock.t = 10.0 + dt
            assert not server.end_outage(clock.t)
            assert not driver.ensure_connected(clock.t + 100.0)
        assert 'refused' in driver.last_error
        clock.t = 12.0
        assert server.end_outage(clock.t) and not server.in_outage
        assert driver.ensure_connected(clock.t + 200.0)
        assert driver.poll() is not None and driver.connects == 2
    finally:
        driver.close()


def test_drop_connections_zero_ends_the_window_and_bad_durations_are_refused(controller):
    _, clock, server, _ = controller
    server.drop_connections_for(5.0, clock.t)
    assert server.in_outage and not server.listening
    assert server.drop_connections_for(0.0, clock.t) == 0
    assert server.listening and not server.in_outage
    for bad in (-1.0, float('nan')):
        with pytest.raises(ValueError):
            server.drop_connections_for(bad, clock.t)
    server.drop_connections_for(5.0, clock.t)
    server.set_listening(True)                   # server_on / set_server_enabled end it too
    assert not server.in_outage and not server.end_outage(clock.t + 10.0)


# --- halt events (bench_estop) -------------------------------------------------------------

def test_halts_in_names_halt_all_and_the_halted_axes():
    model = make_model()
    assert model.halts_in(cm.REG_SYSTEM_CONTROL, [1 << cm.SYS_HALT_ALL]) == ['all']
    assert model.halts_in(cm.REG_SYSTEM_CONTROL, [1 << cm.SYS_ENABLE_ALL]) == []
    word = (1 << cm.CW_ENABLE) | (1 << cm.CW_HALT)
    assert model.halts_in(cm.command_address(2, cm.CMD_CONTROL_WORD), [word]) == [model.names[2]]
    block = [0] * cm.CMD_CONTROL_WORD + [(1 << cm.CW_ENABLE) | (1 << cm.CW_START)]
    assert model.halts_in(cm.command_address(1, 0), block) == []      # a move is no halt


def test_a_halt_write_is_reported_with_controller_and_wall_time(controller):
    model, clock, server, halts = controller
    client = ModbusTcpClient('127.0.0.1', port=server.port, timeout=1.0, retries=0)
    assert client.connect()
    try:
        client.write_register(cm.REG_SYSTEM_CONTROL, 1 << cm.SYS_ENABLE_ALL, slave=1)
        assert halts == []
        clock.t = 11.5
        client.write_register(cm.REG_SYSTEM_CONTROL, 1 << cm.SYS_HALT_ALL, slave=1)
        word = (1 << cm.CW_ENABLE) | (1 << cm.CW_HALT)
        client.write_register(cm.command_address(0, cm.CMD_CONTROL_WORD), word, slave=1)
    finally:
        client.close()
    assert [(t, what) for t, _, what in halts] == [(11.5, ['all']), (11.5, [model.names[0]])]
    assert halts[0][1] <= halts[1][1]
