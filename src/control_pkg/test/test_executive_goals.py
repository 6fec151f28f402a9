"""The executive's goals and its reading of results (control_pkg.executive_goals), no master."""
import math

import pytest
from actionlib_msgs.msg import GoalStatus

from harvest_msgs.msg import KinematicsResult, MoveRobotResult, EndEffectorResult, StartResult
from control_pkg import executive_goals as goals
from tomatoes import tomato, xyz




def test_located_needs_the_frame_a_radius_and_a_finite_point():
    assert goals.located(tomato(1, (0.5, 0.1, 1.0), 0.03), 'base_link') == (0.5, 0.1, 1.0)
    assert goals.located(tomato(1, (0.5, 0.1, 1.0), 0.03), 'map') is None
    assert goals.located(tomato(1, (0.5, 0.1, 1.0), 0.0), 'base_link') is None
    assert goals.located(tomato(1, (math.nan, 0.1, 1.0), 0.03), 'base_link') is None


def test_arm_goals():
    t = tomato(3, (0.5, 0.1, 1.0), 0.03)
    suction = goals.suction_kinematics_goal(t)
    assert suction.arm == goals.ARM_RIGHT and suction.standoff == pytest.approx(0.03)
    assert xyz(suction.target) == (0.5, 0.1, 1.0)
    cut = goals.cutting_kinematics_goal(t, peduncle_gap=0.01, approach=0.03)
    assert cut.arm == goals.ARM_LEFT and cut.standoff == pytest.approx(0.03)
    assert xyz(cut.target) == pytest.approx((0.5, 0.1, 1.04))      # fruit top + gap
    pull = goals.pull_kinematics_goal(t, (-0.08, 0.0, 0.0))
    assert pull.arm == goals.ARM_RIGHT and xyz(pull.target) == pytest.approx((0.42, 0.1, 1.0))
    assert xyz(t.pick_point) == (0.5, 0.1, 1.0), 'the target itself is not moved'
    assert xyz(goals.pulled(t, (-0.08, 0.0, 0.0)).pick_point) == pytest.approx((0.42, 0.1, 1.0))
    move = goals.move_goal(goals.ARM_LEFT, (0.1, 0.2, 0.3))
    assert move.arm == goals.ARM_LEFT and list(move.target_joint.positions) == [0.1, 0.2, 0.3]
    assert goals.scan_goal(2, 'base_link').picking_point == 2
    assert goals.held_scan_goal('base_link').picking_point == -1


def test_scan_gives_the_pickable_in_order_and_the_located_scene():
    scan = [tomato(1, (0.5, 0.0, 1.0), 0.03, order=1), tomato(2, (0.6, 0.0, 1.0), 0.03, order=0),
            tomato(3, (0.7, 0.0, 1.0), 0.03, pickable=False),
            tomato(4, (math.nan, 0.0, 1.0), 0.03, pickable=False)]
    assert [t.id for t in goals.pickable_in_order(scan)] == [2, 1]
    assert [s[0] for s in goals.scene_of(scan, 'base_link')] == [1, 2, 3]


def test_results_read_the_way_the_servers_answer():
    ok = GoalStatus.SUCCEEDED
    assert goals.kinematics_solution(None) == (None, None)
    reach = KinematicsResult(reachable=True)
    reach.joint_goal.positions = [0.1, 0.2, 0.3]
    assert goals.kinematics_solution(reach) == ([0.1, 0.2, 0.3], None)
    assert goals.kinematics_solution(KinematicsResult(reachable=False, reason='beyond reach')) == \
        (None, 'beyond reach')
    assert goals.move_failure(ok, MoveRobotResult(succeed=1)) is None
    assert goals.move_failure(ok, MoveRobotResult(succeed=-2)) == 'move finished with code -2'
    assert goals.move_failure(GoalStatus.ABORTED, MoveRobotResult(succeed=-2)) is None, \
        'an aborted goal is the state machine\'s aborted outcome already'
    assert goals.report_failure(ok, EndEffectorResult(success=False, message='no vacuum')) == \
        'no vacuum'
    assert goals.report_failure(ok, EndEffectorResult(success=True)) is None
    assert goals.self_test_failure(StartResult(success=True)) is None
    failed = StartResult(success=False, failed=['motion'], reasons=['no controller'], message='x')
    assert goals.self_test_failure(failed) == 'motion: no controller'
    assert goals.self_test_failure(StartResult(success=False, message='timed out')) == 'timed out'


def test_held_fruit_relocated_only_to_a_near_fruit_not_smaller():
    held = tomato(5, (0.42, 0.1, 1.0), 0.030)
    near_bigger = tomato(9, (0.43, 0.1, 1.0), 0.032)
    near_smaller = tomato(8, (0.425, 0.1, 1.0), 0.025)
    far = tomato(7, (0.50, 0.1, 1.0), 0.035)
    moved = goals.relocate(held, [far, near_bigger], 0.03)
    assert moved.why == 'moved' and moved.distance == pytest.approx(0.01)
    assert xyz(moved.target.pick_point) == (0.43, 0.1, 1.0) and moved.target.id == 5
    assert moved.target.radius == pytest.approx(0.032)
    assert goals.relocate(held, [near_smaller, near_bigger], 0.03).why == 'smaller', \
        'the nearest one decides'
    assert goals.relocate(held, [far], 0.03).why == 'not-found'
    assert goals.relocate(held, None, 0.03).why == 'no-result'
    assert goals.relocate(tomato(5, (math.nan, 0, 1), 0.03), [near_bigger], 0.03).why == \
        'no-estimate'


def test_held_fruit_relocated_to_one_a_little_smaller_within_the_radius_tolerance():
    """low_light f01_0: seen again 17 mm from the first estimate with radius 28.9 mm against
    31.2 mm; kept on the first estimate, the shear closed 15 mm beside the peduncle."""
    held = tomato(5, (0.42, 0.1, 1.0), 0.0312)
    seen = tomato(9, (0.437, 0.1, 1.0), 0.0289)
    assert goals.relocate(held, [seen], 0.03).why == 'smaller'
    moved = goals.relocate(held, [seen], 0.03, radius_tolerance=0.1)
    assert moved.why == 'moved' and moved.target.radius == pytest.approx(0.0289)
    much_smaller = tomato(8, (0.437, 0.1, 1.0), 0.024)
    assert goals.relocate(held, [much_smaller], 0.03, radius_tolerance=0.1).why == 'smaller'


def _along(a, b, k):
    return tuple(x + k * y for x, y in zip(a, b))


def test_a_smaller_held_fruit_corrects_the_depth_along_the_view_ray_only():
    """low_light f01_0 (twelfth session): the first scan ranged the dim fruit 15 mm too far
    (block matching mismatched its whole skin); seen again 17 mm nearer with a smaller circle
    (29.5 against 31.3 mm), it was kept where the first scan put it and the shear closed 12 mm
    beside the peduncle. The view ray says which part of the difference to trust."""
    eye = (-0.05, 0.0, 1.0)                      # the stereo head's right eye in base_link
    first = (0.50, -0.13, 0.83)
    norm = math.sqrt(sum((f - e) ** 2 for f, e in zip(first, eye)))
    ray = tuple((f - e) / norm for f, e in zip(first, eye))
    across = (ray[1], -ray[0], 0.0)
    scale = math.sqrt(sum(c * c for c in across))
    across = tuple(c / scale for c in across)    # a unit vector square to the ray
    held = tomato(5, first, 0.0313)
    # the same fruit 15 mm nearer along the ray, its circle shrunk by the sleeve (2 mm smaller
    # radius: its centre a further 2 mm nearer) and shifted 4 mm across the view by it
    seen = tomato(9, _along(_along(_along(first, ray, -0.015), ray, -0.002), across, 0.004),
                  0.0293)
    assert goals.relocate(held, [seen], 0.03).why == 'smaller', 'without the eye, as before'
    found = goals.relocate(held, [seen], 0.03, viewpoint=eye)
    assert found.why == 'depth' and found.shift == pytest.approx(-0.015, abs=1e-9)
    assert xyz(found.target.pick_point) == pytest.approx(_along(first, ray, -0.015), abs=1e-9)
    assert found.target.radius == pytest.approx(0.0313) and found.target.id == 5
    assert found.radius == pytest.approx(0.0293)
    assert xyz(held.pick_point) == first, 'the first estimate itself is not changed'
    # at the same depth and only moved across the view (the occluder's doing): it stays put
    beside = tomato(9, _along(_along(first, ray, -0.002), across, 0.006), 0.0293)
    kept = goals.relocate(held, [beside], 0.03, viewpoint=eye)
    assert kept.why == 'depth' and kept.shift == pytest.approx(0.0, abs=1e-9)
    assert xyz(kept.target.pick_point) == pytest.approx(first, abs=1e-9)
    # a larger circle replaces the estimate whole, as before
    bigger = tomato(9, _along(first, across, 0.006), 0.033)
    assert goals.relocate(held, [bigger], 0.03, viewpoint=eye).why == 'moved'
    # an eye at the fruit gives no ray: as without one
    assert goals.relocate(held, [seen], 0.03, viewpoint=first).why == 'smaller'


def test_running_goals_of_a_status_array():
    """WAIT_CART reads the move_base server's statuses: pending, active and being cancelled
    goals run; finished ones, whoever sent them, do not."""
    from actionlib_msgs.msg import GoalID, GoalStatusArray
    array = GoalStatusArray(status_list=[
        GoalStatus(goal_id=GoalID(id=name), status=status) for name, status in (
            ('done', GoalStatus.SUCCEEDED), ('moving', GoalStatus.ACTIVE),
            ('queued', GoalStatus.PENDING), ('stopping', GoalStatus.PREEMPTING),
            ('halted', GoalStatus.ABORTED), ('cancelled', GoalStatus.PREEMPTED),
            ('recalling', GoalStatus.RECALLING), ('lost', GoalStatus.LOST))])
    assert goals.running_goals(array) == ['moving', 'queued', 'stopping', 'recalling']
    assert goals.running_goals(GoalStatusArray()) == []
