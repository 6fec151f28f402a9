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


def test_an_attempt_the_emergency_stop_cut_short_goes_on_in_the_same_record():
    # one fruit, one record (issue 14): the stop leaves the record open; the fruit of the new
    # scan (another id, 1 cm away) continues it and closes it once; the pause is not its time
    r = mission.MissionRecorder('m1', same_fruit=0.03)
    first = r.begin_fruit(0, 7, (0.5, 0.0, 0.9), 20.0)
    r.add_state('DO_KINEMATICS', 0.5)
    r.add_state('DO_MOVE_ROBOT', 3.0)
    assert r.interrupt(24.0) is first and r.current is None
    t = r.totals()
    assert (t['attempted'], t['failed'], t['interrupted']) == (0, 0, 1)
    again = r.begin_fruit(0, 3, (0.5, 0.01, 0.9), 100.0)
    assert again is first and (again.target_id, again.position) == (3, (0.5, 0.01, 0.9))
    assert again.attempts == 2
    r.add_state('DO_KINEMATICS', 0.5)
    rec = r.end_fruit(mission.OUTCOME_PICKED, 106.0)
    assert rec.state_names == ['DO_KINEMATICS', 'DO_MOVE_ROBOT', mission.STOP_STATE, 'DO_KINEMATICS']
    assert rec.state_durations == [0.5, 3.0, 0.0, 0.5]
    assert rec.cycle_time == pytest.approx(4.0 + 6.0)
    t = r.totals()
    assert (t['attempted'], t['picked'], t['failed'], t['interrupted']) == (1, 1, 0, 1)
    assert t['mean_cycle_time'] == pytest.approx(10.0)
    assert r.close_interrupted(mission.INTERRUPTED) == []


def test_an_interrupted_fruit_not_taken_again_is_closed_failed_when_its_point_is_left():
    r = mission.MissionRecorder('m1', same_fruit=0.03)
    cut = r.begin_fruit(0, 7, (0.5, 0.0, 0.9), 20.0)
    r.interrupt(23.0)
    # 5 cm away at its point, or at another point: other fruit, records of their own
    other = r.begin_fruit(0, 8, (0.5, 0.05, 0.9), 50.0)
    r.end_fruit(mission.OUTCOME_PICKED, 55.0)
    elsewhere = r.begin_fruit(1, 7, (0.5, 0.0, 0.9), 60.0)
    r.end_fruit(mission.OUTCOME_PICKED, 66.0)
    assert cut not in (other, elsewhere) and other is not elsewhere
    assert r.close_interrupted('left', keep_point=0) == []       # still at its point
    closed = r.close_interrupted('left', keep_point=1)
    assert closed == [cut] and (cut.outcome, cut.reason) == (mission.OUTCOME_FAILED, 'left')
    assert cut.cycle_time == pytest.approx(3.0)                   # the attempt, not the pause
    assert r.interrupted == []
    t = r.totals()
    assert (t['attempted'], t['picked'], t['failed'], t['interrupted']) == (3, 2, 1, 1)


def test_the_nearest_interrupted_record_is_continued_and_a_mission_without_stop_has_no_count():
    r = mission.MissionRecorder('m1', same_fruit=0.03)
    a = r.begin_fruit(0, 1, (0.5, 0.0, 0.9), 0.0)
    r.interrupt(1.0)
    b = r.begin_fruit(0, 2, (0.5, 0.04, 0.9), 2.0)
    assert b is not a
    r.interrupt(3.0)
    assert r.begin_fruit(0, 9, (0.5, 0.025, 0.9), 10.0) is b     # both within 3 cm: b nearer
    r.end_fruit(mission.OUTCOME_LOST, 11.0, 'target lost')
    assert r.begin_fruit(0, 9, (0.5, 0.001, 0.9), 12.0) is a
    assert r.totals()['interrupted'] == 2
    quiet = mission.MissionRecorder('m2')
    quiet.begin_fruit(0, 1, (0.5, 0.0, 0.9), 0.0)
    quiet.end_fruit(mission.OUTCOME_PICKED, 5.0)
    assert 'interrupted' not in quiet.totals()                   # the paper's summary unchanged


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


def test_the_outcomes_are_the_pick_records_constants():
    from harvest_msgs.msg import PickRecord
    constants = [n for n in dir(PickRecord) if n.startswith('OUTCOME_')]
    assert len(mission.OUTCOMES) == len(constants)
    for name in constants:
        code = getattr(PickRecord, name)
        assert mission.OUTCOME_NAMES[code] == name[len('OUTCOME_'):].lower()
        assert mission.OUTCOME_CODES[mission.OUTCOME_NAMES[code]] == code
    assert mission.OUTCOMES == tuple(mission.OUTCOME_NAMES[c] for c in sorted(mission.OUTCOME_NAMES))
    assert mission.OUTCOME_DROPPED == mission.OUTCOME_NAMES[PickRecord.OUTCOME_DROPPED]


def test_the_totals_count_every_outcome_in_code_order():
    r = mission.MissionRecorder('m1')
    for i, outcome in enumerate(mission.OUTCOMES):
        r.begin_fruit(0, i, (0.5, 0.0, 0.9), float(i))
        r.end_fruit(outcome, i + 0.5, '' if outcome == mission.OUTCOME_PICKED else 'why')
    keys = list(r.totals())
    counted = [k for k in keys if k in mission.OUTCOMES]
    assert counted == list(mission.OUTCOMES)
    assert keys.index(counted[0]) == keys.index('attempted') + 1       # the summary's order
    assert all(r.totals()[o] == 1 for o in mission.OUTCOMES)
