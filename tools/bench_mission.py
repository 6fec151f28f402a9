"""Benchmark of the paper's configuration: mean picking time per fruit, in simulated seconds.

Sequential flow of the executive, visual servo with the paper's integration step (dt = 1 s),
scenarios with at most three targets in view. Prints one line per scenario and the overall
figure beside the paper's "< 35 s" (Liu, Gong and Zhang: average picking time under 35 s when
no more than three targets are in view).

  python tools/bench_mission.py [--scenario three_targets --scenario default ...]
"""
import argparse
import os
import re
import subprocess
import sys

DEFAULT_SCENARIOS = ['three_targets', 'default']
LINE = re.compile(r'^mission: picked (\d+) of (\d+) ripe reachable, damaged (\d+), skipped (\d+), '
                  r'mean cycle (\S+) s/fruit \(sim\), wall (\d+) s$')


def run_one(name, time_scale, timeout):
    """One mission through run_demo.py in its own process (rospy cannot change masters)."""
    demo = os.path.join(os.path.dirname(os.path.abspath(__file__)), 'run_demo.py')
    out = subprocess.run([sys.executable, demo, '--scenario', name, '--time-scale', str(time_scale),
                          '--timeout', str(timeout), '--log', 'bench_%s.log' % name],
                         stdout=subprocess.PIPE, stderr=subprocess.STDOUT, universal_newlines=True)
    for line in out.stdout.splitlines():
        m = LINE.match(line.strip())
        if m:
            return m.groups()
    return None


def main():
    parser = argparse.ArgumentParser(description=__doc__.split('\n')[0])
    parser.add_argument('--scenario', action='append', help='scenario names (repeatable)')
    parser.add_argument('--time-scale', type=float, default=20.0,
                        help="sim.launch's time scale (the clock runs at real time while nothing moves)")
    parser.add_argument('--timeout', type=float, default=900.0, help='wall seconds per mission')
    args = parser.parse_args()
    weighted, fruit = 0.0, 0
    print('%-16s %8s %8s %8s %10s %16s' % ('scenario', 'picked', 'ripe+r', 'damaged', 'wall [s]', 'cycle [s/fruit]'))
    for name in args.scenario or DEFAULT_SCENARIOS:
        got = run_one(name, args.time_scale, args.timeout)
        if got is None:
            print('%-16s failed: see bench_%s.log' % (name, name))
            continue
        picked, rr, damaged, _, cycle, wall = got
        print('%-16s %8s %8s %8s %10s %16s' % (name, picked, rr, damaged, wall, cycle))
        if cycle != 'n/a' and int(picked):
            weighted += float(cycle) * int(picked)
            fruit += int(picked)
        sys.stdout.flush()
    if fruit:
        print('mean picking time %.1f s/fruit (sim) over %d fruit; paper: < 35 s with at most three targets in view'
              % (weighted / fruit, fruit))
        return 0
    print('no fruit picked: no figure')
    return 1


if __name__ == '__main__':
    sys.exit(main())
