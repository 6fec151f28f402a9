"""Benchmark of the paper's configuration: mean picking time per fruit, in simulated seconds.

Sequential flow of the executive, visual servo with the paper's integration step (dt = 1 s),
scenarios with at most three targets in view. Prints one line per scenario and the overall
figure beside the paper's "< 35 s" (Liu, Gong and Zhang: average picking time under 35 s when
no more than three targets are in view).

  python tools/bench_mission.py [--scenario three_targets --scenario default ...]
  python tools/bench_mission.py --compare [--repeat N] [--scenario ...]
                                [--pipelined-servo-mode continuous]

--compare runs both task-planner schedules (`paper`, `pipelined`) on the same scenarios in one
run and prints, per scenario and overall, the mean s/fruit (sim) of each and their ratio
(pipelined / paper), whether the same simulated fruit ended in the box with nothing damaged,
each schedule's motion-time lower bound (per picked fruit, of the arm moves actually sent in its
cycle, the minimal trapezoidal times at robot.yaml's limits summed per arm, the larger arm's)
and its cycle's ratio to it, the pipelined bound over the paper's mean cycle (the least ratio
any schedule sending the same arm moves can reach), each schedule's mean cycle of the first
fruit picked at a picking point (the cutting hand comes from home, the suction arm from the
box) and of the others, with their ratios, and the mean time per picked fruit spent in each
state label (the states of an overlap run at the same time, so they add up to more than
the cycle).
"""
import argparse
import json
import os
import re
import subprocess
import sys
import tempfile

DEFAULT_SCENARIOS = ['three_targets', 'default']
SCHEDULES = ('paper', 'pipelined')
LINE = re.compile(r'^mission: picked (\d+) of (\d+) ripe reachable, damaged (\d+), skipped (\d+), '
                  r'mean cycle (\S+) s/fruit \(sim\), wall (\d+) s$')
#: harvest_sim's SimFruit.COLLECTED, DROPPED, DAMAGED
COLLECTED, DROPPED, DAMAGED = 3, 4, 5
PICKED = 'picked'   # a pick record's outcome (tools/run_demo.py --json)


def run_one(name, time_scale, timeout, schedule=None, json_path=None, log=None, servo_mode=None):
    """One mission through run_demo.py in its own process (rospy cannot change masters):
    the groups of its closing line, or None."""
    demo = os.path.join(os.path.dirname(os.path.abspath(__file__)), 'run_demo.py')
    cmd = [sys.executable, demo, '--scenario', name, '--time-scale', str(time_scale),
           '--timeout', str(timeout), '--log', log or 'bench_%s.log' % name]
    if schedule:
        cmd += ['--schedule', schedule]
    if json_path:
        cmd += ['--json', json_path]
    if servo_mode:
        cmd += ['--servo-mode', servo_mode]
    out = subprocess.run(cmd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                         universal_newlines=True)
    for line in out.stdout.splitlines():
        m = LINE.match(line.strip())
        if m:
            return m.groups()
    return None


# --- the comparison (pure: runs in, figures out) -------------------------------------------------
def picked_cycles(run):
    """Cycle times [s, sim] of the fruit a run's executive recorded picked."""
    return [r['cycle_time'] for r in run['records'] if r['outcome'] == PICKED]


def mean(values):
    return sum(values) / len(values) if values else None


def in_box(run):
    """Ids of the simulated fruit in the box at the end of a run."""
    return sorted(k for k, v in run['fruit_states'].items() if v == COLLECTED)


def damaged(run):
    return sorted(k for k, v in run['fruit_states'].items() if v in (DROPPED, DAMAGED))


def cycles_by_position(run, gap=0.5):
    """(first, later): cycle times [s, sim] of the picked fruit that were the first picked at
    their picking point and of the others. A visit to a point begins with the first attempt (any
    outcome) whose `picking_point` differs from the previous attempt's; in records without one,
    with an attempt whose cycle starts more than `gap` s after the previous attempt ended (at a
    point each cycle starts as the one before ends; between points the base moves and the stereo
    head looks, 3 s and more). The first fruit picked in a visit (unless an attempt that moved the
    arms failed before it) comes with the cutting hand from home, the suction arm from the
    box (control_pkg's PARK_ARMS leaves them so before the first point)."""
    first, later = [], []
    previous, new_point = None, True
    for r in sorted((r for r in run['records'] if 'end' in r), key=lambda r: r['end']):
        if previous is None:
            new_point = True
        elif 'picking_point' in r and 'picking_point' in previous:
            new_point = new_point or r['picking_point'] != previous['picking_point']
        else:
            new_point = new_point or \
                r['end'] - r['cycle_time'] > previous['end'] + gap
        previous = r
        if r['outcome'] == PICKED:
            (first if new_point else later).append(r['cycle_time'])
            new_point = False
    return first, later


def state_means(runs):
    """{state label: mean seconds per picked fruit} over the picked fruit of `runs`."""
    totals, fruit = {}, 0
    for run in runs:
        for r in run['records']:
            if r['outcome'] != PICKED:
                continue
            fruit += 1
            for name, d in zip(r['states'], r['durations']):
                totals[name] = totals.get(name, 0.0) + d
    return dict((k, v / fruit) for k, v in totals.items()) if fruit else {}


def move_duration(distance, speed, acceleration):
    """Rest-to-rest trapezoid (or triangle) time over |distance|: motion_pkg's own profile."""
    from motion_pkg.motion_goals import move_duration as profile_duration
    return profile_duration(distance, speed, acceleration)


def motion_bound(run, limits, home):
    """Mean over the picked fruit of a run of the motion-time lower bound: of the arm moves sent
    during the fruit's cycle (the executive's and the visual servo's, in order, each from where
    the previous one of its arm ended; the arms start at `home`), the minimal trapezoidal times
    at robot.yaml's limits (`limits`: {axis: (speed, acceleration)}) summed per arm, the larger
    of the two arms (a waist move counts for both): no schedule moves an arm faster."""
    pos = {'left': list(home['left']), 'right': list(home['right'])}
    waist = 0.0
    timed = []
    for mv in sorted(run.get('moves', []), key=lambda m: m['t']):
        arm, dur = mv['arm'], 0.0
        if mv['positions']:
            for j, (a, b) in enumerate(zip(pos[arm], mv['positions'][:3])):
                speed, acc = limits['%s_%s' % (arm, ('lift', 'boom', 'forearm')[j])]
                dur = max(dur, move_duration(b - a, speed, acc))
            pos[arm] = list(mv['positions'][:3])
        turned = mv.get('waist') is not None
        if turned:
            dur = max(dur, move_duration(mv['waist'] - waist, *limits['waist']))
            waist = mv['waist']
        timed.append((mv['t'], arm, dur, turned))
    bounds = []
    for r in run['records']:
        if r['outcome'] != PICKED or 'end' not in r:
            continue
        start = r['end'] - r['cycle_time']
        sums = {'left': 0.0, 'right': 0.0}
        for t, arm, dur, turned in timed:
            if start <= t <= r['end']:
                for a in (('left', 'right') if turned else (arm,)):
                    sums[a] += dur
        bounds.append(max(sums.values()))
    return bounds


def robot_limits():
    """{axis: (speed, acceleration)} from harvest_description's robot.yaml, the arms' home joints
    from control_pkg's executive.yaml."""
    import rospkg
    import yaml
    pack = rospkg.RosPack()
    with open(os.path.join(pack.get_path('harvest_description'), 'config', 'robot.yaml')) as f:
        motion = yaml.safe_load(f)['motion']
    limits = {}
    for arm in ('left', 'right'):
        for j in ('lift', 'boom', 'forearm'):
            limits['%s_%s' % (arm, j)] = (motion['speed'][j], motion['acceleration'][j])
    limits['waist'] = (motion['speed']['waist'], motion['acceleration']['waist'])
    with open(os.path.join(pack.get_path('control_pkg'), 'config', 'executive.yaml')) as f:
        home = yaml.safe_load(f)['home']
    return limits, home


def compare(runs):
    """runs: {(scenario, schedule): [run, ...]} -> rows per scenario and the overall figures:
    {'rows': [(scenario, {schedule: mean s/fruit}, ratio, same_fruit, damaged)],
     'overall': {schedule: mean s/fruit}, 'ratio': pipelined / paper}."""
    scenarios = []
    for scenario, _ in runs:
        if scenario not in scenarios:
            scenarios.append(scenario)
    rows, cycles = [], dict((s, []) for s in SCHEDULES)
    for scenario in scenarios:
        means, boxes, broken = {}, {}, []
        for schedule in SCHEDULES:
            got = runs.get((scenario, schedule), [])
            c = [t for run in got for t in picked_cycles(run)]
            cycles[schedule] += c
            means[schedule] = mean(c)
            boxes[schedule] = set(tuple(in_box(run)) for run in got)
            broken += [d for run in got for d in damaged(run)]
        same = len(boxes['paper'] | boxes['pipelined']) == 1
        ratio = (means['pipelined'] / means['paper']
                 if means['paper'] and means['pipelined'] is not None else None)
        rows.append((scenario, means, ratio, same, sorted(set(broken))))
    overall = dict((s, mean(cycles[s])) for s in SCHEDULES)
    ratio = (overall['pipelined'] / overall['paper']
             if overall['paper'] and overall['pipelined'] is not None else None)
    return {'rows': rows, 'overall': overall, 'ratio': ratio}


def executive_overhead(runs):
    """{action: [ms]}: for every goal the executive sent right after one of its results (the
    previous event on the wire, as run_demo's recorder saw it), the wall time between the two:
    the executive's own time between two action states (result callback, transition, next goal
    callback, sending). A goal that follows another goal (the SCAN concurrence's second one) has
    no such gap and is left out."""
    out = {}
    for run in runs:
        previous = None
        for t, kind, action, gid in sorted(run.get('wire', [])):
            if kind == 'goal' and previous is not None and previous[1] == 'result':
                out.setdefault(action, []).append((t - previous[0]) * 1000.0)
            previous = (t, kind)
    return out


def percentile(values, q):
    values = sorted(values)
    if not values:
        return None
    k = (len(values) - 1) * q / 100.0
    lo = int(k)
    hi = min(lo + 1, len(values) - 1)
    return values[lo] + (values[hi] - values[lo]) * (k - lo)


def print_overhead(runs, out=sys.stdout):
    gaps = executive_overhead(runs)
    if not gaps:
        out.write('executive overhead: no sequential goals on the wire\n')
        return gaps
    out.write("executive overhead, previous state's result -> this goal [ms, wall]:\n")
    every = []
    for action in sorted(gaps):
        v = gaps[action]
        every += v
        out.write('  %-18s n %4d  median %6.1f  p95 %6.1f\n' % (
            action, len(v), percentile(v, 50), percentile(v, 95)))
    out.write('  %-18s n %4d  median %6.1f  p95 %6.1f\n' % (
        'all', len(every), percentile(every, 50), percentile(every, 95)))
    return gaps


def bound_floor(bound, paper_cycle):
    """A schedule's motion-time lower bound over the paper schedule's mean cycle (None when
    either is missing): no schedule that sends the same arm moves gets a smaller ratio to the
    paper's cycle, however it overlaps them."""
    if not bound or not paper_cycle:
        return None
    return bound / paper_cycle


def _fmt(value, spec='%.1f'):
    return 'n/a' if value is None else spec % value


def print_comparison(runs, out=sys.stdout):
    result = compare(runs)
    out.write('%-16s %12s %12s %8s %11s %s\n' % ('scenario', 'paper [s]', 'pipelined [s]',
                                                'ratio', 'same fruit', 'damaged'))
    for scenario, means, ratio, same, broken in result['rows']:
        out.write('%-16s %12s %12s %8s %11s %s\n' % (
            scenario, _fmt(means['paper']), _fmt(means['pipelined']), _fmt(ratio, '%.2f'),
            'yes' if same else 'NO', ', '.join(broken) or 'none'))
    o = result['overall']
    out.write('mean s/fruit (sim): paper %s, pipelined %s, ratio pipelined/paper %s\n' % (
        _fmt(o['paper']), _fmt(o['pipelined']), _fmt(result['ratio'], '%.2f')))
    try:
        limits, home = robot_limits()
    except Exception as exc:  # noqa: BLE001 - the bound is an extra: say why it is missing
        out.write('no motion-time lower bound: %s\n' % exc)
    else:
        bound_means = {}
        for schedule in SCHEDULES:
            picked = [r for (_, sch), rs in runs.items() if sch == schedule for r in rs]
            bounds = [b for run in picked for b in motion_bound(run, limits, home)]
            cyc = mean([t for run in picked for t in picked_cycles(run)])
            bound = bound_means[schedule] = mean(bounds)
            out.write('%-9s motion-time lower bound %s s/fruit (sim), cycle / bound %s\n' % (
                schedule, _fmt(bound, '%.2f'),
                _fmt(cyc / bound if cyc and bound else None, '%.2f')))
        floor = bound_floor(bound_means.get('pipelined'), o['paper'])
        if floor is not None:
            out.write('pipelined motion-time lower bound / paper cycle %.2f: the least ratio a '
                      'schedule sending the same arm moves can reach\n' % floor)
    by_position = {}
    for schedule in SCHEDULES:
        split = [cycles_by_position(r) for (_, sch), rs in runs.items() if sch == schedule
                 for r in rs]
        by_position[schedule] = [[t for f in split for t in f[k]] for k in (0, 1)]
    out.write("cycle by the fruit's place at its picking point [s/fruit, sim]: the first picked "
              'there (cutting hand from home) / the others\n')
    for schedule in SCHEDULES:
        out.write('  %-10s %s (%d) / %s (%d)\n' % (
            schedule, _fmt(mean(by_position[schedule][0])), len(by_position[schedule][0]),
            _fmt(mean(by_position[schedule][1])), len(by_position[schedule][1])))
    ratios = []
    for k in (0, 1):
        a, b = mean(by_position['paper'][k]), mean(by_position['pipelined'][k])
        ratios.append(b / a if a and b is not None else None)
    out.write('  %-10s %s / %s\n' % ('ratio', _fmt(ratios[0], '%.2f'), _fmt(ratios[1], '%.2f')))
    result['by_position'] = {'cycles': by_position, 'ratio': ratios}
    states = dict((s, state_means([r for (_, sch), rs in runs.items() if sch == s for r in rs]))
                  for s in SCHEDULES)
    labels = sorted(set(states['paper']) | set(states['pipelined']))
    out.write('state time per picked fruit [s, sim] (overlapping states count each):\n')
    for label in labels:
        out.write('  %-22s %8s %8s\n' % (label, _fmt(states['paper'].get(label), '%.2f'),
                                         _fmt(states['pipelined'].get(label), '%.2f')))
    return result


def run_compare(scenarios, repeat, time_scale, timeout, pipelined_servo_mode=None):
    runs = {}
    tmp = tempfile.mkdtemp(prefix='bench_mission_')
    for scenario in scenarios:
        for i in range(repeat):
            for schedule in SCHEDULES:
                path = os.path.join(tmp, '%s_%s_%d.json' % (scenario, schedule, i))
                got = run_one(scenario, time_scale, timeout, schedule, path,
                              log='bench_%s_%s.log' % (scenario, schedule),
                              servo_mode=pipelined_servo_mode if schedule == 'pipelined' else None)
                if got is None or not os.path.exists(path):
                    print('%-16s %-10s failed: see bench_%s_%s.log' % (scenario, schedule,
                                                                       scenario, schedule))
                    continue
                with open(path) as stream:
                    runs.setdefault((scenario, schedule), []).append(json.load(stream))
                picked, rr, dmg, _, cycle, wall = got
                print('%-16s %-10s picked %s of %s, damaged %s, mean cycle %s s/fruit (sim), '
                      'wall %s s' % (scenario, schedule, picked, rr, dmg, cycle, wall))
                sys.stdout.flush()
    result = print_comparison(runs)
    for schedule in SCHEDULES:
        sys.stdout.write('%s: ' % schedule)
        print_overhead([r for (_, sch), rs in runs.items() if sch == schedule for r in rs])
    return 0 if result['ratio'] is not None else 1


def main():
    parser = argparse.ArgumentParser(description=__doc__.split('\n')[0])
    parser.add_argument('--scenario', action='append', help='scenario names (repeatable)')
    parser.add_argument('--time-scale', type=float, default=20.0,
                        help="sim.launch's time scale (the clock runs at real time while nothing moves)")
    parser.add_argument('--timeout', type=float, default=900.0, help='wall seconds per mission')
    parser.add_argument('--compare', action='store_true',
                        help='both schedules (paper, pipelined) on the same scenarios')
    parser.add_argument('--repeat', type=int, default=1, help='--compare: missions per scenario '
                        'and schedule')
    parser.add_argument('--pipelined-servo-mode', choices=('step', 'continuous'),
                        help="--compare: the visual servo's mode of the pipelined runs (default: "
                        "the paper's step, as in the paper runs)")
    args = parser.parse_args()
    if args.compare:
        if args.pipelined_servo_mode:
            print('pipelined runs with the visual servo in %s mode; paper runs in step mode'
                  % args.pipelined_servo_mode)
        return run_compare(args.scenario or DEFAULT_SCENARIOS, max(1, args.repeat),
                           args.time_scale, args.timeout, args.pipelined_servo_mode)
    weighted, fruit = 0.0, 0
    print('%-16s %8s %8s %8s %10s %16s' % ('scenario', 'picked', 'ripe+r', 'damaged', 'wall [s]', 'cycle [s/fruit]'))
    for name in args.scenario or DEFAULT_SCENARIOS:
        got = run_one(name, args.time_scale, args.timeout)
        if got is None:
            print('%-16s failed: see bench_%s.log' % (name, name))
            continue
        picked, rr, damaged_count, _, cycle, wall = got
        print('%-16s %8s %8s %8s %10s %16s' % (name, picked, rr, damaged_count, wall, cycle))
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
