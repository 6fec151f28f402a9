"""Goals of the image_processing and tomato_scan actions and what they answer, rospy-free.

How a goal ends (Aborted, Cancelled, the RunningGoal flag), the check of its min_ripeness, the
SPATIAL_POSITIONING result built from the detections and their 3D points (which fruit are
pickable, the picking order, the TomatoArray), the result texts, and the SERVO_FEATURE target
geometry in the hand camera (sphere-centre projection, reference point of the target hint).
The node (image_processing_node.py, hand_camera.py) gets the data and wires these in;
test/test_image_processing_goals.py checks them without a master.
"""
import math
import threading

import cv2
import numpy as np
from harvest_msgs.msg import Tomato, TomatoArray

from vision_pkg import localisation, names, ordering


class Aborted(Exception):
    """A goal cannot be served; the message goes into the result."""


class Cancelled(Exception):
    """The client cancelled the goal."""


#: s: in simulated time (one /clock for every node) a goal's request stamp ahead of this node's
#: clock is its clock lagging; only a lead beyond this is taken for another time base
SIM_MAX_REQUEST_LEAD = 30.0


def fresh_since(arrival, requested, max_lead):
    """(time, skewed): data for a goal count as fresh from this stamp on. That is the goal's
    request stamp (actionlib's goal_id.stamp: the client's clock when it sent the goal) when it
    is later than the goal's arrival (this node's clock, which in simulated time lags the
    client's while a busy process works through its /clock backlog: an image taken before the
    client's last move then passed as fresh). A zero stamp (not set), or one more than max_lead
    ahead of the arrival (clocks of two machines apart: skewed=True), counts from the arrival.
    Times and durations are rospy's (genpy's)."""
    if requested.is_zero() or not requested > arrival:
        return arrival, False
    if requested - arrival > max_lead:
        return arrival, True
    return requested, False


class RunningGoal(object):
    """Cancellation flag of one running goal."""

    def __init__(self):
        self.cancelled = threading.Event()


def stamp_id(stamp):
    """image_id of the stereo pair taken at `stamp`."""
    return 'stereo_right_%d.%09d' % (stamp.secs, stamp.nsecs)


# -- SPATIAL_POSITIONING ----------------------------------------------------------------------
def ripeness_threshold(min_ripeness, default):
    """Ripeness score a pickable fruit needs: the goal's min_ripeness when > 0, else `default`
    (~min_ripeness). Aborted for NaN or above 1."""
    if isinstance(min_ripeness, float) and math.isnan(min_ripeness):
        raise Aborted('min_ripeness is NaN')
    if min_ripeness > 1.0:
        raise Aborted('min_ripeness %.3f is above 1 (scores are 0..1)' % min_ripeness)
    return min_ripeness if min_ripeness > 0.0 else default


def plausible_fruit(det, loc, width, height, min_radius, max_radius, margin_px):
    """True when a located detection can be picked from here: its fitted sphere has a tomato's
    size (leaves and stems do not) and its circle is not cut by the image border (such a fruit
    has a wrong circle and 3D point: it is picked from the next point)."""
    return (loc is not None and min_radius <= loc.radius <= max_radius
            and ordering.inside_image(det.u, det.v, det.radius_px, width, height, margin_px))


def picking_sequence(entries, row_tolerance):
    """Indices of `entries` [(detection, location, point, pickable), ...] as the TomatoArray
    lists them: the pickable ones in picking order (ordering.picking_order), then the others
    by falling ripeness score."""
    pickable = [i for i, e in enumerate(entries) if e[3]]
    order = ordering.picking_order([(entries[i][0].u, entries[i][0].v) for i in pickable],
                                   row_tolerance)
    ordered = [pickable[k] for k in order]
    rest = sorted((i for i, e in enumerate(entries) if not e[3]),
                  key=lambda i: -entries[i][0].score)
    return ordered + rest


def tomato_array(image_header, width, height, entries, sequence, frame, cloud_stamp):
    """TomatoArray of the right image (`image_header`, `width` x `height`) listing `entries` in
    `sequence` (picking_sequence): id and pick_order are the rank (pick_order -1 when not
    pickable); a fruit without a 3D point has a NaN pick point in `frame` at `cloud_stamp`."""
    array = TomatoArray()
    array.header = image_header
    array.image_id = stamp_id(image_header.stamp)
    for rank, index in enumerate(sequence):
        det, loc, point, is_pickable = entries[index]
        tomato = Tomato()
        tomato.id = rank
        x, y, w, h = det.box(width, height)
        tomato.box.x_offset, tomato.box.y_offset = x, y
        tomato.box.width, tomato.box.height = w, h
        if point is not None:
            tomato.pick_point = point
            tomato.radius = loc.radius
        else:
            tomato.pick_point.header.frame_id = frame
            tomato.pick_point.header.stamp = cloud_stamp
            tomato.pick_point.point.x = float('nan')
            tomato.pick_point.point.y = float('nan')
            tomato.pick_point.point.z = float('nan')
        tomato.ripeness_stage = det.stage
        tomato.ripeness_score = det.score
        tomato.pickable = is_pickable
        tomato.pick_order = rank if is_pickable else -1
        array.tomatoes.append(tomato)
    return array


def pickable_count(tomatoes):
    """Number of pickable fruit in a TomatoArray."""
    return sum(1 for t in tomatoes.tomatoes if t.pickable)


def positioning_message(tomatoes):
    """Result text of a SPATIAL_POSITIONING goal."""
    return '%d tomatoes, %d pickable' % (len(tomatoes.tomatoes), pickable_count(tomatoes))


def scan_message(picking_point, tomatoes, pickable):
    """Result text of a tomato_scan goal."""
    return 'picking point %d: %d tomatoes, %d pickable' % (
        picking_point, len(tomatoes.tomatoes), pickable)


# -- SERVO_FEATURE ----------------------------------------------------------------------------
def servo_message(feature):
    """Result text of a SERVO_FEATURE goal."""
    return 'target found' if feature.found else 'no tomato in the hand camera image'


def camera_model(info):
    """(K 3x3, distortion) of the hand camera's camera_info; Aborted without intrinsics."""
    k = np.array(info.K, dtype=np.float64).reshape(3, 3)
    dist = np.array(info.D, dtype=np.float64) if len(info.D) else np.zeros(5)
    if k[0, 0] <= 0.0:
        raise Aborted('%s has no intrinsics (K is zero)' % names.HAND_CAMERA_INFO)
    return k, dist


def undistorted_centre(det, k, dist):
    """(u, v, x, y): projection of the sphere centre (not the silhouette centre)."""
    pts = cv2.undistortPoints(np.array([[[det.u, det.v]]], dtype=np.float64), k, dist)
    x, y = pts.reshape(2)
    fx, fy = k[0, 0], k[1, 1]
    axis, _ = localisation.sphere_ray(x * fx, y * fy, det.radius_px, fx, fy, 0.0, 0.0)
    xn, yn = axis[0] / axis[2], axis[1] / axis[2]
    proj, _ = cv2.projectPoints(np.array([[[xn, yn, 1.0]]]), np.zeros(3), np.zeros(3), k,
                                dist)
    u, v = proj.reshape(2)
    return float(u), float(v), float(xn), float(yn)


def servo_reference(hint_point, k, dist):
    """(ref, depth): the image point the servo target is chosen by and the hint's depth.
    hint_point: the target hint in the camera's optical frame (None without a hint); in front
    of the camera it projects to ref, else ref is the principal point and depth None."""
    if hint_point is not None and hint_point.z > 0.0:
        p = np.array([hint_point.x, hint_point.y, hint_point.z])
        ref, _ = cv2.projectPoints(p.reshape(1, 1, 3), np.zeros(3), np.zeros(3), k, dist)
        return ref.reshape(2), float(hint_point.z)
    return np.array([k[0, 2], k[1, 2]]), None
