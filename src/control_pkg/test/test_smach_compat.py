"""SMACH core on this Python through control_pkg.smach_compat (no ROS master needed)."""
import os
import subprocess
import sys
import textwrap
import threading

import pytest

from control_pkg import smach_compat
from control_pkg.smach_compat import smach
from harvest_test_utils.strict_deps import skip_optional

JOIN_TIMEOUT = 10.0


class GateState(smach.State):
    """Waits on an Event until released or preempted (no polling)."""

    def __init__(self, outcome='done'):
        smach.State.__init__(self, outcomes=[outcome, 'preempted'], output_keys=['log'])
        self.outcome = outcome
        self.started = threading.Event()
        self.gate = threading.Event()

    def execute(self, ud):
        self.started.set()
        self.gate.wait()
        if self.preempt_requested():
            self.service_preempt()
            return 'preempted'
        ud.log = self.outcome
        return self.outcome

    def request_preempt(self):
        smach.State.request_preempt(self)
        self.gate.set()


def run_in_thread(state, userdata=None):
    """Execute `state` in a thread; returns (thread, result dict)."""
    result = {}

    def target():
        try:
            result['outcome'] = state.execute(userdata if userdata is not None
                                              else smach.UserData())
        except Exception as ex:  # reported by the test, not lost in the thread
            result['error'] = ex

    thread = threading.Thread(target=target)
    thread.daemon = True
    thread.start()
    return thread, result


def finish(thread, result):
    thread.join(JOIN_TIMEOUT)
    assert not thread.is_alive(), 'state did not finish within %.0f s' % JOIN_TIMEOUT
    assert 'error' not in result, result.get('error')
    return result['outcome']


def make_concurrence(**kwargs):
    return smach.Concurrence(outcomes=['succeeded', 'aborted', 'preempted'],
                             default_outcome='aborted',
                             outcome_map={'succeeded': {'A': 'done', 'B': 'ok'},
                                          'preempted': {'A': 'preempted',
                                                        'B': 'preempted'}},
                             **kwargs)


def test_patch_is_contained_and_idempotent():
    assert smach_compat.CONCURRENCE_PATCHED
    assert smach.concurrence.threading.Event is threading.Event
    thread = smach.concurrence.threading.Thread(target=lambda: None)
    assert hasattr(thread, 'isAlive') and not thread.isAlive()
    if sys.version_info >= (3, 9):
        assert not hasattr(threading.Thread, 'isAlive'), 'the stdlib must stay untouched'
    proxy = smach.concurrence.threading
    assert smach_compat._patch_concurrence()
    assert smach.concurrence.threading is proxy


def test_importing_smach_needs_no_rospy():
    code = ('import sys, control_pkg.smach_compat as c; '
            'assert "rospy" not in sys.modules, "rospy imported"; '
            'assert "smach_ros" not in sys.modules')
    subprocess.check_call([sys.executable, '-c', code])


def test_concurrence_runs_to_completion():
    a, b = GateState('done'), GateState('ok')
    con = make_concurrence(output_keys=['log'])
    with con:
        smach.Concurrence.add('A', a)
        smach.Concurrence.add('B', b, remapping={'log': 'log_b'})
    thread, result = run_in_thread(con)
    assert a.started.wait(JOIN_TIMEOUT) and b.started.wait(JOIN_TIMEOUT)
    a.gate.set()
    b.gate.set()
    assert finish(thread, result) == 'succeeded'
    assert con.userdata.log == 'done' and con.userdata.log_b == 'ok'


def test_concurrence_quick_children_in_a_state_machine():
    sm = smach.StateMachine(outcomes=['finished', 'failed'])
    with sm:
        con = smach.Concurrence(outcomes=['ok', 'bad'], default_outcome='bad',
                                outcome_map={'ok': {'X': 'x', 'Y': 'y'}})
        with con:
            smach.Concurrence.add('X', smach.CBState(lambda ud: 'x', outcomes=['x']))
            smach.Concurrence.add('Y', smach.CBState(lambda ud: 'y', outcomes=['y']))
        smach.StateMachine.add('CON', con, transitions={'ok': 'finished', 'bad': 'failed'})
    for _ in range(3):  # re-entering a Concurrence works too
        assert finish(*run_in_thread(sm)) == 'finished'


def test_concurrence_preempted_from_another_thread():
    a, b = GateState('done'), GateState('ok')
    con = make_concurrence()
    with con:
        smach.Concurrence.add('A', a)
        smach.Concurrence.add('B', b)
    thread, result = run_in_thread(con)
    assert a.started.wait(JOIN_TIMEOUT) and b.started.wait(JOIN_TIMEOUT)
    preempter = threading.Thread(target=con.request_preempt)
    preempter.start()
    preempter.join(JOIN_TIMEOUT)
    assert finish(thread, result) == 'preempted'
    assert not con.preempt_requested(), 'the concurrence serviced the preempt'
    assert not a.preempt_requested() and not b.preempt_requested()


def test_child_termination_cb_preempts_the_rest():
    """The monitor pattern: one child ending stops the others."""
    a, b = GateState('done'), GateState('ok')
    con = smach.Concurrence(outcomes=['first_done', 'aborted'], default_outcome='aborted',
                            outcome_map={'first_done': {'A': 'done', 'B': 'preempted'}},
                            child_termination_cb=lambda outcomes: True)
    with con:
        smach.Concurrence.add('A', a)
        smach.Concurrence.add('B', b)
    thread, result = run_in_thread(con)
    assert a.started.wait(JOIN_TIMEOUT) and b.started.wait(JOIN_TIMEOUT)
    a.gate.set()
    assert finish(thread, result) == 'first_done'


def test_ros_names_are_lazy_and_known():
    with pytest.raises(AttributeError):
        getattr(smach_compat, 'NoSuchThing')
    assert 'SimpleActionState' in smach_compat.__all__
    assert isinstance(smach_compat.HAVE_SMACH_ROS, bool)


# What task_planner imports, then the layer it got (the choice is made once per process,
# so each case runs in a fresh interpreter with its own fake smach_ros on the path).
_LAYER_PROBE = (
    'import control_pkg.executive_node\n'
    'import control_pkg.smach_compat as c\n'
    'from control_pkg.smach_compat import SimpleActionState, IntrospectionServer\n'
    'print("LAYER", c.HAVE_SMACH_ROS, SimpleActionState.__module__, IntrospectionServer.__module__)\n')

_FALLBACK_LAYER = ('LAYER False control_pkg.smach_ros_compat_action '
                   'control_pkg.smach_ros_compat_introspection')
_WARNING = 'smach_ros is installed but cannot be imported'


def probe_layer(tmp_path, smach_ros_init=None):
    """Run _LAYER_PROBE with `smach_ros_init` as smach_ros/__init__.py (None: no smach_ros)."""
    env = dict(os.environ)
    if smach_ros_init is not None:
        package = tmp_path / 'smach_ros'
        package.mkdir()
        (package / '__init__.py').write_text(textwrap.dedent(smach_ros_init))
        env['PYTHONPATH'] = os.pathsep.join([str(tmp_path)] + [p for p in [env.get('PYTHONPATH')] if p])
    proc = subprocess.run([sys.executable, '-c', _LAYER_PROBE], env=env, stdout=subprocess.PIPE,
                          stderr=subprocess.PIPE, universal_newlines=True)
    assert proc.returncode == 0, proc.stderr
    layer = [line for line in proc.stdout.splitlines() if line.startswith('LAYER ')]
    return layer, proc.stderr


@pytest.mark.parametrize('smach_ros_init', [
    # smach_ros found but not on the ROS package path: roslib raises rospkg.ResourceNotFound
    'import roslib\nroslib.load_manifest("smach_ros_not_on_the_package_path")\n',
    # a dependency of smach_ros missing
    'import a_dependency_that_is_not_installed\n',
    # anything else a broken install can raise while importing
    'raise AttributeError("module smach has no attribute Iterator")\n',
], ids=['roslib_load_manifest', 'missing_dependency', 'other_error'])
def test_broken_smach_ros_falls_back_with_one_warning(tmp_path, smach_ros_init):
    layer, stderr = probe_layer(tmp_path, smach_ros_init)
    assert layer == [_FALLBACK_LAYER]
    warnings = [line for line in stderr.splitlines() if _WARNING in line]
    assert len(warnings) == 1, stderr
    assert 'control_pkg.smach_ros_compat' in warnings[0]


def test_working_smach_ros_is_used(tmp_path):
    layer, stderr = probe_layer(tmp_path, '''
        class SimpleActionState(object):
            pass
        class IntrospectionServer(object):
            pass
        ''')
    assert layer == ['LAYER True smach_ros smach_ros']
    assert _WARNING not in stderr


def test_smach_info_lines_go_to_debug_with_either_layer(tmp_path):
    """SMACH's per-transition info lines are rospy DEBUG (they cost the executive ~0.5 ms
    each); its warnings and errors stay warnings and errors."""
    probe = ('import rospy, smach\n'
             'import control_pkg.smach_compat as c\n'
             'c.SimpleActionState\n'
             'print("LOGGERS", smach.loginfo is rospy.logdebug, smach.logwarn is rospy.logwarn, '
             'smach.logerr is rospy.logerr)\n')
    for smach_ros_init in (None, 'import rospy, smach\n'
                                 'smach.set_loggers(rospy.loginfo, rospy.logwarn, '
                                 'rospy.logdebug, rospy.logerr)\n'
                                 'class SimpleActionState(object):\n    pass\n'
                                 'class IntrospectionServer(object):\n    pass\n'):
        env = dict(os.environ)
        if smach_ros_init is not None:
            package = tmp_path / 'smach_ros'
            package.mkdir()
            (package / '__init__.py').write_text(smach_ros_init)
            env['PYTHONPATH'] = os.pathsep.join([str(tmp_path)] + [p for p in [env.get('PYTHONPATH')] if p])
        proc = subprocess.run([sys.executable, '-c', probe], env=env, stdout=subprocess.PIPE,
                              stderr=subprocess.PIPE, universal_newlines=True)
        assert proc.returncode == 0, proc.stderr
        assert 'LOGGERS True True True' in proc.stdout, (smach_ros_init, proc.stdout)


def test_no_smach_ros_falls_back_quietly(tmp_path):
    if subprocess.call([sys.executable, '-c', 'import smach_ros'], stderr=subprocess.DEVNULL) == 0:
        skip_optional('smach_ros is installed here')   # not by tools/setup.sh: Debian has none
    layer, stderr = probe_layer(tmp_path)
    assert layer == [_FALLBACK_LAYER]
    assert 'smach_ros' not in stderr
