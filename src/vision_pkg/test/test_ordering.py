"""Picking order: bottom to top, then left to right, with a row tolerance."""
import pytest

from vision_pkg.ordering import picking_order


def test_empty():
    assert picking_order([], 10.0) == []


def test_bottom_row_first_then_left_to_right():
    # image coordinates (u right, v down): two rows
    pts = [(500, 100), (100, 400), (300, 105), (400, 395), (50, 110)]
    assert picking_order(pts, 20.0) == [1, 3, 4, 2, 0]


def test_tolerance_decides_rows():
    pts = [(300, 400), (100, 370)]      # 30 px apart vertically
    assert picking_order(pts, 40.0) == [1, 0]    # one row: left first
    assert picking_order(pts, 20.0) == [0, 1]    # two rows: lower first


def test_staggered_chain_does_not_become_one_row():
    # each fruit 15 px above the previous: rows are anchored at their lowest fruit
    pts = [(i * 50, 500 - i * 15) for i in range(6)]
    order = picking_order(pts, 20.0)
    assert order == [0, 1, 2, 3, 4, 5]
    pts_rev = [(300 - i * 50, 500 - i * 15) for i in range(6)]
    # rows {0,1}, {2,3}, {4,5}; within each row left (smaller u) first
    assert picking_order(pts_rev, 20.0) == [1, 0, 3, 2, 5, 4]


def test_ties_are_deterministic():
    pts = [(100, 200), (100, 200), (50, 200)]
    assert picking_order(pts, 0.0) == [2, 0, 1]


def test_negative_tolerance_rejected():
    with pytest.raises(ValueError):
        picking_order([(0, 0)], -1.0)


def test_inside_image_rejects_fruit_cut_by_the_border():
    from vision_pkg.ordering import inside_image
    assert inside_image(100, 100, 50, 640, 480, 4)
    assert not inside_image(28, 455, 48, 1024, 768, 4)       # cut by the left border
    assert not inside_image(600, 240, 40, 640, 480, 4)       # cut by the right border
    assert not inside_image(320, 470, 20, 640, 480, 4)       # cut by the bottom


def test_servo_follows_the_fruit_the_target_projects_onto_not_a_neighbour():
    from vision_pkg.ordering import servo_target
    centres, radii = [(300.0, 200.0), (120.0, 210.0)], [150.0, 60.0]
    assert servo_target(centres, radii, (310.0, 190.0)) == 0
    # the held fruit is not seen in this frame: the nearest neighbour does not hold the
    # target's projection, so nothing is followed (the servo counts the frame as lost)
    assert servo_target(centres[1:], radii[1:], (310.0, 190.0)) is None
    assert servo_target(centres[1:], radii[1:], (310.0, 190.0), on_fruit=False) == 0
    # of two fruit holding the projection, the nearer one
    assert servo_target([(300.0, 200.0), (330.0, 190.0)], [150.0, 150.0], (325.0, 190.0)) == 1
    assert servo_target([], [], (0.0, 0.0)) is None
