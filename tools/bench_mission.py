"""Benchmark of the paper's configuration: mean picking time per fruit, in simulated seconds.

Sequential flow of the executive, visual servo with the paper's integration step (dt = 1 s),
scenarios with at most three targets in view. Prints one line per scenario and the overall
figure beside the paper's "< 35 s" (Liu, Gong and Zhang: average picking time under 35 s when
no more than three targets are in view).

  python tools/bench_mission.py [--scenario three_targets --scenario default ...]
"""
import argparse
import math
import sys

import run_demo

DEFAULT_SCENARIOS = ['three_targets', 'default']


def main():
    parser = argparse.ArgumentParser(description=__doc__.split('\n')[0])
    parser.add_argument('--scenario', action='append', help='scenario names (repeatable)')
    parser.add_argument('--time-scale', type=float, default=2.0)
    parser.add_argument('--timeout', type=float, default=900.0, help='wall seconds per mission')
    args = parser.parse_args()
    cycles = []
    print('%-16s %8s %8s %8s %10s %14s' % ('scenario', 'picked', 'ripe+r', 'damaged', 'wall [s]', 'cycle [s/fruit]'))
    for name in args.scenario or DEFAULT_SCENARIOS:
        try:
            run = run_demo.run_mission(name, args.time_scale, args.timeout, 'bench_%s.log' % name)
        except RuntimeError as exc:
            print('%-16s failed: %s' % (name, exc))
            continue
        s, t = run['summary'], run['truth']
        rr, harvested, damaged = run_demo.ground_truth_counts(t)
        print('%-16s %8d %8d %8d %10.0f %14.1f' % (name, harvested, rr, damaged, run['wall'],
                                                   s['mean_cycle_time']))
        if s['picked'] and not math.isnan(s['mean_cycle_time']):
            cycles += [s['mean_cycle_time']] * s['picked']
        sys.stdout.flush()
    if cycles:
        print('mean picking time %.1f s/fruit (sim) over %d fruit; paper: < 35 s with at most three targets in view'
              % (sum(cycles) / len(cycles), len(cycles)))
        return 0
    print('no fruit picked: no figure')
    return 1


if __name__ == '__main__':
    sys.exit(main())
