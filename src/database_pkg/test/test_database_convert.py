"""Unit tests of database_pkg.convert (message classes only, no ROS master)."""
import math

import pytest

harvest_msgs = pytest.importorskip('harvest_msgs.msg', reason='harvest_msgs not built/sourced')

import genpy  # noqa: E402
from harvest_msgs.msg import (Checkpoint, MissionEvent, PickRecord, SpatialTemporalGoal,  # noqa: E402
                              Tomato, TomatoArray)
from geometry_msgs.msg import Point  # noqa: E402

from database_pkg import convert  # noqa: E402
from database_pkg.store import Store  # noqa: E402


def tomato_array(points, pickable):
    arr = TomatoArray(image_id='img-7')
    arr.header.stamp = genpy.Time(7, 500000000)
    arr.header.frame_id = 'stereo_frame'
    for i, (p, ok) in enumerate(zip(points, pickable)):
        t = Tomato(id=i, radius=0.03, ripeness_stage=3 if ok else 0,
                   ripeness_score=0.9 if ok else 0.1, pickable=ok, pick_order=i if ok else -1)
        t.pick_point.point.x, t.pick_point.point.y, t.pick_point.point.z = p
        t.pick_point.header.frame_id = 'base_link' if i == 0 else ''
        arr.tomatoes.append(t)
    return arr


def test_observations_from_tomatoes():
    nan = (math.nan,) * 3
    obs = convert.observations_from_tomatoes(tomato_array([(0.5, 0.0, 0.9), nan],
                                                          [True, False]))
    assert obs[0]['position'] == (0.5, 0.0, 0.9) and obs[0]['frame_id'] == 'base_link'
    assert obs[1]['position'] is None and obs[1]['frame_id'] == 'stereo_frame'
    assert all(o['stamp'] == 7.5 and o['image_id'] == 'img-7' for o in obs)
    with Store(':memory:') as s:
        assert len(s.add_observations('m', 0, 0.0, obs)) == 2


def test_pickable_tomato_without_point_is_rejected():
    obs = convert.observations_from_tomatoes(tomato_array([(math.nan, 0.0, 0.9)], [True]))
    with Store(':memory:') as s:
        with pytest.raises(ValueError, match='finite'):
            s.add_observations('m', 0, 0.0, obs)
        assert s.row_counts()['observations'] == 0


def test_pick_record_and_event_round_trip():
    msg = PickRecord(mission_id='m', picking_point=1, target_id=4, outcome=PickRecord.OUTCOME_LOST,
                     reason='lost in servo', state_names=['DO_VISUALSERVOING'],
                     state_durations=[3.25], cycle_time=3.25, stamp=genpy.Time(12, 250000000))
    msg.pick_point.header.frame_id = 'base_link'
    msg.pick_point.point.x = 0.45
    ev = MissionEvent(mission_id='m', stamp=genpy.Time(11), kind='fault', state='DO_MOVE_ROBOT',
                      detail='axis 3 alarm')
    with Store(':memory:') as s:
        s.add_pick_record(convert.pick_record_to_dict(msg))
        s.add_event(convert.event_to_dict(ev))
        _, records, events = s.mission_records('m')
    back = convert.pick_record_from_dict(records[0])
    assert back.stamp == msg.stamp
    back.pick_point.header.stamp = genpy.Time()
    assert back == msg
    assert convert.event_from_dict(events[0]) == ev


@pytest.mark.parametrize('goal, problem', [
    (SpatialTemporalGoal(mission_id='m', picking_point=0, track_position=0.0), None),
    (SpatialTemporalGoal(mission_id='', picking_point=0, track_position=0.0), 'mission_id'),
    (SpatialTemporalGoal(mission_id='m', picking_point=-1, track_position=0.0), 'picking_point'),
    (SpatialTemporalGoal(mission_id='m', picking_point=0, track_position=math.nan),
     'track_position'),
])
def test_check_spatial_temporal_goal(goal, problem):
    result = convert.check_spatial_temporal_goal(goal)
    if problem is None:
        assert result is None
    else:
        assert problem in result


def test_checkpoint_round_trip_through_the_store(tmp_path):
    msg = Checkpoint(mission_id='m-cp', robot='r1', stamp=genpy.Time(12, 0), points=[3, 1],
                     point_index=0, picking_point=3, targets_done=[5, 6],
                     done_positions=[Point(0.5, 0.1, 0.9), Point(0.6, 0.0, 1.0)], target_id=7,
                     target_position=Point(0.55, -0.05, 0.95), phase='cut', holding=True)
    with Store(str(tmp_path / 'cp.db')) as s:
        s.put_checkpoint(convert.checkpoint_to_dict(msg))
        assert convert.checkpoint_from_dict(s.latest_unfinished_checkpoint('r1')) == msg
        between = Checkpoint(mission_id='m-cp', robot='r1', stamp=genpy.Time(13, 0), points=[3, 1],
                             point_index=1, picking_point=1, target_id=-1)
        between.target_position = Point(9.0, 9.0, 9.0)        # ignored without a target
        s.put_checkpoint(convert.checkpoint_to_dict(between))
        back = convert.checkpoint_from_dict(s.checkpoint('m-cp'))
        assert back.target_id == -1 and back.target_position == Point()


def test_checkpoint_with_mismatched_done_lists_is_rejected():
    msg = Checkpoint(mission_id='m', targets_done=[1], done_positions=[])
    with pytest.raises(ValueError, match='done_positions'):
        convert.checkpoint_to_dict(msg)
