"""Conversions between harvest_msgs messages and the store's dicts (no rospy here).

Only message classes (genpy) are used, so this module is testable without a ROS master.
"""

import math

import genpy
from geometry_msgs.msg import Point, PointStamped
from harvest_msgs.msg import Checkpoint, MissionEvent, PickRecord

__all__ = ['observations_from_tomatoes', 'pick_record_to_dict', 'pick_record_from_dict',
           'event_to_dict', 'event_from_dict', 'check_spatial_temporal_goal',
           'checkpoint_to_dict', 'checkpoint_from_dict']


def _sec(stamp):
    return stamp.to_sec()


def _time(seconds):
    return genpy.Time.from_sec(float(seconds))


def _xyz(point):
    return (point.x, point.y, point.z)


def check_spatial_temporal_goal(goal):
    """None if a SpatialTemporal goal is usable, else the reason why not."""
    if not goal.mission_id:
        return 'mission_id is empty'
    if goal.picking_point < 0:
        return 'picking_point must be >= 0, got %d' % goal.picking_point
    if not math.isfinite(goal.track_position):
        return 'track_position must be finite, got %r' % goal.track_position
    return None


def observations_from_tomatoes(tomato_array):
    """Store dicts for every tomato of a harvest_msgs/TomatoArray.

    A tomato that is not pickable and has a non-finite 3D point is stored without a position
    (None): the vision node marks fruit without a valid 3D point that way. A pickable tomato
    with a non-finite point is passed through as is and makes the store raise ValueError.
    The observation time is the tomato's point stamp, or the image stamp if that is zero.
    """
    image_stamp = _sec(tomato_array.header.stamp)
    result = []
    for tomato in tomato_array.tomatoes:
        point = tomato.pick_point
        position = _xyz(point.point)
        if not tomato.pickable and not all(math.isfinite(v) for v in position):
            position = None
        stamp = _sec(point.header.stamp) or image_stamp
        result.append({
            'detection_id': tomato.id,
            'position': position,
            'frame_id': point.header.frame_id or tomato_array.header.frame_id,
            'radius': tomato.radius,
            'ripeness_stage': tomato.ripeness_stage,
            'ripeness_score': tomato.ripeness_score,
            'pickable': tomato.pickable,
            'pick_order': tomato.pick_order,
            'stamp': stamp,
            'image_id': tomato_array.image_id,
        })
    return result


def pick_record_to_dict(msg):
    return {
        'mission_id': msg.mission_id,
        'picking_point': msg.picking_point,
        'target_id': msg.target_id,
        'position': _xyz(msg.pick_point.point),
        'frame_id': msg.pick_point.header.frame_id,
        'outcome': msg.outcome,
        'reason': msg.reason,
        'state_names': list(msg.state_names),
        'state_durations': list(msg.state_durations),
        'cycle_time': msg.cycle_time,
        'stamp': _sec(msg.stamp),
    }


def pick_record_from_dict(row):
    """A PickRecord from a store row; pick_point.header.stamp is the record's stamp."""
    msg = PickRecord()
    msg.mission_id = row['mission_id']
    msg.picking_point = row['picking_point']
    msg.target_id = row['target_id']
    msg.pick_point = PointStamped()
    msg.pick_point.header.frame_id = row['frame_id']
    msg.pick_point.header.stamp = _time(row['stamp'])
    msg.pick_point.point.x, msg.pick_point.point.y, msg.pick_point.point.z = row['position']
    msg.outcome = row['outcome']
    msg.reason = row['reason']
    msg.state_names = list(row['state_names'])
    msg.state_durations = list(row['state_durations'])
    msg.cycle_time = row['cycle_time']
    msg.stamp = _time(row['stamp'])
    return msg


def event_to_dict(msg):
    return {
        'mission_id': msg.mission_id,
        'stamp': _sec(msg.stamp),
        'kind': msg.kind,
        'state': msg.state,
        'detail': msg.detail,
    }


def event_from_dict(row):
    return MissionEvent(mission_id=row['mission_id'], stamp=_time(row['stamp']), kind=row['kind'],
                        state=row['state'], detail=row['detail'])


def checkpoint_to_dict(msg):
    """A harvest_msgs/Checkpoint as the store's dict (Store.put_checkpoint)."""
    if len(msg.targets_done) != len(msg.done_positions):
        raise ValueError('checkpoint: %d targets_done but %d done_positions'
                         % (len(msg.targets_done), len(msg.done_positions)))
    return {
        'mission_id': msg.mission_id,
        'robot': msg.robot,
        'stamp': _sec(msg.stamp),
        'points': list(msg.points),
        'point_index': msg.point_index,
        'picking_point': msg.picking_point,
        'targets_done': [(t, _xyz(p)) for t, p in zip(msg.targets_done, msg.done_positions)],
        'target_id': msg.target_id,
        'target_position': _xyz(msg.target_position) if msg.target_id >= 0 else None,
        'phase': msg.phase,
        'holding': bool(msg.holding),
        'finished': bool(msg.finished),
        'outcome': msg.outcome,
    }


def checkpoint_from_dict(row):
    """The store's checkpoint dict as a harvest_msgs/Checkpoint."""
    msg = Checkpoint(mission_id=row['mission_id'], robot=row['robot'], stamp=_time(row['stamp']),
                     points=list(row['points']), point_index=row['point_index'],
                     picking_point=row['picking_point'], target_id=row['target_id'],
                     phase=row['phase'], holding=bool(row['holding']),
                     finished=bool(row['finished']), outcome=row['outcome'])
    msg.targets_done = [int(t) for t, _ in row['targets_done']]
    msg.done_positions = [Point(*p) for _, p in row['targets_done']]
    if row['target_position'] is not None:
        msg.target_position = Point(*row['target_position'])
    return msg
