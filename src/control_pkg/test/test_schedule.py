"""The pipelined schedule's pure decisions (control_pkg.mission): the arms' paths, the collision
check that guards every overlap, the record of the steps; the move gate's turns."""
import math
import os
import random
import threading

import pytest

from control_pkg import mission as m
from control_pkg import mission_planning as planning
from control_pkg import executive_goals as goals

kinematics = pytest.importorskip('motion_pkg.kinematics')


@pytest.fixture(scope='module')
def geometry():
    import rospkg
    path = os.path.join(rospkg.RosPack().get_path('harvest_description'), 'config', 'robot.yaml')
    return kinematics.RobotGeometry.from_yaml(path)


HOME_LEFT = (0.0, 0.7854, 2.3562)
BOX_RIGHT = (0.05, -2.159, 1.962)


# --- the arms' paths ---------------------------------------------------------------------------
@pytest.mark.parametrize('distance', [0.01, 0.5, 2.0])       # triangle and trapezoid profiles
def test_trapezoid_starts_and_ends_at_rest_where_the_motion_profile_says(distance):
    v, a = 1.0, 3.0
    total = distance / v + v / a if distance >= v * v / a else 2.0 * math.sqrt(distance / a)
    assert m.trapezoid_position(0.0, distance, v, a, 0.0) == 0.0
    assert m.trapezoid_position(0.0, distance, v, a, total) == pytest.approx(distance)
    assert m.trapezoid_position(0.0, distance, v, a, total + 1.0) == distance
    assert m.trapezoid_position(0.0, distance, v, a, total / 2.0) == pytest.approx(distance / 2.0)
    samples = [m.trapezoid_position(0.0, distance, v, a, total * i / 50.0) for i in range(51)]
    assert samples == sorted(samples)                         # monotone
    assert m.trapezoid_position(1.0, 1.0 - distance, v, a, total / 2.0) == \
        pytest.approx(1.0 - distance / 2.0)                   # backwards too


def test_arm_path_runs_every_axis_on_its_own_profile_from_start_to_goal():
    path = m.arm_path((0.0, 0.0, 0.0), (0.1, 1.0, -0.2), (0.1, 1.0, 1.0), (0.3, 3.0, 3.0), 0.01)
    assert tuple(path[0]) == (0.0, 0.0, 0.0)
    assert tuple(path[-1]) == pytest.approx((0.1, 1.0, -0.2))
    # the short forearm move is over long before the boom's
    assert path[len(path) // 2][2] == pytest.approx(-0.2)
    assert path[len(path) // 2][1] < 1.0
    assert [tuple(c) for c in m.arm_path((0.1, 0.2, 0.3), None, (1, 1, 1), (3, 3, 3), 0.01)] == \
        [(0.1, 0.2, 0.3)]


def test_arm_segments_are_motion_pkgs_arm_points(geometry):
    configs = [(0.1, 0.3, -1.0), (0.25, -2.0, 2.5), HOME_LEFT]
    for arm in ('left', 'right'):
        elbow, tip, z = m.arm_segments(geometry, arm, configs)
        for i, c in enumerate(configs):
            _, e, t = geometry.arm_points(arm, *c)
            assert tuple(elbow[i]) == pytest.approx(tuple(e[:2]))
            assert tuple(tip[i]) == pytest.approx(tuple(t[:2]))
            assert z[i] == pytest.approx(e[2])


def test_the_thinned_paths_find_the_distance_of_every_sample(geometry):
    # the check compares about 1 sample in 10 of a path: its minimum is that of all samples
    # within the sampling's error (1 cm)
    at_fruit = geometry.inverse('right', (0.5, -0.12, 1.0), standoff=0.035).joints
    cutting = geometry.inverse('left', (0.42, -0.12, 1.045), standoff=0.03,
                               other_arm_joints=at_fruit).joints
    speeds = [geometry.speed[j] for j in ('lift', 'boom', 'forearm')]
    accels = [3.0 * v for v in speeds]
    left = m.arm_path(cutting, HOME_LEFT, speeds, accels, 0.001)
    right = m.arm_path(at_fruit, BOX_RIGHT, speeds, accels, 0.001)
    every = m.arms_min_distance(geometry, left, right)
    thinned = m.arms_min_distance(geometry, left, right, 0.00375)
    assert every <= thinned <= every + 0.01
    assert len(m.thin_path(m.arm_segments(geometry, 'left', left), 0.00375)) < len(left) / 5


def test_the_plane_distance_of_segments_is_motion_pkgs_segment_distance():
    import numpy as np
    rng = random.Random(4)
    a0, a1, b0, b1 = ([[rng.uniform(-1, 1), rng.uniform(-1, 1)] for _ in range(40)]
                      for _ in range(4))
    got = m._segments_distance_2d(*(np.array(v) for v in (a0, a1, b0, b1)))
    for i in range(40):
        for j in range(40):
            want = kinematics.segment_distance(a0[i] + [0.0], a1[i] + [0.0], b0[j] + [0.0],
                                               b1[j] + [0.0])
            assert got[i, j] == pytest.approx(want, abs=1e-9)


# --- the guard of an overlap -------------------------------------------------------------------
def test_the_left_arm_may_approach_while_the_right_arm_draws_the_fruit_out(geometry):
    at_fruit = geometry.inverse('right', (0.5, -0.12, 1.0), standoff=0.035).joints
    pulled = geometry.inverse('right', (0.42, -0.12, 1.0), standoff=0.035, current=at_fruit).joints
    cutting = geometry.inverse('left', (0.42, -0.12, 1.045), standoff=0.03,
                               other_arm_joints=pulled).joints
    v = m.overlap_clear(geometry, {'left': HOME_LEFT, 'right': at_fruit},
                        {'left': cutting, 'right': pulled}, geometry.arm_clearance)
    assert v.clear, v.why
    assert v.distance >= geometry.arm_clearance + 0.01
    # and the place: the right arm to the box while the left one returns home
    v = m.overlap_clear(geometry, {'left': cutting, 'right': pulled},
                        {'left': HOME_LEFT, 'right': BOX_RIGHT}, geometry.arm_clearance)
    assert v.clear, v.why


def test_goals_that_collide_are_not_overlapped(geometry):
    right = geometry.inverse('right', (0.45, -0.1, 1.0), standoff=0.0).joints
    left = geometry.inverse('left', (0.45, -0.1, 1.0), standoff=0.0, other_arm_joints=HOME_LEFT
                            ).joints   # the other arm ignored: both tools on one point
    assert left is not None
    v = m.overlap_clear(geometry, {'left': HOME_LEFT, 'right': right},
                        {'left': left, 'right': None}, geometry.arm_clearance)
    assert not v.clear
    assert v.distance < geometry.arm_clearance
    assert 'close' in v.why


def test_hands_at_one_fruit_may_part_at_once_but_not_close_in(geometry):
    # the right arm holds the pulled fruit, the shear closed just above it: the arms start
    # closer than arm_clearance + margin (3.3 cm), above robot.yaml's arm_clearance (2 cm)
    right = geometry.inverse('right', (0.42, -0.1, 1.0), standoff=0.035).joints
    left = geometry.inverse('left', (0.42, -0.1, 1.013), standoff=0.0,
                            other_arm_joints=right).joints
    start = geometry.clearance('left', left, right)
    assert geometry.arm_clearance + 0.01 < start < geometry.arm_clearance + 0.02
    starts = {'left': left, 'right': right}
    parting = m.schedule_step(geometry, starts, {'left': HOME_LEFT, 'right': BOX_RIGHT}, 0.01)
    assert parting.clear, parting.why
    lifted = (right[0] + 0.005, right[1], right[2])      # the held fruit up toward the shear
    closing = m.schedule_step(geometry, starts, {'left': None, 'right': lifted}, 0.01)
    assert not closing.clear
    assert 'closer than' in closing.why


def test_a_path_that_sweeps_through_the_other_arm_is_not_overlapped(geometry):
    # both ends are well clear of the resting right arm (10 cm, 70 cm), the way between is not
    right = (0.15, -0.5880118084407364, 2.071251067351907)
    left = (0.15, -0.833702361032314, -1.811200543564156)
    assert geometry.clearance('left', left, right) > 0.09
    assert geometry.clearance('left', HOME_LEFT, right) > 0.5
    v = m.overlap_clear(geometry, {'left': HOME_LEFT, 'right': right},
                        {'left': left, 'right': None}, geometry.arm_clearance)
    assert not v.clear
    assert v.distance < geometry.arm_clearance


def test_an_unknown_arm_a_waist_move_or_no_geometry_is_never_overlapped(geometry):
    v = m.overlap_clear(geometry, {'left': None, 'right': BOX_RIGHT},
                        {'left': HOME_LEFT, 'right': None}, 0.02)
    assert not v.clear and 'left arm position unknown' in v.why
    v = m.overlap_clear(geometry, {'left': HOME_LEFT, 'right': BOX_RIGHT},
                        {'left': None, 'right': BOX_RIGHT + (0.3,)}, 0.02)
    assert not v.clear and 'waist' in v.why
    v = m.schedule_step(None, {'left': HOME_LEFT, 'right': BOX_RIGHT}, {'left': HOME_LEFT})
    assert not v.clear and 'geometry' in v.why


def test_a_goal_that_keeps_the_waist_where_it_is_is_an_arm_move(geometry):
    box = BOX_RIGHT + (0.0,)
    assert m.without_waist(box, 0.0005) == BOX_RIGHT
    assert m.without_waist(box, 0.2) == box
    assert m.without_waist(box, None) == box
    assert m.without_waist(BOX_RIGHT, 0.2) == BOX_RIGHT
    starts = {'left': (0.1, 0.3, -2.0), 'right': (0.1, -0.3, 2.0)}
    assert m.schedule_step(geometry, starts, {'left': HOME_LEFT, 'right': box}, waist=0.0).clear
    v = m.schedule_step(geometry, starts, {'left': HOME_LEFT, 'right': box}, waist=0.3)
    assert not v.clear and 'waist' in v.why


def test_the_margin_is_added_to_robot_yamls_arm_clearance(geometry):
    at_fruit = geometry.inverse('right', (0.5, -0.12, 1.0), standoff=0.035).joints
    cutting = geometry.inverse('left', (0.5, -0.12, 1.045), standoff=0.03,
                               other_arm_joints=at_fruit).joints
    starts, ends = {'left': HOME_LEFT, 'right': at_fruit}, {'left': cutting}
    d = m.overlap_clear(geometry, starts, ends, 0.0).distance
    assert m.schedule_step(geometry, starts, ends, margin=0.0).clear
    assert m.schedule_step(geometry, starts, ends, margin=d - geometry.arm_clearance - 0.011).clear
    assert not m.schedule_step(geometry, starts, ends, margin=d - geometry.arm_clearance).clear


def test_the_left_arm_aims_where_the_pull_will_leave_the_fruit():
    from harvest_msgs.msg import Tomato
    t = Tomato(id=1, radius=0.03)
    t.pick_point.header.frame_id = 'base_link'
    t.pick_point.point.x = 0.5
    ahead = goals.target_after_pull(t, (-0.08, 0.0, 0.0), [0.1, 0.2, 0.3])
    assert ahead.pick_point.point.x == pytest.approx(0.42)
    assert goals.target_after_pull(t, (-0.08, 0.0, 0.0), []) is t
    assert t.pick_point.point.x == 0.5


# --- the record ----------------------------------------------------------------------------------
def test_steps_are_counted_and_the_paper_summary_has_no_overlaps_key():
    r = m.MissionRecorder('m')
    assert 'overlaps' not in r.totals()
    r.note_step('PLACE', True)
    r.note_step('PLACE', False)
    r.note_step('APPROACH', True)
    assert r.totals()['overlaps'] == {'APPROACH': {'overlapped': 1, 'sequential': 0},
                                      'PLACE': {'overlapped': 1, 'sequential': 1}}


# --- the move gate ---------------------------------------------------------------------------------
def test_one_move_server_makes_the_arms_take_turns():
    from control_pkg.executive_states import MoveGate
    gate = MoveGate(per_arm=False)
    assert gate.acquire('left', lambda: False)
    assert not gate.acquire('right', lambda: True)   # busy: a cancelled wait takes nothing
    got = []
    t = threading.Thread(target=lambda: got.append(gate.acquire('right', lambda: False)))
    t.start()
    gate.release('left')
    t.join(30.0)
    assert got == [True]
    gate.release('right')


def test_per_arm_move_servers_let_the_arms_move_at_once():
    from control_pkg.executive_states import MoveGate
    gate = MoveGate(per_arm=True)
    assert gate.acquire('left', lambda: False)
    assert gate.acquire('right', lambda: False)
    assert not gate.acquire('left', lambda: True)


def test_a_waiting_move_gives_up_when_woken_by_its_preemption():
    from control_pkg.executive_states import MoveGate
    gate = MoveGate()
    assert gate.acquire('left', lambda: False)
    cancelled = threading.Event()
    got = []
    t = threading.Thread(target=lambda: got.append(gate.acquire('right', cancelled.is_set)))
    t.start()
    cancelled.set()
    gate.wake()
    t.join(30.0)
    assert got == [False]


# --- the overlaps' outcomes ------------------------------------------------------------------------
def test_an_overlap_with_an_aborted_branch_is_aborted_not_preempted():
    from control_pkg.executive_pipelined import _both_outcome, _any_aborted
    assert _both_outcome({'A': 'succeeded', 'B': 'succeeded'}) == 'succeeded'
    # the branch still running when the other aborted ends preempted: the overlap is a fault
    assert _any_aborted({'A': 'aborted', 'B': None})
    assert not _any_aborted({'A': 'succeeded', 'B': None})
    assert _both_outcome({'A': 'aborted', 'B': 'preempted'}) == 'aborted'
    assert _both_outcome({'A': 'preempted', 'B': 'preempted'}) == 'preempted'
    assert _both_outcome({'A': 'succeeded', 'B': 'preempted'}) == 'preempted'


def test_taking_turns_the_first_arm_of_an_overlap_goes_first_even_when_it_asks_later():
    from control_pkg.executive_states import MoveGate
    gate = MoveGate()
    gate.first('right')
    assert not gate.acquire('left', lambda: True)     # it would wait for the right arm
    got = []
    t = threading.Thread(target=lambda: got.append(gate.acquire('left', lambda: False)))
    t.start()
    assert gate.acquire('right', lambda: False)
    gate.release('right')
    t.join(30.0)
    assert got == [True]
    gate.release('left')
    gate.first('right')
    gate.first(None)                                   # the overlap ended without that move
    assert gate.acquire('left', lambda: False)


def test_with_a_move_server_per_arm_nobody_waits_for_the_first():
    from control_pkg.executive_states import MoveGate
    gate = MoveGate(per_arm=True)
    gate.first('right')
    assert gate.acquire('left', lambda: False)


# --- the cutting hand's standby (left_standby) ---------------------------------------------------
class _Context(object):
    """What the pipelined callbacks read of executive_states.MissionContext."""

    def __init__(self, geometry, left, right):
        from control_pkg.executive_config import merged_config
        self.config = merged_config({'schedule': 'pipelined'})
        self.geometry = geometry
        self.joints = {'left': left, 'right': right}
        self.recorder = m.MissionRecorder('m')
        self.standby = None

    def arm_joints(self, arm):
        return self.joints[arm]

    def waist(self):
        return 0.0


class _Target(object):
    def __init__(self, target_id):
        self.id = target_id


class _Ud(dict):
    """Userdata: keys as attributes."""
    __getattr__ = dict.__getitem__
    __setattr__ = dict.__setitem__


def _callbacks(context):
    pytest.importorskip('smach')
    from control_pkg.executive_pipelined import _PipelinedCallbacks
    return _PipelinedCallbacks(context)


def _after_a_cut(geometry):
    """The arms after a cut (right: the pulled fruit, left: the shear at its peduncle), the
    next fruit 12 cm further right: its suction pose and the cutting hand's standby by it."""
    held = geometry.inverse('right', (0.42, -0.12, 1.0), standoff=0.035).joints
    cut = geometry.inverse('left', (0.42, -0.12, 1.045), standoff=0.03,
                           other_arm_joints=held).joints
    suction = geometry.inverse('right', (0.5, -0.24, 1.0), standoff=0.035, current=BOX_RIGHT).joints
    standby = geometry.inverse('left', (0.5, -0.24, 1.045), standoff=0.08,
                               other_arm_joints=suction).joints
    assert None not in (held, cut, suction, standby)
    return held, cut, suction, standby


def test_the_cutting_hand_waits_by_the_next_target_when_both_ways_are_clear(geometry):
    held, cut, suction, standby = _after_a_cut(geometry)
    c = _Context(geometry, cut, held)
    cb = _callbacks(c)
    ud = _Ud(targets=[_Target(7)], next_goal=list(suction), standby_goal=list(standby))
    assert cb.place_step(ud) == 'standby'
    assert c.standby == (7, tuple(standby))
    assert c.recorder.totals()['overlaps']['STANDBY'] == {'overlapped': 1, 'sequential': 0}
    # once there, it is waiting by that target (and by no other)
    c.joints['left'] = tuple(standby)
    assert cb.waiting(_Ud(target=_Target(7))) == 'waiting'
    assert cb.waiting(_Ud(target=_Target(8))) == 'free'
    c.joints['left'] = HOME_LEFT
    assert cb.waiting(_Ud(target=_Target(7))) == 'free'
    assert cb.left_away(_Ud()) == 'home'


def test_no_standby_where_the_suction_arms_way_to_the_next_target_meets_it(geometry):
    held, cut, _, _ = _after_a_cut(geometry)
    # the next fruit at y 0, the hand waiting at its suction point: its way there is clear of
    # the suction arm's way to the box (the first leg), not of its way on to that fruit
    suction = geometry.inverse('right', (0.5, 0.0, 1.0), standoff=0.035, current=BOX_RIGHT).joints
    in_the_way = geometry.inverse('left', (0.5, 0.0, 1.0), standoff=0.0,
                                  other_arm_joints=HOME_LEFT).joints
    first = m.schedule_step(geometry, {'left': cut, 'right': held},
                            {'left': in_the_way, 'right': BOX_RIGHT}, 0.01)
    assert first.clear, first.why
    c = _Context(geometry, cut, held)
    cb = _callbacks(c)
    ud = _Ud(targets=[_Target(7)], next_goal=list(suction), standby_goal=list(in_the_way))
    step = cb.place_step(ud)
    assert step == 'overlap'          # the left arm home beside the way to the box instead
    assert c.standby is None
    assert c.recorder.totals()['overlaps']['STANDBY'] == {'overlapped': 0, 'sequential': 1}


def test_where_only_the_way_to_the_box_meets_it_the_suction_arm_leaves_first(geometry):
    # the arms after the cut of three_targets' first fruit at its second point (joints of a
    # pipelined mission): the cutting hand's way to its standby by the next fruit comes 29 mm
    # close to the suction arm's way to the box, but not to its way on from the box
    held, cut = (0.052, 0.64, 1.848), (0.089, -2.046, 2.366)
    suction, standby = (0.032, 0.292, 1.829), (0.081, -2.37, 2.167)
    at_once = m.schedule_step(geometry, {'left': cut, 'right': held},
                              {'left': standby, 'right': BOX_RIGHT}, 0.01)
    assert not at_once.clear
    c = _Context(geometry, cut, held)
    cb = _callbacks(c)
    ud = _Ud(targets=[_Target(7)], next_goal=list(suction), standby_goal=list(standby))
    assert cb.place_step(ud) == 'box_first'
    # the cutting hand goes to that standby after all: the next target finds it waiting
    assert c.standby == (7, tuple(standby))
    totals = c.recorder.totals()['overlaps']
    assert totals['STANDBY'] == {'overlapped': 0, 'sequential': 1}
    assert totals['BOX_FIRST'] == {'overlapped': 1, 'sequential': 0}
    # each of its two steps is clear: the suction arm to the box beside the resting hand, then
    # both arms on at once
    assert m.schedule_step(geometry, {'left': cut, 'right': held},
                           {'left': None, 'right': BOX_RIGHT}, 0.01).clear
    assert m.schedule_step(geometry, {'left': cut, 'right': BOX_RIGHT},
                           {'left': standby, 'right': suction}, 0.01).clear


def test_no_box_first_where_the_way_on_from_the_box_meets_the_hand(geometry):
    held, cut, _, _ = _after_a_cut(geometry)
    # the standby right on the next fruit's suction point: in the way of both legs' ends
    suction = geometry.inverse('right', (0.5, 0.0, 1.0), standoff=0.035, current=BOX_RIGHT).joints
    in_the_way = geometry.inverse('left', (0.5, 0.0, 1.0), standoff=0.0,
                                  other_arm_joints=HOME_LEFT).joints
    c = _Context(geometry, cut, held)
    cb = _callbacks(c)
    ud = _Ud(targets=[_Target(7)], next_goal=list(suction), standby_goal=list(in_the_way))
    assert cb.place_step(ud) in ('overlap', 'sequential')
    assert c.standby is None
    assert 'BOX_FIRST' not in c.recorder.totals()['overlaps']


def test_a_plan_for_the_next_target_starts_empty_and_none_means_home(geometry):
    held, cut, suction, standby = _after_a_cut(geometry)
    c = _Context(geometry, cut, held)
    cb = _callbacks(c)
    # the last fruit's goals must not be taken again when there is no next target
    ud = _Ud(targets=[], next_goal=list(suction), standby_goal=list(standby))
    assert cb.plan_next(ud) == 'none'
    assert ud['next_goal'] == [] and ud['standby_goal'] == []
    assert cb.place_step(ud) in ('overlap', 'sequential')
    assert 'STANDBY' not in c.recorder.totals().get('overlaps', {})
    assert c.standby is None
    assert cb.left_away(_Ud()) == 'away'


def test_the_pruned_smallest_distance_is_the_one_of_every_pair(geometry):
    """arms_min_distance prunes block pairs by their bounding boxes: over 60 random moves
    between home, the box and the plant, sampled finely and coarsely, it gives exactly the
    smallest distance of all sample pairs (and the pruning did skip work on many of them)."""
    import numpy as np
    rng = random.Random(11)
    fruit = [(0.42 + 0.1 * rng.random(), -0.3 + 0.4 * rng.random(), 0.9 + 0.2 * rng.random())
             for _ in range(12)]
    poses = {'left': [HOME_LEFT], 'right': [BOX_RIGHT]}
    for p in fruit:
        for arm, standoff in (('left', 0.08), ('right', 0.035)):
            joints = geometry.inverse(arm, p, standoff=standoff).joints
            if joints is not None:
                poses[arm].append(joints)
    speeds = [geometry.speed[j] for j in ('lift', 'boom', 'forearm')]
    accels = [3.0 * v for v in speeds]
    pruned = 0
    for _ in range(60):
        starts = {arm: rng.choice(poses[arm]) for arm in ('left', 'right')}
        goals_ = {arm: rng.choice(poses[arm]) for arm in ('left', 'right')}
        for dt in (0.004, 0.02):
            a = planning.arm_segments(geometry, 'left', planning.arm_path(starts['left'], goals_['left'],
                                                            speeds, accels, dt))
            b = planning.arm_segments(geometry, 'right', planning.arm_path(starts['right'], goals_['right'],
                                                             speeds, accels, dt))
            every = float(planning._pairs_distance(a, b).min())
            assert planning._min_segment_distance(a, b) == every
            (alo, ahi), (blo, bhi) = planning._blocks(a, planning.DISTANCE_BLOCK), planning._blocks(b, planning.DISTANCE_BLOCK)
            gap = np.maximum(np.maximum(alo[:, None] - bhi[None], blo[None] - ahi[:, None]), 0.0)
            pruned += int((np.sqrt((gap * gap).sum(axis=2)) >= every).sum() > 0)
    assert pruned > 30


def test_block_bounds_hold_every_segment_of_their_block(geometry):
    """The pruning is exact only if a block's box holds its segments: both ends and height."""
    import numpy as np
    speeds = [geometry.speed[j] for j in ('lift', 'boom', 'forearm')]
    path = planning.arm_segments(geometry, 'right', planning.arm_path(BOX_RIGHT, HOME_LEFT, speeds,
                                                        [3.0 * v for v in speeds], 0.003))
    lo, hi = planning._blocks(path, 16)
    for k in range(len(path[2])):
        b = k // 16
        for end in (path[0][k], path[1][k]):
            assert np.all(lo[b, :2] <= end) and np.all(end <= hi[b, :2])
        assert lo[b, 2] <= path[2][k] <= hi[b, 2]
