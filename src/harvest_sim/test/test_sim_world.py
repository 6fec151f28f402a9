"""World logic (no ROS master): suction seal, held fruit motion, harvest, drop, damage."""

import numpy as np
import pytest

from sim_fixtures import GEOM, scn

from harvest_sim import world as w

F0 = np.array([0.45, 0.05, 0.95])
F1 = np.array([0.50, -0.12, 0.90])
R = 0.035


def make_world(**kw):
    s = scn.Scenario('t', scn.Track([0.0]), scn.Lighting(),
                     [scn.Fruit('f0', F0, R, 0.9, picking_point=0, reachable=True),
                      scn.Fruit('f1', F1, R, 0.3, picking_point=0, reachable=True)])
    return w.World(s, GEOM, **kw)


def arm(name, target, standoff=0.0, other=None):
    ik = GEOM.inverse(name, target, standoff=standoff, other_arm_joints=other)
    assert ik.reachable, ik.reason
    return dict(zip(['%s_%s_joint' % (name, j) for j in ('lift', 'boom', 'forearm')],
                    ik.joints)), ik.joints


def _nothing(events):
    """A shear close that cut nothing: one event naming the nearest peduncle."""
    return len(events) == 1 and events[0].startswith('shear closed on nothing (nearest peduncle')


def suction_at(centre, extra=0.0):
    """Right arm with the suction tcp on the fruit surface (+extra metres further out)."""
    return arm('right', centre, standoff=R + extra)


def test_seal_moves_fruit_and_harvest_then_collect():
    world = make_world()
    joints, rj = suction_at(F0)
    world.set_joints(joints)
    assert world.set_valve(True) and world.sealed
    f0 = world.fruits[0]
    assert f0.state == w.HELD
    # pull the fruit 3 cm toward the robot: it follows the tcp
    pulled = F0 + [-0.03, 0.0, 0.0]
    joints, rj = suction_at(pulled)
    world.set_joints(joints)
    assert np.allclose(f0.position, pulled, atol=1e-3)
    assert np.allclose(f0.peduncle, pulled + [0, 0, R + 0.01], atol=1e-3)
    left, _ = arm('left', f0.peduncle + [0.004, 0.0, 0.0], other=rj)
    world.set_joints(left)
    events = world.shear_cut()
    assert f0.state == w.HARVESTED and not f0.attached, events
    # carry it away, release: collected
    joints, _ = arm('right', (0.2, -0.45, 0.85))
    world.set_joints(joints)
    assert np.linalg.norm(f0.position - F0) > 0.2       # no tearing: it is cut off already
    assert f0.state == w.HARVESTED
    world.set_valve(False)
    assert f0.state == w.COLLECTED and not world.sealed
    c = world.summary()
    assert (c['collected'], c['collected_ripe'], c['hanging'], c['seal_events'],
            c['cut_events']) == (1, 1, 1, 1, 1)


def test_no_seal_beyond_tolerance_but_seal_when_tcp_arrives():
    world = make_world(seal_tolerance=0.012)
    joints, _ = suction_at(F0, extra=0.02)          # 20 mm short of the surface
    world.set_joints(joints)
    world.set_valve(True)
    assert not world.sealed and world.fruits[0].state == w.HANGING
    joints, _ = suction_at(F0, extra=0.008)         # 8 mm: within tolerance
    world.set_joints(joints)
    assert world.sealed and world.fruits[0].state == w.HELD


def test_cut_without_suction_drops_and_cut_elsewhere_does_nothing():
    world = make_world()
    f1 = world.fruits[1]
    left, _ = arm('left', f1.peduncle + [0.0, 0.0, 0.02])    # 20 mm above: miss
    world.set_joints(left)
    assert _nothing(world.shear_cut())
    left, _ = arm('left', f1.peduncle)
    world.set_joints(left)
    world.shear_cut()
    assert f1.state == w.DROPPED and f1.position[2] == pytest.approx(R)
    assert world.summary()['dropped'] == 1


def test_shear_inside_fruit_damages_it():
    world = make_world()
    left, _ = arm('left', F1 + [0.0, 0.0, 0.01])
    world.set_joints(left)
    world.shear_cut()
    assert world.fruits[1].state == w.DAMAGED


def test_release_uncut_returns_fruit_and_tearing_damages():
    world = make_world(tear_distance=0.05)
    joints, _ = suction_at(F0)
    world.set_joints(joints)
    world.set_valve(True)
    joints, _ = suction_at(F0 + [-0.02, 0, 0])
    world.set_joints(joints)
    world.set_valve(False)
    f0 = world.fruits[0]
    assert f0.state == w.HANGING and np.allclose(f0.position, F0)
    joints, _ = suction_at(F0)
    world.set_joints(joints)
    world.set_valve(True)
    joints, _ = suction_at(F0 + [-0.08, 0, 0])
    events = world.set_joints(joints)
    assert f0.state == w.DAMAGED and not f0.attached, events
    world.set_valve(False)
    assert f0.position[2] == pytest.approx(R)           # fell to the floor


def test_stamped_cut_waits_for_joints_as_recent():
    world = make_world()
    f1 = world.fruits[1]
    away, _ = arm('left', (0.4, 0.3, 1.0))
    world.set_joints(away, stamp=10.0)
    assert world.shear_cut(stamp=10.5) == []           # queued: joints are older
    there, _ = arm('left', f1.peduncle)
    world.set_joints(there, stamp=10.4)
    assert f1.state == w.HANGING
    world.set_joints(there, stamp=10.6)                 # first joints at/after the cut
    assert f1.state == w.DROPPED
    world.shear_cut(stamp=11.0)
    assert world.flush_cuts(now=11.2, max_wait=0.5) == []
    assert _nothing(world.flush_cuts(now=11.6, max_wait=0.5))


def test_cut_between_sparse_joint_states_is_judged_with_the_one_before():
    # on a busy machine at 20x joint states come a simulated second apart: the next one after
    # the close shows the left arm already on its way home; the shear closed where it stood
    world = make_world()
    f1 = world.fruits[1]
    peduncle = f1.peduncle.copy()
    there, _ = arm('left', peduncle)
    world.set_joints(there, stamp=30.0)
    assert world.shear_cut(stamp=30.05) == []           # queued until a later joint state
    away, _ = arm('left', (0.4, 0.3, 1.0))
    events = world.set_joints(away, stamp=31.0)
    assert f1.state == w.DROPPED and not f1.attached, events     # cut (no suction): it fell
    assert np.allclose(f1.cut_point, peduncle, atol=1e-6)


def test_late_stamped_cut_is_judged_where_the_arm_was_at_its_stamp():
    # on a busy machine the shear close can reach the world after joint states in which the
    # left arm already moves away: it must cut where the shear was when it closed
    world = make_world()
    joints, rj = suction_at(F0)
    world.set_joints(joints, stamp=19.0)
    world.set_valve(True)
    f0 = world.fruits[0]
    assert f0.state == w.HELD
    joints, rj = suction_at(F0 + [-0.03, 0.0, 0.0])
    world.set_joints(joints, stamp=19.5)                # drawn out
    there, _ = arm('left', f0.peduncle + [0.003, 0.0, 0.0], other=rj)
    world.set_joints(there, stamp=20.0)
    world.set_joints(there, stamp=20.06)
    away, _ = arm('left', (0.3, 0.3, 1.0), other=rj)
    world.set_joints(away, stamp=20.1)                  # the arm leaves after the close
    events = world.shear_cut(stamp=20.05)               # ... whose message comes only now
    assert f0.state == w.HARVESTED and not f0.attached, events
    assert np.allclose(f0.cut_point, f0.peduncle, atol=1e-6)
    # a close older than the kept history is judged with the latest pose
    world.set_joints(away, stamp=20.1 + w.TOOL_HISTORY + 1.0)
    assert _nothing(world.shear_cut(stamp=20.05))


def _held_and_servoed(world, stamp):
    """f0 sealed and drawn out 3 cm, the shear on its peduncle from `stamp` (s) on; the
    suction arm's joints there."""
    joints, rj = suction_at(F0)
    world.set_joints(joints, stamp=stamp - 1.0)
    world.set_valve(True)
    assert world.held is world.fruits[0]
    joints, rj = suction_at(F0 + [-0.03, 0.0, 0.0])
    world.set_joints(joints, stamp=stamp - 0.5)
    there, _ = arm('left', world.fruits[0].peduncle + [0.003, 0.0, 0.0], other=rj)
    world.set_joints(there, stamp=stamp)
    return rj


def test_a_close_that_comes_after_the_tearing_pull_still_cuts_the_fruit():
    # the cut done, the suction arm carries the fruit to the box at once; that move's joint
    # states overtook the shear close: the world tears the fruit off, then hears the close,
    # stamped before the tear
    world = make_world(tear_distance=0.12)
    f0, f1 = world.fruits
    _held_and_servoed(world, 20.0)
    to_box, _ = arm('right', (0.2, -0.45, 0.85))
    events = world.set_joints(to_box, stamp=20.2)
    assert f0.state == w.DAMAGED and not f0.attached, events     # as far as the world knows yet
    events = world.shear_cut(stamp=20.05)
    assert f0.state == w.HARVESTED and not f0.attached, events
    assert 'not torn' in events[0], events
    assert np.allclose(f0.cut_point, F0 + [-0.03, 0.0, R + 0.01], atol=1e-3)
    assert f1.state == w.HANGING
    world.set_valve(False, stamp=21.0)
    c = world.summary()
    assert (c['collected'], c['damaged']) == (1, 0), c


def test_a_late_close_that_cuts_nothing_leaves_the_fruit_torn():
    world = make_world(tear_distance=0.12)
    f0 = world.fruits[0]
    rj = _held_and_servoed(world, 20.0)
    away, _ = arm('left', (0.3, 0.3, 1.0), other=rj)
    world.set_joints(away, stamp=20.02)                 # the shear left before it closed
    to_box, _ = arm('right', (0.2, -0.45, 0.85))
    world.set_joints(to_box, stamp=20.2)
    events = world.shear_cut(stamp=20.1)
    assert 'not torn' in events[0] and _nothing(events[1:]), events
    assert f0.attached and f0.state == w.HELD            # until the next joint state
    events = world.set_joints(to_box, stamp=20.3)
    assert f0.state == w.DAMAGED and not f0.attached and 'torn off' in events[0], events


def test_a_close_stamped_after_the_tear_does_not_undo_it():
    world = make_world(tear_distance=0.12)
    f0 = world.fruits[0]
    _held_and_servoed(world, 20.0)
    to_box, _ = arm('right', (0.2, -0.45, 0.85))
    world.set_joints(to_box, stamp=20.2)
    world.set_joints(to_box, stamp=20.4)
    events = world.shear_cut(stamp=20.3)
    assert f0.state == w.DAMAGED and not f0.attached, events
    assert not any('not torn' in e for e in events), events


def test_a_valve_opened_after_the_move_seals_only_with_a_pose_from_after_it():
    # the approach to f1 swept past f0; the valve's message (opened at 10.0, once the arm was at
    # f1) overtook the move's last joint states: the cup seals f1, never the neighbour it passed
    world = make_world()
    passing, _ = suction_at(F0)
    at_target, _ = suction_at(F1)
    world.set_joints(passing, stamp=9.8)
    assert world.set_valve(True, stamp=10.0) == [] and not world.sealed
    world.set_joints(passing, stamp=9.9)               # still in flight from mid-move
    assert not world.sealed and world.fruits[0].state == w.HANGING
    events = world.set_joints(at_target, stamp=10.02)
    assert world.sealed and world.held.id == 'f1', events
    assert world.fruits[0].state == w.HANGING


def test_a_valve_opened_with_the_arm_already_there_seals_at_once():
    world = make_world()
    joints, _ = suction_at(F0)
    world.set_joints(joints, stamp=10.5)
    assert world.set_valve(True, stamp=10.4) and world.sealed and world.held.id == 'f0'
    world.set_valve(False)
    assert world.seal_after is None


def test_a_valve_closed_before_the_tearing_pull_lets_the_fruit_go_on_its_pedicel():
    # a restarted task planner releases the fruit it was pulling, then takes the arm home: the
    # home move's joint states overtook the valve's closing (stamped before them)
    world = make_world(tear_distance=0.05)
    f0 = world.fruits[0]
    at_fruit, _ = suction_at(F0)
    world.set_joints(at_fruit, stamp=10.0)
    world.set_valve(True, stamp=10.0)
    assert world.held is f0
    pulled, _ = suction_at(F0 + [-0.03, 0, 0])
    world.set_joints(pulled, stamp=11.0)
    home, _ = suction_at(F0 + [-0.08, 0, 0])
    world.set_joints(home, stamp=12.1)
    assert f0.state == w.DAMAGED and not f0.attached     # as far as the world knows yet
    events = world.set_valve(False, stamp=12.0)
    assert f0.state == w.HANGING and f0.attached and np.allclose(f0.position, F0), events
    assert 'not torn' in events[0] and world.summary()['damaged'] == 0
    # sealed again and pulled too far with the valve open: torn for good
    world.set_joints(at_fruit, stamp=13.0)
    world.set_valve(True, stamp=13.0)
    world.set_joints(home, stamp=14.0)
    world.set_valve(False, stamp=14.5)
    assert f0.state == w.DAMAGED and not f0.attached and f0.position[2] == pytest.approx(R)


def test_a_closing_stamped_before_a_tear_keeps_a_fruit_damaged_by_the_shear_damaged():
    world = make_world(tear_distance=0.05)
    f0 = world.fruits[0]
    at_fruit, _ = suction_at(F0)
    world.set_joints(at_fruit, stamp=10.0)
    f0.state = w.DAMAGED                                  # shear closed inside it before
    world.set_valve(True, stamp=10.0)
    assert world.held is f0
    home, _ = suction_at(F0 + [-0.08, 0, 0])
    world.set_joints(home, stamp=11.0)
    world.set_valve(False, stamp=10.5)
    assert f0.state == w.DAMAGED and f0.attached and np.allclose(f0.position, F0)
