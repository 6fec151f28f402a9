"""tools/load_check.py (`make load-check`): its verdict from run_demo's output, and the run again
without the CPU hogs of a scenario that failed beside them."""

import pytest

from harvest_test_utils.tools import load_tool

PASSED = '''[demo] mission demo-default ended succeeded after 3 picking points; executive record: picked 6, unreachable 0, lost 0, failed 0
[demo] ground truth (default): 14 fruit, 8 ripe, 6 ripe reachable; collected 6 (ripe 6, unripe 0), dropped 0, damaged 0
speed: 110 s simulated in 26.9 s wall = 4.1x real time
mission: picked 6 of 6 ripe reachable, damaged 0, skipped 2, mean cycle 14.5 s/fruit (sim), wall 37 s
'''
DAMAGED = PASSED.replace('collected 6 (ripe 6, unripe 0), dropped 0, damaged 0',
                         'collected 5 (ripe 5, unripe 0), dropped 0, damaged 1')


@pytest.fixture()
def load_check():
    return load_tool('load_check')


def test_a_clean_mission_passes_and_a_damaged_fruit_fails(load_check):
    ok, line = load_check.check(PASSED)
    assert ok and line.startswith('PASS - succeeded, picked 6 of 6 ripe reachable')
    assert 'cycle 14.5 s/fruit (sim), speed 4.1x (110 s sim in 26.9 s wall)' in line
    ok, line = load_check.check(DAMAGED)
    assert not ok
    assert line.startswith('FAIL (5 of 6 ripe reachable in the box; executive record 6, box 5; '
                           '1 damaged)')
    ok, line = load_check.check('roslaunch died\n')
    assert not ok and line == 'FAIL (no mission result: roslaunch died)'


class _Hogs(object):
    pid = 4242

    def wait(self):
        return 0


def _run(load_check, monkeypatch, capsys, argv, results):
    """main() with run_demo's missions and stress-ng replaced: `results` maps (scenario, log
    name suffix) to run_demo's output; returns (exit status, printed lines, missions run)."""
    runs = []

    def run_one(args, name, log_name):
        quiet = log_name.endswith('_quiet.log')
        runs.append((name, quiet))
        return load_check.check(results[(name, quiet)]) + (1.0,)

    started = []
    monkeypatch.setattr(load_check, 'run_one', run_one)
    monkeypatch.setattr(load_check.subprocess, 'Popen',
                        lambda cmd, **kw: started.append(cmd) or _Hogs())
    monkeypatch.setattr(load_check.os, 'killpg', lambda pid, sig: None)
    monkeypatch.setattr('sys.argv', ['load_check.py'] + argv)
    status = load_check.main()
    return status, capsys.readouterr().out.splitlines(), runs, started


def test_a_failure_beside_the_hogs_is_run_again_without_them(load_check, monkeypatch, capsys,
                                                           tmp_path):
    results = {('a', False): PASSED, ('b', False): DAMAGED, ('c', False): DAMAGED,
               ('b', True): DAMAGED, ('c', True): PASSED}
    status, out, runs, started = _run(
        load_check, monkeypatch, capsys,
        ['--scenario', 'a', '--scenario', 'b', '--scenario', 'c', '--logs', str(tmp_path)], results)
    assert status == 1                   # the runs beside the hogs decide
    assert started == [['stress-ng', '--cpu', '2', '--quiet']]
    assert runs == [('a', False), ('b', False), ('c', False), ('b', True), ('c', True)]
    assert any(line.startswith('load-check: 1 of 3 scenarios passed beside 2 CPU hogs')
               for line in out)
    b = [line for line in out if line.startswith('load-check b without load: FAIL')]
    assert len(b) == 1 and b[0].endswith('-> the same failure without the hogs: not a load effect')
    c = [line for line in out if line.startswith('load-check c without load: PASS')]
    assert len(c) == 1 and c[0].endswith('-> it failed only beside the hogs: a load effect')
    assert out[-1] == 'load-check: 1 of the 2 failures beside the hogs fail without them too'


def test_no_hogs_starts_no_stress_ng_and_runs_nothing_twice(load_check, monkeypatch, capsys,
                                                          tmp_path):
    status, out, runs, started = _run(
        load_check, monkeypatch, capsys,
        ['--hogs', '0', '--scenario', 'b', '--logs', str(tmp_path)], {('b', False): DAMAGED})
    assert status == 1 and started == [] and runs == [('b', False)]
    assert out[0].startswith('load-check: 1 scenarios, no CPU hogs')
    status, out, runs, started = _run(
        load_check, monkeypatch, capsys,
        ['--scenario', 'b', '--no-quiet-rerun', '--logs', str(tmp_path)], {('b', False): DAMAGED})
    assert status == 1 and runs == [('b', False)]



def test_the_schedule_and_the_servo_mode_reach_run_demo(load_check, monkeypatch, capsys,
                                                        tmp_path):
    commands = []

    class _Done(object):
        stdout = PASSED

    monkeypatch.setattr(load_check.subprocess, 'run',
                        lambda cmd, **kw: commands.append(cmd) or _Done())

    class Args(object):
        timeout, time_scale, depth_probe, logs = 60.0, None, None, str(tmp_path)
        schedule, servo_mode = 'pipelined', 'continuous'

    ok, line, _ = load_check.run_one(Args, 'three_targets', 'x.log')
    assert ok and line.startswith('PASS')
    cmd = commands[0]
    assert cmd[cmd.index('--schedule') + 1] == 'pipelined'
    assert cmd[cmd.index('--servo-mode') + 1] == 'continuous'
    Args.schedule = Args.servo_mode = None
    load_check.run_one(Args, 'three_targets', 'x.log')
    assert '--schedule' not in commands[1] and '--servo-mode' not in commands[1]
    # and the first line says which schedule and mode the verdicts are for
    status, out, runs, _ = _run(
        load_check, monkeypatch, capsys,
        ['--hogs', '0', '--scenario', 'a', '--schedule', 'pipelined', '--servo-mode',
         'continuous', '--logs', str(tmp_path)], {('a', False): PASSED})
    assert status == 0 and runs == [('a', False)]
    assert out[0].endswith('; schedule pipelined, visual servo continuous')
