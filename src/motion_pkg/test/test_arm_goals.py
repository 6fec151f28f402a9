"""move_robot goals per arm (motion_pkg.motion_goals.ArmGoals, goal_arms): who takes over whom."""

import os
import sys

import pytest

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(HERE, '..', 'src'))

from motion_pkg import motion_goals as mg  # noqa: E402

RIGHT = mg.arm_axes(False)
LEFT = mg.arm_axes(True)


class Goal(object):
    """A stand-in for the server's running goal (compared by identity)."""

    def __init__(self, name):
        self.name = name

    def __repr__(self):
        return self.name


def test_goal_arms():
    assert mg.goal_arms(False, False) == ('right',)
    assert mg.goal_arms(True, False) == ('left',)
    # the waist carries both arms: a waist goal belongs to both, whatever its arm field
    assert set(mg.goal_arms(False, True)) == {'right', 'left'}
    assert set(mg.goal_arms(True, True)) == {'right', 'left'}


def test_goals_of_the_two_arms_run_side_by_side():
    book = mg.ArmGoals()
    right, left = Goal('right'), Goal('left')
    assert book.add(right, ('right',), RIGHT) == []
    assert book.add(left, ('left',), LEFT) == []
    assert book.goals() == [right, left]
    assert book.goal_of('right') is right and book.goal_of('left') is left
    assert book.remove(left)
    assert book.goals() == [right]
    assert not book.remove(left)              # a goal ends once


def test_a_new_goal_for_an_arm_replaces_its_goal_without_halting():
    book = mg.ArmGoals()
    old, other, new = Goal('old'), Goal('other'), Goal('new')
    book.add(old, ('left',), LEFT)
    book.add(other, ('right',), RIGHT)
    displaced = book.add(new, ('left',), LEFT)
    assert [d.goal for d in displaced] == [old]
    assert displaced[0].halt == []            # the new goal retargets every axis of the old one
    assert not book.holds(old)
    assert book.goal_of('left') is new and book.goal_of('right') is other


def test_a_waist_goal_takes_over_both_arms():
    book = mg.ArmGoals()
    right, left, waist = Goal('right'), Goal('left'), Goal('waist+left')
    book.add(right, ('right',), RIGHT)
    book.add(left, ('left',), LEFT)
    displaced = book.add(waist, mg.goal_arms(True, True), LEFT + ['waist'])
    assert {d.goal: d.halt for d in displaced} == {right: RIGHT, left: []}
    assert book.goals() == [waist]
    assert book.arms_of(waist) == ('right', 'left')


def test_a_waist_only_goal_halts_both_arms():
    book = mg.ArmGoals()
    right, left, waist = Goal('right'), Goal('left'), Goal('waist')
    book.add(right, ('right',), RIGHT)
    book.add(left, ('left',), LEFT)
    displaced = book.add(waist, mg.goal_arms(False, True), ['waist'])
    assert {d.goal: d.halt for d in displaced} == {right: RIGHT, left: LEFT}


def test_an_arm_goal_ends_a_waist_goal_of_both_arms_once():
    book = mg.ArmGoals()
    waist, new = Goal('waist+right'), Goal('right')
    book.add(waist, mg.goal_arms(False, True), RIGHT + ['waist'])
    displaced = book.add(new, ('right',), RIGHT)
    assert len(displaced) == 1 and displaced[0].goal is waist
    assert displaced[0].halt == ['waist']     # nobody would watch the waist any more
    assert book.goal_of('left') is None       # the waist goal's hold on the left arm ends too
    assert book.goals() == [new]


def test_displaced_by_changes_nothing_and_take_over_frees_the_arms():
    book = mg.ArmGoals()
    old = Goal('old')
    book.add(old, ('right',), RIGHT)
    assert [d.goal for d in book.displaced_by(('right',), RIGHT)] == [old]
    assert book.holds(old)
    assert book.displaced_by(('left',), LEFT) == []
    assert [d.goal for d in book.take_over(('right',), RIGHT)] == [old]
    assert book.goals() == [] and not book.remove(old)


def test_clear_returns_every_goal_once():
    book = mg.ArmGoals()
    waist = Goal('waist')
    book.add(waist, mg.ARMS, ['waist'])
    assert book.clear() == [waist]
    assert book.goals() == []
    right, left = Goal('right'), Goal('left')
    book.add(right, ('right',), RIGHT)
    book.add(left, ('left',), LEFT)
    assert book.clear() == [right, left]


def test_unknown_arm_refused():
    with pytest.raises(ValueError):
        mg.ArmGoals().add(Goal('x'), ('middle',), [])


def test_a_waist_already_there_is_no_waist_move():
    names, targets, speeds = LEFT + ['waist'], [0.1, 0.2, 0.3, 0.0], [1.0, 2.0, 3.0, 4.0]
    assert mg.goal_scope(True, names, targets, speeds, True) == (
        ('left',), LEFT, [0.1, 0.2, 0.3], [1.0, 2.0, 3.0])
    arms, got, _, _ = mg.goal_scope(True, names, targets, speeds, False)
    assert set(arms) == {'left', 'right'} and got == names
    # the waist alone always belongs to both arms (nothing else to belong to)
    arms, got, _, _ = mg.goal_scope(False, ['waist'], [0.0], [1.0], True)
    assert set(arms) == {'left', 'right'} and got == ['waist']
    assert mg.goal_scope(False, RIGHT, [0.0] * 3, [1.0] * 3, True)[:2] == (('right',), RIGHT)
    assert names == LEFT + ['waist']          # the caller's lists are left alone


def test_waist_settled():
    tol = 0.0035
    assert mg.waist_settled(0.0, 0.003, False, tol, False)
    assert not mg.waist_settled(0.0, 0.004, False, tol, False)    # beyond the tolerance
    assert not mg.waist_settled(0.0, 0.0, True, tol, False)       # still turning
    assert not mg.waist_settled(0.0, 0.0, False, tol, True)       # a running goal turns it
    assert not mg.waist_settled(0.0, None, False, tol, False)     # position unknown


def test_axis_held():
    book = mg.ArmGoals()
    waist = Goal('waist')
    book.add(waist, mg.ARMS, RIGHT + ['waist'])
    assert book.axis_held('waist') and book.axis_held(RIGHT[0]) and not book.axis_held(LEFT[0])
    book.remove(waist)
    assert not book.axis_held('waist')


def test_a_callback_makes_only_its_own_servers_calls():
    # a goal callback holds its server's lock: calling into another server's goal handles from
    # there can deadlock with that server's callback doing the same (end_effector off beside a
    # move_robot goal); those calls are left to the poll thread
    actions = [('move_robot', 'finish right'), ('end_effector', 'finish valve'),
               ('move_robot', 'feedback left'), ('move_base', 'feedback cart')]
    now, later = mg.split_actions(actions, 'move_robot')
    assert now == ['finish right', 'feedback left']
    assert later == [('end_effector', 'finish valve'), ('move_base', 'feedback cart')]
    now, later = mg.split_actions(actions, 'end_effector')
    assert now == ['finish valve'] and len(later) == 3
    # the poll thread (no server lock held) makes every call, in order
    assert mg.split_actions(actions, None) == ([a for _, a in actions], [])
