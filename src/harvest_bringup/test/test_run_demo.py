"""tools/run_demo.py (`make demo`) when the launch ends early: the reason is reported, not a
traceback of the clean-up."""

import signal
import subprocess
import sys

import pytest

from harvest_test_utils.tools import load_tool


@pytest.fixture(scope='module')
def run_demo():
    return load_tool('run_demo')


def test_stop_launch_after_the_launch_ended(run_demo):
    """A required node died and roslaunch ended with its whole process group: nothing to stop."""
    launch = subprocess.Popen([sys.executable, '-c', 'pass'], start_new_session=True)
    launch.wait()
    run_demo.stop_launch(launch)                       # raised ProcessLookupError before
    assert launch.returncode == 0


def test_stop_launch_interrupts_a_running_launch(run_demo):
    # SIGINT's default action restored: make test's lanes run in the background of a shell,
    # which starts its children with SIGINT ignored, and the child then waited out the 30 s
    # grace for its SIGKILL (roslaunch installs its own SIGINT handler). It says when its
    # handler is in place: a SIGINT before that would be ignored
    launch = subprocess.Popen([sys.executable, '-c', 'import signal, time; '
                               'signal.signal(signal.SIGINT, signal.default_int_handler); '
                               'print("ready", flush=True); time.sleep(60)'],
                              start_new_session=True, stdout=subprocess.PIPE)
    assert launch.stdout.readline().strip() == b'ready'
    run_demo.stop_launch(launch)
    launch.stdout.close()
    assert launch.returncode is not None and launch.returncode != 0
    assert launch.returncode != -signal.SIGKILL, 'the SIGINT did not end it: killed after the grace'


def test_fatal_lines(run_demo, tmp_path):
    log = tmp_path / 'demo.log'
    log.write_text('process[sim/sim_controller-4]: started with pid [1]\n'
                   '[FATAL] [1.0, 2.0]: cannot listen on 127.0.0.1:5020: the port is taken\n'
                   'REQUIRED process [sim/sim_controller-4] has died!\n')
    assert run_demo.fatal_lines(str(log)) == [
        '[FATAL] [1.0, 2.0]: cannot listen on 127.0.0.1:5020: the port is taken']
    assert run_demo.fatal_lines(str(tmp_path / 'missing.log')) == []


def test_ground_truth_waits_for_the_fruit_on_the_suction_sleeve():
    # the summary can arrive before the world lets the last fruit go into the box: the fruit
    # still held (or cut and not let go) are what the ground truth must wait for
    # (harvest_sim.truth, used by run_demo and bench_sim; here, where the tools' tests are)
    from harvest_sim.msg import SimFruit
    from harvest_sim.truth import fruit_in_hand
    fruits = [SimFruit(id='a', state=SimFruit.COLLECTED), SimFruit(id='b', state=SimFruit.HARVESTED),
              SimFruit(id='c', state=SimFruit.HELD), SimFruit(id='d', state=SimFruit.HANGING)]
    assert fruit_in_hand(fruits) == ['b', 'c']
    assert fruit_in_hand(fruits[:1] + fruits[3:]) == []


def test_a_fruit_cut_and_still_on_the_sleeve_counts_as_harvested():
    from harvest_sim.srv import GetSimSummaryResponse
    from harvest_sim.truth import ground_truth_counts
    summary = GetSimSummaryResponse(ripe_reachable=6, collected=5, harvested=1, dropped=1,
                                    damaged=1)
    assert ground_truth_counts(summary) == (6, 6, 2)
