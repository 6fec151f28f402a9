"""harvest_sim.instance: what keeps one simulated stack apart from another on one machine."""

import os
import random
import socket
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(HERE, '..', 'src'))

from harvest_sim import instance  # noqa: E402
from harvest_sim.controller_map import DEFAULT_SERIAL_NUMBER, parse_serial_number  # noqa: E402


def test_free_port_can_be_bound_on_loopback():
    port = instance.free_port()
    with socket.socket() as s:
        s.bind((instance.LOOPBACK, port))
        s.listen(1)


def test_run_serial_numbers_differ_from_the_default_and_pass_as_ros_parameters():
    rng = random.Random(3)
    numbers = [instance.new_serial_number(rng) for _ in range(200)]
    assert DEFAULT_SERIAL_NUMBER not in numbers
    assert all(parse_serial_number(n) == n and n < 2 ** 31 for n in numbers)
    assert len(set(numbers)) == len(numbers)


def test_sim_launch_args():
    assert instance.sim_launch_args(15099, 42) == ['controller_port:=15099',
                                                   'controller_serial:=42']
    port_arg, serial_arg = instance.sim_launch_args()
    assert port_arg.startswith('controller_port:=') and serial_arg.startswith('controller_serial:=')
    assert int(serial_arg.split(':=')[1]) != DEFAULT_SERIAL_NUMBER
