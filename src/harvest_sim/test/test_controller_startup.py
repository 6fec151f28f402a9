"""A simulated controller that cannot listen ends the launch with one clear fatal line.

Runs `roslaunch harvest_sim sim_robot.launch` (clock, world and controller; no cameras) on a
private master while another socket holds the controller's port: the controller must exit 1
with `[FATAL] ... cannot listen on 127.0.0.1:PORT`, and the launch must end (the node is
required) instead of running on without it. Needs the built workspace (devel/setup.bash).
"""

import os
import shutil
import socket
import subprocess
import sys

import pytest

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(HERE, '..', 'src'))

from harvest_test_utils.net import free_port  # noqa: E402

LAUNCH_TIMEOUT = 60.0       # wall seconds: a safety net only (the launch ends in a few seconds)


def harvest_sim_built():
    if shutil.which('roslaunch') is None:
        return False
    try:
        import rospkg
        rospkg.RosPack().get_path('harvest_sim')
    except Exception:        # rospkg missing or the workspace not sourced
        return False
    return True


@pytest.mark.skipif(not harvest_sim_built(), reason='needs roslaunch and the sourced workspace')
def test_port_taken_ends_the_launch(tmp_path):
    with socket.socket() as other:              # "another simulation's controller"
        other.bind(('127.0.0.1', 0))
        other.listen(1)
        port = other.getsockname()[1]
        master = free_port()
        env = dict(os.environ, ROS_MASTER_URI='http://127.0.0.1:%d' % master,
                   ROS_HOSTNAME='localhost', ROS_HOME=str(tmp_path))
        run = subprocess.run(
            ['roslaunch', '-p', str(master), 'harvest_sim', 'sim_robot.launch',
             'modbus_port:=%d' % port, 'cameras:=false', 'stereo_proc:=false',
             'state_publisher:=false'],
            env=env, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, universal_newlines=True,
            timeout=LAUNCH_TIMEOUT)
    out = run.stdout
    fatal = [line for line in out.splitlines() if '[FATAL]' in line]
    assert len(fatal) == 1, out
    assert 'cannot listen on 127.0.0.1:%d: the port is taken' % port in fatal[0]
    assert 'REQUIRED process [sim/sim_controller' in out, out
    assert 'exit code 1' in out, out
