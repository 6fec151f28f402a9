"""tools/bench_mission.py --compare: the figures it prints from the runs of both schedules."""

import io

import pytest

from harvest_test_utils.tools import load_tool


@pytest.fixture(scope='module')
def bench():
    return load_tool('bench_mission')


def run(cycles, box, broken=(), moves=(), ends=None):
    records = [{'outcome': 'picked', 'cycle_time': c, 'states': ['DO_MOVE_ROBOT'],
                'durations': [c / 2.0], 'end': (ends or [10.0 * (i + 1) for i in range(len(cycles))])[i]}
               for i, c in enumerate(cycles)]
    records.append({'outcome': 'unreachable', 'cycle_time': 99.0, 'states': [], 'durations': []})
    states = dict((k, 3) for k in box)                  # COLLECTED
    states.update((k, 5) for k in broken)               # DAMAGED
    states['green'] = 0
    return {'records': records, 'fruit_states': states, 'moves': list(moves)}


def test_compare_gives_each_schedules_mean_and_their_ratio(bench):
    runs = {('a', 'paper'): [run([10.0, 20.0], ['f1', 'f2'])],
            ('a', 'pipelined'): [run([6.0, 9.0], ['f1', 'f2'])],
            ('b', 'paper'): [run([12.0], ['g1'])],
            ('b', 'pipelined'): [run([6.0], ['g2'], broken=['g1'])]}
    got = bench.compare(runs)
    (a, a_means, a_ratio, a_same, a_broken), (b, _, b_ratio, b_same, b_broken) = got['rows']
    assert (a, a_means, a_ratio, a_same, a_broken) == (
        'a', {'paper': 15.0, 'pipelined': 7.5}, 0.5, True, [])
    assert (b, b_ratio, b_same, b_broken) == ('b', 0.5, False, ['g1'])
    assert got['overall'] == {'paper': 14.0, 'pipelined': 7.0}       # per fruit, not per run
    assert got['ratio'] == 0.5


def test_a_schedule_that_picked_nothing_has_no_ratio(bench):
    got = bench.compare({('a', 'paper'): [run([10.0], ['f1'])], ('a', 'pipelined'): [run([], [])]})
    assert got['rows'][0][2] is None and got['ratio'] is None
    out = io.StringIO()
    bench.print_comparison({('a', 'paper'): [run([10.0], ['f1'])]}, out)
    assert 'ratio pipelined/paper n/a' in out.getvalue()


def test_the_motion_bound_is_the_busier_arms_minimal_move_time(bench):
    limits = {'waist': (1.0, 1e9)}
    for arm in ('left', 'right'):
        for j in ('lift', 'boom', 'forearm'):
            limits['%s_%s' % (arm, j)] = (1.0, 1e9)         # ~instant acceleration: time = distance
    home = {'left': [0.0, 0.0, 0.0], 'right': [0.0, 0.0, 0.0]}
    moves = [{'t': 1.0, 'arm': 'right', 'positions': [0.0, 2.0, 0.0], 'waist': None},
             {'t': 2.0, 'arm': 'left', 'positions': [0.0, 1.0, 0.5], 'waist': None},
             {'t': 3.0, 'arm': 'right', 'positions': [0.0, 1.0, 0.0], 'waist': None},
             {'t': 12.0, 'arm': 'left', 'positions': [], 'waist': 0.5},   # the waist: both arms
             {'t': 13.0, 'arm': 'left', 'positions': [0.0, 1.0, 0.0], 'waist': None}]
    bounds = bench.motion_bound(run([8.0, 5.0], ['f1', 'f2'], moves=moves, ends=[9.0, 14.0]),
                                limits, home)
    assert bounds == [pytest.approx(3.0), pytest.approx(1.0)]


def test_the_bound_floor_is_the_least_ratio_to_the_paper_cycle(bench):
    # 8.1 s of arm moves per fruit against a 14.6 s paper cycle: no overlap of those moves
    # gets below 0.555 of the paper's cycle
    assert bench.bound_floor(8.1, 14.6) == pytest.approx(8.1 / 14.6)
    assert bench.bound_floor(None, 14.6) is None
    assert bench.bound_floor(8.1, None) is None


def test_executive_overhead_counts_goals_that_follow_a_result(bench):
    e = '/task_planner-'
    wire = [(1.000, 'goal', 'kinematics', e + '1'), (1.010, 'result', 'kinematics', e + '1'),
            (1.013, 'goal', 'move_robot', e + '2'),           # 3 ms after the result
            (2.000, 'result', 'move_robot', e + '2'),
            (2.002, 'goal', 'tomato_scan', e + '3'),          # 2 ms; SCAN: two goals at once
            (2.003, 'goal', 'spatial_temporal', e + '4'),     # follows a goal: left out
            (2.500, 'result', 'spatial_temporal', e + '4'),
            (2.600, 'result', 'tomato_scan', e + '3'),
            (2.605, 'goal', 'kinematics', e + '5')]           # 5 ms after the last result
    gaps = bench.executive_overhead([{'wire': wire}])
    assert sorted(gaps) == ['kinematics', 'move_robot', 'tomato_scan']
    assert gaps['move_robot'] == [pytest.approx(3.0)]
    assert gaps['tomato_scan'] == [pytest.approx(2.0)]
    assert gaps['kinematics'] == [pytest.approx(5.0)]
    out = io.StringIO()
    bench.print_overhead([{'wire': wire}], out)
    assert 'all' in out.getvalue() and 'median' in out.getvalue()
    assert bench.percentile([1.0, 2.0, 3.0, 4.0], 50) == pytest.approx(2.5)


def _attempt(outcome, start, end):
    return {'outcome': outcome, 'cycle_time': end - start, 'end': end, 'states': [],
            'durations': []}


def test_cycles_are_split_by_the_fruits_place_at_its_picking_point(bench):
    records = [_attempt('picked', 5.0, 16.0),           # point 1: first (arms from home)
               _attempt('picked', 16.0, 23.0),          # ... the next starts where it ended
               _attempt('unreachable', 23.0, 23.5),     # a skipped target: still point 1
               _attempt('picked', 23.5, 30.0),
               _attempt('unreachable', 34.0, 34.2),     # point 2: a gap (the base moved) ...
               _attempt('picked', 34.2, 44.0),          # ... its first picked fruit
               _attempt('picked', 50.0, 61.0)]          # point 3
    got = bench.cycles_by_position({'records': records[::-1]})    # any order
    assert got == ([11.0, pytest.approx(9.8), 11.0], [7.0, 6.5])


def test_the_comparison_prints_the_first_and_the_later_fruits_ratios(bench):
    def point_run(cycles_per_point):
        records, t = [], 0.0
        for cycles in cycles_per_point:
            t += 3.0                                    # the base moves between points
            for c in cycles:
                records.append(_attempt('picked', t, t + c))
                t += c
        return {'records': records, 'fruit_states': {'f': 3}, 'moves': []}
    runs = {('a', 'paper'): [point_run([[14.0, 14.0], [16.0]])],
            ('a', 'pipelined'): [point_run([[10.0, 7.0], [11.0]])]}
    out = io.StringIO()
    got = bench.print_comparison(runs, out)
    assert got['by_position']['cycles'] == {'paper': [[14.0, 16.0], [14.0]],
                                            'pipelined': [[10.0, 11.0], [7.0]]}
    first, later = got['by_position']['ratio']
    assert first == pytest.approx(0.7) and later == pytest.approx(0.5)
    assert '  pipelined  10.5 (2) / 7.0 (1)' in out.getvalue()
    assert '  ratio      0.70 / 0.50' in out.getvalue()


def test_records_with_their_picking_point_are_split_by_it(bench):
    def at(point, outcome, start, end):
        r = _attempt(outcome, start, end)
        r['picking_point'] = point
        return r
    # a cycle may start a little after the previous one ended (20 ms here): the point decides
    records = [at(3, 'picked', 5.0, 16.0), at(3, 'picked', 16.02, 23.0),
               at(3, 'picked', 23.02, 30.0), at(4, 'unreachable', 30.5, 30.6),
               at(4, 'picked', 30.6, 41.0), at(5, 'picked', 41.2, 50.0)]
    assert bench.cycles_by_position({'records': records}) == \
        ([11.0, pytest.approx(10.4), pytest.approx(8.8)],
         [pytest.approx(6.98), pytest.approx(6.98)])
