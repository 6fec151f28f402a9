"""The mission summary is strict JSON and the mission id is never `mission-0` (issue 14)."""
import json

import pytest
from hypothesis import given, settings, strategies as st

from control_pkg import mission


def test_summary_of_a_mission_that_picked_nothing_is_strict_json():
    r = mission.MissionRecorder('m0')
    r.start(0.0)
    r.begin_fruit(0, 1, (0.5, 0.0, 0.9), 1.0)
    r.end_fruit(mission.OUTCOME_UNREACHABLE, 2.0, 'beyond reach')
    totals = r.totals()                      # not finished: no duration either
    json.dumps(totals, allow_nan=False)      # raised ValueError while the mean cycle was NaN
    assert totals['mean_cycle_time'] is None and totals['duration'] is None
    text = mission.summary_json(dict(totals, outcome='succeeded', last_error=''))
    assert 'NaN' not in text
    decoded = json.loads(text)
    assert decoded['mean_cycle_time'] is None and decoded['unreachable'] == 1


def test_summary_json_keeps_finite_numbers_and_nulls_the_rest():
    totals = {'picked': 2, 'mean_cycle_time': 12.5, 'duration': float('inf'),
              'nested': [float('nan'), 1.0, {'x': float('-inf')}], 'ok': True, 'what': object()}
    decoded = json.loads(mission.summary_json(totals))
    assert decoded['picked'] == 2 and decoded['mean_cycle_time'] == 12.5 and decoded['ok'] is True
    assert decoded['duration'] is None
    assert decoded['nested'] == [None, 1.0, {'x': None}]
    assert isinstance(decoded['what'], str)


@settings(deadline=None)
@given(st.dictionaries(st.text(max_size=5),
                       st.recursive(st.one_of(st.floats(), st.integers(), st.text(max_size=5),
                                              st.none(), st.booleans()),
                                    lambda c: st.one_of(st.lists(c, max_size=3),
                                                        st.dictionaries(st.text(max_size=3), c,
                                                                        max_size=3)),
                                    max_leaves=10), max_size=5))
def test_summary_json_is_always_strict(totals):
    text = mission.summary_json(totals)
    json.loads(text, parse_constant=lambda name: pytest.fail('non-strict constant %s' % name))


def test_mission_id_from_the_wall_clock_is_never_mission_0():
    # under /use_sim_time, ROS time is 0 before the first /clock: the id was 'mission-0'
    assert mission.make_mission_id(1716279330.0, '3fa9') == 'mission-20240521T081530Z-3fa9'
    assert mission.make_mission_id(1716279330.0, '3fa9') != mission.make_mission_id(1716279330.0,
                                                                                      '3fa8')
    for bad in (0.0, -1.0, float('nan'), float('inf'), None):
        with pytest.raises(ValueError):
            mission.make_mission_id(bad, '3fa9')
    with pytest.raises(ValueError):
        mission.make_mission_id(1716279330.0, '')


@settings(deadline=None)
@given(st.floats(1.0, 4.0e9), st.text('0123456789abcdef', min_size=1, max_size=8))
def test_mission_ids_are_readable_and_ordered_by_start(wall, token):
    mid = mission.make_mission_id(wall, token)
    assert mid.startswith('mission-') and mid != 'mission-0' and mid.endswith('-' + token)
    stamp = len('mission-YYYYmmddTHHMMSSZ')
    assert mission.make_mission_id(wall + 1.0, token)[:stamp] > mid[:stamp]   # a second later
