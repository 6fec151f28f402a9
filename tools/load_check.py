"""`make load-check`: every mission scenario with CPU hogs beside it.

Starts `stress-ng --cpu N` (two hogs by default: as many as the CI machine has cores) and runs
the simulated mission of every scenario in harvest_sim/scenarios (tools/run_demo.py, one process
and one private ROS master per mission) while the hogs run. Prints one line per scenario:

  load-check SCENARIO: PASS|FAIL (reasons) - outcome, picked P of R ripe reachable, ...

PASS when the mission ends `succeeded`, every ripe reachable fruit is in the box (and the
executive's record agrees) and nothing unripe was collected, nothing dropped or damaged: the
whole-mission rostests' checks, from the simulator's ground truth. Exit status 0 when all pass.

A scenario that fails beside the hogs is run once more after them, on the quiet machine
(`--no-quiet-rerun` skips that), and its line says whether the failure came with the load or
is the same without it (then it is the robot's own limit in that scenario, e.g. perception,
not the load). The exit status counts only the runs beside the hogs. `--hogs 0` runs without
hogs (stress-ng itself reads `--cpu 0` as one worker per core). `--schedule pipelined` and
`--servo-mode continuous` pass on to run_demo.py: the same checks for the task planner's other
schedule and the visual servo's other mode.
"""
import argparse
import glob
import os
import re
import signal
import subprocess
import sys
import time

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)
SCENARIOS = os.path.join(ROOT, 'src', 'harvest_sim', 'scenarios')
TRUTH = re.compile(r'ground truth \((\S+)\): (\d+) fruit, (\d+) ripe, (\d+) ripe reachable; '
                   r'collected (\d+) \(ripe (\d+), unripe (\d+)\), dropped (\d+), damaged (\d+)')
RECORD = re.compile(r'mission \S+ ended (\S+) after (\d+) picking points; executive record: '
                    r'picked (\d+)')
SPEED = re.compile(r'^speed: (\S+) s simulated in (\S+) s wall = (\S+)x real time')
CLOSING = re.compile(r'^mission: .* mean cycle (\S+) s/fruit \(sim\), wall (\d+) s$')


def check(text):
    """(passed, line) from the output of one run_demo.py mission."""
    truth, record = TRUTH.search(text), RECORD.search(text)
    speed = closing = None
    for line in text.splitlines():
        speed = SPEED.match(line) or speed
        closing = CLOSING.match(line) or closing
    if truth is None or record is None:
        last = [l for l in text.splitlines() if l.strip()][-1:] or ['no output']
        return False, 'FAIL (no mission result: %s)' % last[0]
    _, _, _, ripe_reachable, collected, _, unripe, dropped, damaged = \
        (int(v) if v.isdigit() else v for v in truth.groups())
    outcome, _, picked = record.group(1), record.group(2), int(record.group(3))
    faults = []
    if outcome != 'succeeded':
        faults.append('outcome %s' % outcome)
    if collected - unripe != ripe_reachable:
        faults.append('%d of %d ripe reachable in the box' % (collected - unripe, ripe_reachable))
    if picked != collected:
        faults.append('executive record %d, box %d' % (picked, collected))
    for n, what in ((unripe, 'unripe collected'), (dropped, 'dropped'), (damaged, 'damaged')):
        if n:
            faults.append('%d %s' % (n, what))
    verdict = 'PASS' if not faults else 'FAIL (%s)' % '; '.join(faults)
    line = ('%s - %s, picked %d of %d ripe reachable, unripe collected %d, dropped %d, damaged '
            '%d' % (verdict, outcome, picked, ripe_reachable, unripe, dropped, damaged))
    if closing:
        line += ', cycle %s s/fruit (sim)' % closing.group(1)
    if speed:
        line += ', speed %sx (%s s sim in %s s wall)' % (speed.group(3), speed.group(1),
                                                        speed.group(2))
    return not faults, line


def main():
    parser = argparse.ArgumentParser(description=__doc__.split('\n')[0])
    parser.add_argument('--hogs', type=int, default=2, help='stress-ng CPU workers')
    parser.add_argument('--scenario', action='append', help='scenario names (default: all)')
    parser.add_argument('--time-scale', type=float, default=None,
                        help="sim.launch's time_scale (default: run_demo's)")
    parser.add_argument('--timeout', type=float, default=600.0, help='wall seconds per mission')
    parser.add_argument('--logs', default='load_check_logs', help='directory of the launch logs')
    parser.add_argument('--depth-probe', type=float, default=None, metavar='M',
                        help="run_demo's --depth-probe (default: the visual servo's own, off)")
    parser.add_argument('--schedule', choices=('paper', 'pipelined'), default=None,
                        help="run_demo's --schedule (default: control_pkg executive.yaml's, the "
                        "paper's)")
    parser.add_argument('--servo-mode', choices=('step', 'continuous'), default=None,
                        help="run_demo's --servo-mode (default: the visual servo's own, step)")
    parser.add_argument('--no-quiet-rerun', dest='quiet_rerun', action='store_false',
                        help='do not run a failed scenario again without the hogs')
    args = parser.parse_args()
    args.logs = os.path.abspath(args.logs)
    names = args.scenario or sorted(os.path.splitext(os.path.basename(p))[0]
                                    for p in glob.glob(os.path.join(SCENARIOS, '*.yaml')))
    os.makedirs(args.logs, exist_ok=True)
    hogs = None
    if args.hogs > 0:
        hogs = subprocess.Popen(['stress-ng', '--cpu', str(args.hogs), '--quiet'],
                                stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
                                start_new_session=True)
        print('load-check: %d scenarios, each beside `stress-ng --cpu %d` (pid %d) on %d cores%s'
              % (len(names), args.hogs, hogs.pid, os.cpu_count() or 0, _options(args)))
    else:
        print('load-check: %d scenarios, no CPU hogs, on %d cores%s'
              % (len(names), os.cpu_count() or 0, _options(args)))
    sys.stdout.flush()
    failed = []
    start = time.time()
    try:
        for name in names:
            ok, line, wall = run_one(args, name, 'load_check_%s.log' % name)
            if not ok:
                failed.append(name)
            print('load-check %s: %s; %.0f s wall, load average %.1f'
                  % (name, line, wall, os.getloadavg()[0]))
            sys.stdout.flush()
    finally:
        if hogs is not None:
            os.killpg(hogs.pid, signal.SIGTERM)
            hogs.wait()
    print('load-check: %d of %d scenarios passed beside %d CPU hogs in %.0f s'
          % (len(names) - len(failed), len(names), args.hogs, time.time() - start))
    if failed and args.hogs > 0 and args.quiet_rerun:
        same = 0
        for name in failed:
            ok, line, wall = run_one(args, name, 'load_check_%s_quiet.log' % name)
            same += not ok
            print('load-check %s without load: %s; %.0f s wall -> %s'
                  % (name, line, wall, 'the same failure without the hogs: not a load effect'
                     if not ok else 'it failed only beside the hogs: a load effect'))
            sys.stdout.flush()
        print('load-check: %d of the %d failures beside the hogs fail without them too'
              % (same, len(failed)))
    return 0 if not failed else 1


def _options(args):
    """'; schedule X, visual servo Y' for the options that change the mission ('' for none)."""
    said = ['%s %s' % (what, value) for what, value in (
        ('schedule', args.schedule), ('visual servo', args.servo_mode)) if value]
    return '; ' + ', '.join(said) if said else ''


def run_one(args, name, log_name):
    """(passed, line, wall seconds) of one run_demo.py mission of scenario `name`."""
    cmd = [sys.executable, os.path.join(HERE, 'run_demo.py'), '--scenario', name,
           '--timeout', str(args.timeout), '--log', os.path.join(args.logs, log_name)]
    if args.time_scale is not None:
        cmd += ['--time-scale', str(args.time_scale)]
    if args.depth_probe is not None:
        cmd += ['--depth-probe', str(args.depth_probe)]
    if args.schedule:
        cmd += ['--schedule', args.schedule]
    if args.servo_mode:
        cmd += ['--servo-mode', args.servo_mode]
    t0 = time.time()
    out = subprocess.run(cmd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                         universal_newlines=True, cwd=args.logs)
    ok, line = check(out.stdout)
    return ok, line, time.time() - t0


if __name__ == '__main__':
    sys.exit(main())
