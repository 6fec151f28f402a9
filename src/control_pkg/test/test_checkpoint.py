"""Crash-safe continuation, the pure parts (control_pkg.checkpoint, mission.Progress.resume_at,
MissionRecorder.restore): no ROS master."""
import pytest

from control_pkg import checkpoint as ck
from control_pkg import mission as ml


class _P(object):
    def __init__(self, x, y, z):
        self.x, self.y, self.z = x, y, z


class _T(object):
    """A scan's target: only .id and .pick_point.point are read."""

    def __init__(self, tid, xyz):
        self.id = tid
        self.pick_point = type('PS', (), {})()
        self.pick_point.point = _P(*xyz)


def keeper():
    sent = []
    return ck.CheckpointKeeper('m1', 'r', publish=sent.append), sent


def test_keeper_follows_a_pick_and_publishes_every_transition():
    k, sent = keeper()
    k.point([4, 2, 7], 1)
    k.target(5, (0.5, 0.1, 0.9))
    k.phase(ck.PHASE_SUCTION)
    assert sent[-1].holding and sent[-1].phase == 'suction' and sent[-1].target_id == 5
    k.phase(ck.PHASE_PULL)
    k.phase(ck.PHASE_CUT)
    k.phase(ck.PHASE_PLACE)
    assert sent[-1].holding
    k.phase(ck.PHASE_PLACED)
    assert not sent[-1].holding
    k.target_done(5, (0.5, 0.1, 0.9))
    last = sent[-1]
    assert (last.mission_id, last.robot, last.points, last.point_index, last.picking_point) == \
        ('m1', 'r', [4, 2, 7], 1, 2)
    assert last.targets_done == [(5, (0.5, 0.1, 0.9))]
    assert (last.target_id, last.target_position, last.phase, last.holding) == (-1, None, '', False)
    assert len(sent) == 8


def test_next_point_clears_done_targets_but_the_same_point_again_keeps_them():
    k, sent = keeper()
    k.point([0, 1], 0)
    k.target(1, (0.0, 0.0, 1.0))
    k.target_done(1, (0.0, 0.0, 1.0))
    k.point([0, 1], 0)                         # visited again (resume, emergency stop)
    assert sent[-1].targets_done == [(1, (0.0, 0.0, 1.0))]
    k.point([0, 1], 1)
    assert sent[-1].targets_done == [] and sent[-1].picking_point == 1


def test_phase_without_a_target_or_after_finish_publishes_nothing():
    k, sent = keeper()
    k.phase(ck.PHASE_APPROACH)
    assert sent == []
    k.target(1, (0.0, 0.0, 1.0))
    k.finish('succeeded')
    assert sent[-1].finished and sent[-1].outcome == 'succeeded' and not sent[-1].holding
    n = len(sent)
    k.phase(ck.PHASE_CUT)
    assert len(sent) == n
    with pytest.raises(ValueError, match='phase'):
        k.phase('dance')


def snap(phase, target_id=3, done=(), point_index=1, **kw):
    return ck.Snapshot('m1', '', [0, 5, 6], point_index, [0, 5, 6][point_index], list(done),
                       target_id, (0.5, 0.0, 1.0) if target_id >= 0 else None, phase,
                       phase in ck.HOLDING_PHASES, **kw)


@pytest.mark.parametrize('phase, steps, record, failed', [
    ('', ['release', 'home'], None, None),
    ('approach', ['release', 'home'], None, None),
    ('suction', ['release', 'home'], None, None),
    ('pull', ['release', 'home'], None, None),
    ('cut', ['cut', 'place', 'home'], 'picked', 'lost'),
    ('place', ['place', 'home'], 'picked', 'lost'),
    ('placed', ['home'], 'picked', None),
])
def test_resume_plan_by_phase(phase, steps, record, failed):
    plan = ck.resume_plan(snap(phase, target_id=-1 if phase == '' else 3))
    assert plan.steps == steps
    assert (plan.record, plan.record_if_failed) == (record, failed)
    assert plan.point_index == 1 and plan.why


@pytest.mark.parametrize('phase', ['cut', 'place', 'placed'])
def test_resume_does_not_record_a_held_fruit_twice(phase):
    # the record went out, the checkpoint after it did not: the store has it
    recorded = [(5, 3, (0.505, 0.0, 1.0))]
    plan = ck.resume_plan(snap(phase), recorded)
    assert plan.record is None and plan.record_if_failed is None
    assert (0.505, 0.0, 1.0) in plan.skip
    # the same id at another point, or far away, is another fruit
    for other in ([(0, 3, (0.5, 0.0, 1.0))], [(5, 3, (0.7, 0.0, 1.0))]):
        assert ck.resume_plan(snap(phase), other).record == 'picked'


def test_resume_skips_targets_done_at_its_point_and_records_elsewhere_do_not_count():
    done = [(1, (0.4, 0.1, 0.9))]
    recorded = [(5, 2, (0.3, 0.2, 1.1)), (0, 9, (0.9, 0.9, 0.9)), (5, 1, (0.401, 0.1, 0.9))]
    plan = ck.resume_plan(snap('approach', done=done), recorded, tolerance=0.02)
    assert sorted(plan.skip) == [(0.3, 0.2, 1.1), (0.4, 0.1, 0.9)]
    scan = [_T(0, (0.41, 0.1, 0.9)), _T(1, (0.6, 0.0, 1.0)), _T(2, (0.3, 0.21, 1.1))]
    assert [t.id for t in ck.not_done(scan, plan.skip, 0.02)] == [1]


def test_resume_before_the_first_point_starts_at_the_first_point():
    plan = ck.resume_plan(ck.Snapshot('m1', points=[3, 4], point_index=-1))
    assert plan.point_index == 0 and plan.steps == ['release', 'home']


def test_a_finished_checkpoint_is_not_resumed():
    with pytest.raises(ValueError, match='finished'):
        ck.resume_plan(snap('', target_id=-1, finished=True, outcome='succeeded'))


def test_progress_resume_at_visits_the_point_again_then_the_rest():
    p = ml.Progress(loader=lambda: pytest.fail('the plan comes from the checkpoint'))
    p.resume_at([4, 2, 7], 1)
    assert [p.advance(), p.advance(), p.advance()] == [2, 7, None]
    done = ml.Progress(points=[1])
    done.resume_at([1, 2], 2)                 # every point visited, not finished
    assert done.advance() is None
    with pytest.raises(ValueError):
        ml.Progress(points=[1]).resume_at([1, 2], 3)


def test_recorder_restore_counts_the_fruit_recorded_before_the_restart():
    r = ml.MissionRecorder('m1')
    r.restore([(0, 1, (0.1, 0.2, 0.3), ml.OUTCOME_PICKED, '', 12.0),
               (0, 2, (0.1, 0.3, 0.3), ml.OUTCOME_UNREACHABLE, 'out of reach', 1.0)],
              points_visited=1)
    r.begin_fruit(1, 0, (0.0, 0.0, 1.0), 100.0)
    r.end_fruit(ml.OUTCOME_PICKED, 110.0)
    t = r.totals()
    assert (t['picked'], t['unreachable'], t['attempted'], t['points_visited']) == (2, 1, 3, 1)
    assert t['mean_cycle_time'] == pytest.approx(11.0)


def test_restart_detail():
    assert 'start 2' in ck.restart_detail(2, 'm1', 'released')
    assert 'm1' in ck.restart_detail(3, 'm1', 'x') and 'waiting for ~start' in ck.restart_detail(2)
