"""Mission bookkeeping: picking-point progress across an emergency stop, the record, the summary line."""
import math

import pytest

from control_pkg import mission


def test_progress_visits_points_in_order_then_ends():
    p = mission.Progress([0, 2, 5])
    assert [p.advance(), p.advance(), p.advance(), p.advance()] == [0, 2, 5, None]


def test_progress_revisits_interrupted_point_after_resume():
    p = mission.Progress([0, 1])
    assert p.advance() == 0
    p.mark_interrupted()
    assert p.advance() == 0          # re-scan the interrupted point
    assert p.advance() == 1
    assert p.advance() is None


def test_progress_loader_is_called_lazily_and_validated():
    calls = []
    p = mission.Progress(loader=lambda: calls.append(1) or [3, 4])
    assert calls == []
    assert p.advance() == 3 and calls == [1]
    bad = mission.Progress(loader=lambda: [1, -2])
    with pytest.raises(ValueError, match='non-negative'):
        bad.advance()
    with pytest.raises(ValueError):
        mission.Progress()


def test_recorder_accounts_states_to_the_open_fruit():
    r = mission.MissionRecorder('m1')
    r.start(10.0)
    r.add_state('DO_MOVEBASE', 3.0)            # no fruit open: not a fruit's time
    r.begin_fruit(0, 7, (0.5, 0.0, 0.9), 20.0)
    r.add_state('DO_KINEMATICS', 0.5)
    r.add_state('DO_MOVE_ROBOT', 4.0)
    rec = r.end_fruit(mission.OUTCOME_PICKED, 31.0)
    assert rec.state_names == ['DO_KINEMATICS', 'DO_MOVE_ROBOT']
    assert rec.state_durations == [0.5, 4.0]
    assert rec.cycle_time == pytest.approx(11.0)
    r.begin_fruit(0, 8, (0.5, 0.1, 0.9), 31.0)
    r.end_fruit(mission.OUTCOME_UNREACHABLE, 31.5, 'beyond reach')
    r.finish(40.0)
    t = r.totals()
    assert (t['picked'], t['unreachable'], t['attempted']) == (1, 1, 2)
    assert t['mean_cycle_time'] == pytest.approx(11.0)
    assert t['duration'] == pytest.approx(30.0)
    assert r.end_fruit(mission.OUTCOME_LOST, 50.0) is None   # nothing open


def test_recorder_rejects_bad_input():
    r = mission.MissionRecorder('m1')
    with pytest.raises(ValueError):
        r.add_state('X', float('nan'))
    r.begin_fruit(0, 1, (0, 0, 0), 0.0)
    with pytest.raises(ValueError, match='unknown fruit outcome'):
        r.end_fruit('eaten', 1.0)


def test_summary_line_format():
    line = mission.summary_line(3, 3, 0, 1, 28.44, 61.2)
    assert line == ('mission: picked 3 of 3 ripe reachable, damaged 0, skipped 1, '
                    'mean cycle 28.4 s/fruit (sim), wall 61 s')
    assert 'mean cycle n/a' in mission.summary_line(0, 0, 0, 0, float('nan'), 1.0)
    assert math.isnan(mission.MissionRecorder('x').mean_cycle_time())


def test_pull_is_the_first_candidate_clear_of_other_fruit():
    from control_pkg.mission import choose_pull
    held = ((0.5, 0.0, 0.9), 0.035)
    candidates = [(-0.08, 0.0, 0.0), (-0.06, 0.0, -0.05), (-0.04, 0.0, 0.0)]
    assert choose_pull(held[0], held[1], [], candidates) == candidates[0]
    # a fruit hanging in front of and above the held one: the straight pull would close the
    # shear inside it; pulling down and out leaves the cut point clear
    front = ((0.42, 0.0, 0.97), 0.03)
    assert choose_pull(held[0], held[1], [front], candidates) == candidates[1]
    # a fruit where every pull ends
    blocking = ((0.44, 0.0, 0.88), 0.035)
    assert choose_pull(held[0], held[1], [blocking], candidates) is None
    # a neighbour touching the held fruit does not block a pull away from it, and one passed
    # on the way (fruit of a truss give way) does not either
    beside = ((0.5, 0.075, 0.9), 0.035)
    assert choose_pull(held[0], held[1], [beside], candidates) == candidates[0]
    passed = ((0.46, 0.065, 0.9), 0.03)
    assert choose_pull(held[0], held[1], [passed], candidates) == candidates[0]
    assert choose_pull(held[0], held[1], [front], []) is None
