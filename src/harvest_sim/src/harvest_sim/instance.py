"""What keeps one simulated stack apart from another on the same machine (no ROS).

The tools that start a simulator (tools/run_demo.py and, through it, `make demo`,
tools/load_check.py and tools/bench_mission.py; harvest_sim.bench; visualization_pkg's
doc_screenshots.py) give every run a private ROS master port, a free loopback port for the
simulated Modbus controller (sim.launch `controller_port`) and a serial number of its own
(sim.launch `controller_serial`: the simulated controller reports it and the robot's driver
refuses any other controller), so two stacks can run side by side.

A port found free can still be taken by someone else before the simulated controller binds it;
the controller then exits fatally and the launch ends (sim_robot.launch marks it required), and
the serial number keeps the robot stack from driving the other run's controller meanwhile.
"""

import random
import socket

LOOPBACK = '127.0.0.1'
#: serial numbers given to runs: 1 is the default one (sim.launch, the rostests), and values
#: stay within XML-RPC's signed 32-bit integers so they pass as plain ROS parameters
RUN_SERIAL_RANGE = (2, 2 ** 31 - 1)


def free_port(host=LOOPBACK):
    """A TCP port that nothing listens on at host now (the kernel's choice)."""
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as s:
        s.bind((host, 0))
        return s.getsockname()[1]


def new_serial_number(rng=None):
    """A serial number for one run's simulated controller, unlike the default one."""
    return (rng or random.SystemRandom()).randint(*RUN_SERIAL_RANGE)


def sim_launch_args(controller_port=None, controller_serial=None):
    """sim.launch arguments for a run of its own: ['controller_port:=P', 'controller_serial:=S'],
    with a free port and a new serial number for what is not given."""
    port = free_port() if controller_port is None else int(controller_port)
    serial = new_serial_number() if controller_serial is None else int(controller_serial)
    return ['controller_port:=%d' % port, 'controller_serial:=%d' % serial]
