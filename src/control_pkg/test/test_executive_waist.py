"""The waist in the executive's goals (control_pkg.executive_goals), no master."""
import math

import pytest

from harvest_msgs.msg import KinematicsResult
from control_pkg import executive_goals as goals
from tomatoes import tomato, xyz




def test_suction_goal_lets_the_waist_turn_for_both_hands():
    goal = goals.suction_kinematics_goal(tomato(0, (0.66, 0.34, 0.83), 0.035))
    assert goal.solve_waist and goal.check_other
    assert goal.other_target.header.frame_id == 'base_link'
    assert xyz(goal.other_target) == pytest.approx((0.66, 0.34, 0.83 + 0.035 + goals.PEDUNCLE_GAP))
    assert goal.other_standoff == 0.0         # the cut point itself, where the servo ends
    goal = goals.suction_kinematics_goal(tomato(0, (0.66, 0.34, 0.83), 0.035), peduncle_gap=0.02)
    assert xyz(goal.other_target)[2] == pytest.approx(0.83 + 0.055)


def test_suction_goal_without_the_waist():
    goal = goals.suction_kinematics_goal(tomato(0, (0.66, 0.34, 0.83), 0.035), waist=False)
    assert not goal.solve_waist and not goal.check_other
    assert xyz(goal.target) == (0.66, 0.34, 0.83) and goal.standoff == pytest.approx(0.035)


def test_cut_check_lets_the_waist_turn_for_both_hands():
    t = tomato(0, (0.66, 0.34, 0.83), 0.035)
    goal = goals.cut_check_kinematics_goal(t, 0.01, 0.03)
    plain = goals.cutting_kinematics_goal(t, 0.01, 0.03)
    assert goal.arm == goals.ARM_LEFT and goal.standoff == plain.standoff
    assert xyz(goal.target) == xyz(plain.target)
    assert goal.solve_waist and goal.check_other
    assert xyz(goal.other_target) == (0.66, 0.34, 0.83)        # the suction arm on the fruit
    assert goal.other_standoff == pytest.approx(0.035)


def test_goals_while_the_fruit_is_held_keep_the_waist():
    t = tomato(0, (0.5, 0.1, 1.0), 0.03)
    for goal in (goals.cutting_kinematics_goal(t, 0.01, 0.03),
                 goals.pull_kinematics_goal(t, (-0.08, 0.0, 0.0))):
        assert not goal.solve_waist and not goal.check_other


def test_a_solution_with_the_waist_moves_it_with_the_arm():
    result = KinematicsResult(reachable=True, move_waist=True, waist=0.3)
    result.joint_goal.positions = [0.1, 0.2, 0.3]
    joints, reason = goals.kinematics_solution(result)
    assert joints == [0.1, 0.2, 0.3, 0.3] and reason is None
    move = goals.move_goal(goals.ARM_RIGHT, joints)
    assert move.arm == goals.ARM_RIGHT and list(move.target_joint.positions) == [0.1, 0.2, 0.3]
    assert move.move_waist and move.waist == pytest.approx(0.3)


def test_a_solution_where_the_waist_is_leaves_it():
    result = KinematicsResult(reachable=True, move_waist=False, waist=0.3)
    result.joint_goal.positions = [0.1, 0.2, 0.3]
    joints, _ = goals.kinematics_solution(result)
    assert joints == [0.1, 0.2, 0.3]
    move = goals.move_goal(goals.ARM_LEFT, joints)
    assert not move.move_waist and list(move.target_joint.positions) == [0.1, 0.2, 0.3]


def test_waist_goal_moves_the_waist_alone():
    goal = goals.waist_goal(-math.pi / 4)
    assert goal.move_waist and goal.waist == pytest.approx(-math.pi / 4)
    assert list(goal.target_joint.positions) == []
