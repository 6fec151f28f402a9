"""Debian's mbpoll (a third-party Modbus TCP master) reads and writes the simulated controller."""

import os
import re
import shutil
import subprocess
import sys
import time

import pytest
import yaml

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(HERE, '..', 'src'))

from harvest_sim import controller_map as cm  # noqa: E402
from harvest_sim.controller_model import ControllerModel, axes_from_robot_config  # noqa: E402
from harvest_sim.controller_server import ControllerServer  # noqa: E402
from harvest_test_utils.net import free_port  # noqa: E402

ROBOT_YAML = os.path.join(HERE, '..', '..', 'harvest_description', 'config', 'robot.yaml')
MBPOLL = shutil.which('mbpoll')
pytestmark = pytest.mark.skipif(MBPOLL is None, reason='mbpoll not installed (apt: mbpoll)')


@pytest.fixture(scope='module')
def controller():
    with open(ROBOT_YAML) as f:
        model = ControllerModel(axes_from_robot_config(yaml.safe_load(f)))
    port = free_port()
    start = time.monotonic()
    server = ControllerServer(model, lambda: time.monotonic() - start, port=port)
    server.start()
    yield model, port
    server.stop()


def mbpoll(port, *args):
    cmd = [MBPOLL, '-m', 'tcp', '-p', str(port), '-a', '1', '-0', '-B', '-1', '-o', '2'] + \
        list(args[:-1]) + ['127.0.0.1'] + ([] if args[-1] is None else [str(v) for v in args[-1]])
    out = subprocess.run(cmd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, timeout=20,
                         universal_newlines=True)
    return out.returncode, out.stdout


def values(text):
    """{address: value} from mbpoll's '[addr]: value' lines."""
    return {int(a): int(v) for a, v in re.findall(r'\[(\d+)\]:\s*(-?\d+)', text)}


def test_mbpoll_reads_system_block(controller):
    _, port = controller
    rc, out = mbpoll(port, '-t', '4', '-r', '0', '-c', '3', None)
    assert rc == 0, out
    assert values(out) == {0: cm.IDENTITY, 1: cm.MAP_VERSION, 2: 8}


def test_mbpoll_moves_an_axis(controller):
    model, port = controller
    assert mbpoll(port, '-t', '4', '-r', str(cm.REG_SYSTEM_CONTROL), [1])[0] == 0
    target = cm.command_address(2, cm.CMD_TARGET_POSITION)
    rc, out = mbpoll(port, '-t', '4:int', '-r', str(target), [1500])
    assert rc == 0, out
    assert model.axes[2].command[:2] == cm.split_int32(1500)
    rc, out = mbpoll(port, '-t', '4', '-r', str(cm.command_address(2, cm.CMD_CONTROL_WORD)), [3])
    assert rc == 0, out
    deadline = time.monotonic() + 5.0
    while time.monotonic() < deadline:
        rc, out = mbpoll(port, '-t', '4:int', '-r', str(cm.feedback_address(2, 0)), '-c', '2',
                         None)
        if values(out) == {cm.feedback_address(2, 0): 1500, cm.feedback_address(2, 2): 0}:
            break
    assert values(out) == {cm.feedback_address(2, 0): 1500, cm.feedback_address(2, 2): 0}


def test_mbpoll_coils_and_inputs(controller):
    model, port = controller
    rc, out = mbpoll(port, '-t', '0', '-r', str(cm.COIL_SUCTION_VALVE), [1])
    assert rc == 0, out
    assert model.valve_open
    rc, out = mbpoll(port, '-t', '1', '-r', '0', '-c', '3', None)
    assert rc == 0, out
    assert values(out) == {0: 0, 1: 0, 2: 1}


def test_mbpoll_sees_exception_for_read_only_register(controller):
    _, port = controller
    rc, out = mbpoll(port, '-t', '4', '-r', str(cm.REG_HEARTBEAT), [7])
    assert rc != 0 or 'Illegal data address' in out, out
