"""image_processing results without a master: min_ripeness check, pickable fruit, picking
sequence, TomatoArray, result texts, servo target geometry and the rviz markers."""
import math

import genpy
import numpy as np
import pytest
from geometry_msgs.msg import Point, PointStamped
from harvest_msgs.msg import ServoFeature
from sensor_msgs.msg import CameraInfo
from std_msgs.msg import Header
from visualization_msgs.msg import Marker

from vision_pkg import image_processing_goals as goals
from vision_pkg.fruit import STAGE_GREEN, STAGE_RED, Detection
from vision_pkg.localisation import FruitLocation
from vision_pkg.markers import tomato_markers

WIDTH, HEIGHT = 1024, 768
FX, FY, CX, CY = 800.0, 800.0, 320.0, 240.0


def located(radius=0.03):
    return FruitLocation((0.0, 0.0, 0.5), radius, 100, (0.0, 0.0, 0.47))


def point(x, y, z, frame='base_link'):
    ps = PointStamped()
    ps.header.frame_id = frame
    ps.point.x, ps.point.y, ps.point.z = x, y, z
    return ps


def hand_info(k=(FX, 0.0, CX, 0.0, FY, CY, 0.0, 0.0, 1.0), d=()):
    info = CameraInfo()
    info.K = list(k)
    info.D = list(d)
    return info


# -- goals ----------------------------------------------------------------------------------
def test_ripeness_threshold_goal_value_or_default():
    assert goals.ripeness_threshold(0.5, 0.7) == 0.5
    assert goals.ripeness_threshold(0.0, 0.7) == 0.7
    assert goals.ripeness_threshold(-1.0, 0.7) == 0.7
    assert goals.ripeness_threshold(1.0, 0.7) == 1.0


def test_ripeness_threshold_aborts_nan_and_above_one():
    with pytest.raises(goals.Aborted, match='min_ripeness is NaN'):
        goals.ripeness_threshold(float('nan'), 0.7)
    with pytest.raises(goals.Aborted) as exc:
        goals.ripeness_threshold(1.5, 0.7)
    assert str(exc.value) == 'min_ripeness 1.500 is above 1 (scores are 0..1)'


def test_running_goal_starts_not_cancelled():
    state = goals.RunningGoal()
    assert not state.cancelled.is_set()
    state.cancelled.set()
    assert state.cancelled.is_set()


def test_stamp_id():
    assert goals.stamp_id(genpy.Time(12, 3400)) == 'stereo_right_12.000003400'


# -- SPATIAL_POSITIONING --------------------------------------------------------------------
def test_plausible_fruit_size_and_border():
    det = Detection(500, 400, 40, 0.9)
    args = (WIDTH, HEIGHT, 0.018, 0.055, 4.0)
    assert goals.plausible_fruit(det, located(0.03), *args)
    assert not goals.plausible_fruit(det, None, *args)
    assert not goals.plausible_fruit(det, located(0.01), *args)     # a leaf's size
    assert not goals.plausible_fruit(det, located(0.08), *args)
    cut = Detection(30, 400, 40, 0.9)                                  # over the left border
    assert not goals.plausible_fruit(cut, located(0.03), *args)


def test_picking_sequence_pickable_in_order_then_by_score():
    entries = [
        (Detection(300, 100, 30, 0.9), None, None, True),     # top row
        (Detection(100, 100, 30, 0.3), None, None, False),
        (Detection(500, 600, 30, 0.8), None, None, True),     # bottom row, right
        (Detection(200, 610, 30, 0.95), None, None, True),    # bottom row, left
        (Detection(700, 300, 30, 0.6), None, None, False),
    ]
    assert goals.picking_sequence(entries, 40.0) == [3, 2, 0, 4, 1]
    assert goals.picking_sequence([], 40.0) == []


def test_tomato_array_ranks_points_and_nan():
    header = Header(stamp=genpy.Time(5, 6), frame_id='stereo_right_optical')
    ripe = Detection(500, 600, 30, 0.9)
    green = Detection(200, 100, 25, 0.1)
    entries = [(green, None, None, False),
               (ripe, located(0.031), point(0.4, -0.1, 0.9), True)]
    array = goals.tomato_array(header, WIDTH, HEIGHT, entries, [1, 0], 'base_link',
                               genpy.Time(5, 7))
    assert array.header.frame_id == 'stereo_right_optical'
    assert array.image_id == 'stereo_right_5.000000006'
    first, second = array.tomatoes
    assert (first.id, first.pick_order, first.pickable) == (0, 0, True)
    assert first.pick_point.point.x == 0.4 and first.radius == pytest.approx(0.031)
    assert first.ripeness_stage == STAGE_RED and first.ripeness_score == pytest.approx(0.9)
    assert (first.box.x_offset, first.box.y_offset, first.box.width, first.box.height) == \
        ripe.box(WIDTH, HEIGHT)
    assert (second.id, second.pick_order, second.pickable) == (1, -1, False)
    assert second.ripeness_stage == STAGE_GREEN
    assert second.pick_point.header.frame_id == 'base_link'
    assert second.pick_point.header.stamp == genpy.Time(5, 7)
    assert all(math.isnan(c) for c in (second.pick_point.point.x, second.pick_point.point.y,
                                       second.pick_point.point.z))
    assert second.radius == 0.0


def test_result_texts():
    header = Header(stamp=genpy.Time(1, 0))
    entries = [(Detection(500, 600, 30, 0.9), located(), point(0.4, 0.0, 0.9), True),
               (Detection(200, 100, 25, 0.1), None, None, False)]
    array = goals.tomato_array(header, WIDTH, HEIGHT, entries, [0, 1], 'base_link',
                               genpy.Time(1, 0))
    assert goals.pickable_count(array) == 1
    assert goals.positioning_message(array) == '2 tomatoes, 1 pickable'
    assert goals.scan_message(3, array, 1) == 'picking point 3: 2 tomatoes, 1 pickable'
    feature = ServoFeature()
    assert goals.servo_message(feature) == 'no tomato in the hand camera image'
    feature.found = True
    assert goals.servo_message(feature) == 'target found'


# -- SERVO_FEATURE --------------------------------------------------------------------------
def test_camera_model():
    k, dist = goals.camera_model(hand_info())
    assert k.shape == (3, 3) and k[0, 2] == CX
    assert np.array_equal(dist, np.zeros(5))
    _, dist = goals.camera_model(hand_info(d=(0.1, -0.02, 0.0, 0.0, 0.0)))
    assert dist[0] == pytest.approx(0.1)
    with pytest.raises(goals.Aborted, match='hand_eye/camera_info has no intrinsics'):
        goals.camera_model(hand_info(k=(0.0,) * 9))


def test_undistorted_centre_on_axis_and_off_axis():
    k, dist = goals.camera_model(hand_info())
    u, v, x, y = goals.undistorted_centre(Detection(CX, CY, 60, 0.9), k, dist)
    assert (u, v) == pytest.approx((CX, CY), abs=1e-6) and (x, y) == pytest.approx((0, 0))
    # off axis the sphere centre projects inward of the silhouette centre, on the same ray
    det = Detection(CX + 200, CY, 80, 0.9)
    u, v, x, y = goals.undistorted_centre(det, k, dist)
    assert CX < u < det.u and v == pytest.approx(CY, abs=1e-6)
    assert (u, v) == pytest.approx((FX * x + CX, FY * y + CY), abs=1e-6)


def test_servo_reference_hint_or_principal_point():
    k, dist = goals.camera_model(hand_info())
    ref, depth = goals.servo_reference(None, k, dist)
    assert list(ref) == [CX, CY] and depth is None
    ref, depth = goals.servo_reference(Point(0.01, 0.02, -0.5), k, dist)   # behind the camera
    assert list(ref) == [CX, CY] and depth is None
    ref, depth = goals.servo_reference(Point(0.01, 0.02, 0.5), k, dist)
    assert ref == pytest.approx((CX + FX * 0.02, CY + FY * 0.04)) and depth == 0.5


# -- markers --------------------------------------------------------------------------------
def test_tomato_markers_sphere_and_text_per_located_fruit():
    header = Header(stamp=genpy.Time(2, 0))
    entries = [(Detection(500, 600, 30, 0.9), located(0.03), point(0.4, 0.0, 0.9), True),
               (Detection(300, 500, 30, 0.5), located(0.002), point(0.3, 0.1, 0.8), False),
               (Detection(200, 100, 25, 0.1), None, None, False)]
    array = goals.tomato_array(header, WIDTH, HEIGHT, entries, [0, 1, 2], 'base_link',
                               genpy.Time(2, 0))
    markers = tomato_markers(array, 'base_link').markers
    assert markers[0].action == Marker.DELETEALL
    assert len(markers) == 5            # no marker for the fruit without a 3D point
    sphere, text = markers[1], markers[2]
    assert (sphere.ns, sphere.id, sphere.type) == ('tomatoes', 0, Marker.SPHERE)
    assert sphere.header.frame_id == 'base_link' and sphere.header.stamp == genpy.Time(2, 0)
    assert sphere.scale.x == pytest.approx(0.06) and sphere.color.a == pytest.approx(0.9)
    assert (text.ns, text.text) == ('pick_order', '#1')
    assert text.pose.position.z == pytest.approx(0.9 + 0.03 + 0.02)
    assert markers[3].scale.x == pytest.approx(0.01)      # at least a 5 mm radius
    assert markers[4].text == '0.50'


def test_fresh_since_takes_the_later_of_arrival_and_request():
    arrival, lead = genpy.Time(100, 0), genpy.Duration(2.0)
    # a client whose clock is ahead (this node's /clock lags): data from its request on
    assert goals.fresh_since(arrival, genpy.Time(100, 600000000), lead) == (
        genpy.Time(100, 600000000), False)
    # a request stamped before its arrival (the usual case): from the arrival
    assert goals.fresh_since(arrival, genpy.Time(99, 0), lead) == (arrival, False)
    # no stamp set by the client
    assert goals.fresh_since(arrival, genpy.Time(0, 0), lead) == (arrival, False)
    # further ahead than max_lead: clocks apart, not a lag; from the arrival, flagged
    assert goals.fresh_since(arrival, genpy.Time(103, 0), lead) == (arrival, True)
    assert goals.fresh_since(arrival, genpy.Time(102, 0), lead) == (genpy.Time(102, 0), False)
    # simulated time: a /clock lagging 3.4 s (seen under a 1-core CPU quota) is a lag, not skew
    sim_lead = genpy.Duration(goals.SIM_MAX_REQUEST_LEAD)
    assert goals.fresh_since(arrival, genpy.Time(103, 400000000), sim_lead) == (
        genpy.Time(103, 400000000), False)
    assert goals.fresh_since(arrival, genpy.Time(131, 0), sim_lead) == (arrival, True)


def test_node_module_keeps_its_names():
    pytest.importorskip('rospy')
    pytest.importorskip('actionlib')
    from vision_pkg import image_processing_node as node
    for name in ('ImageProcessingNode', 'Aborted', 'Cancelled', 'BUFF_SIZE', 'IMAGE_HISTORY',
                 'WAIT_POLL', 'RATE_TOLERANCE', 'HAND_DETECTOR_DEFAULTS', '_Goal', '_stamp_id',
                 '_NoRateCheck', '_detector_params'):
        assert hasattr(node, name), name
    assert node.Aborted is goals.Aborted
    for name in ('servo_feature', 'spatial_positioning', '_undistorted_centre',
                 '_publish_visuals', '_setup_diagnostics', '_hand_data'):
        assert hasattr(node.ImageProcessingNode, name), name
