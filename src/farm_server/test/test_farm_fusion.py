"""Fusion, ripening model, plans and yields of the farm server (pure Python, no server)."""
import datetime

import pytest

from farm_server import fusion
from farm_server.fusion import DAY, FusionConfig, fuse

T0 = 1.75e9                      # a calendar time (ROS stamps from a robot on wall time)
DAY0 = fusion.day_of(T0, FusionConfig())


def mission(robot, mission_id, site='row1', started=T0):
    return dict(robot=robot, mission_id=mission_id, site=site, started=started, created=started,
                revision=1)


_counter = [0]


def obs(robot, mission_id, point, track, xyz, score, t, frame='base_link'):
    _counter[0] += 1
    x, y, z = xyz if xyz is not None else (None, None, None)
    return dict(id='%032x' % _counter[0], robot=robot, mission_id=mission_id,
                picking_point=point, track_position=track, x=x, y=y, z=z, frame_id=frame,
                ripeness_stage=3 if score >= 0.7 else 0, ripeness_score=score, stamp=t,
                created=t + 1.0)


def pick(robot, mission_id, point, xyz, t, outcome=0, cycle_time=30.0):
    _counter[0] += 1
    return dict(id='%032x' % _counter[0], robot=robot, mission_id=mission_id,
                picking_point=point, x=xyz[0], y=xyz[1], z=xyz[2], frame_id='base_link',
                outcome=outcome, cycle_time=cycle_time, stamp=t, created=t + 1.0)


def only_row(state, row='row1'):
    return state.rows[row]


def test_same_fruit_matched_across_robots_and_days_within_tolerance():
    ms = [mission('a', 'a1'), mission('b', 'b1', started=T0 + DAY)]
    observations = [
        obs('a', 'a1', 0, 1.0, (0.5, 0.10, 0.9), 0.3, T0),
        obs('b', 'b1', 0, 1.0, (0.52, 0.11, 0.91), 0.45, T0 + DAY),    # 2.4 cm away: same
        obs('b', 'b1', 0, 1.0, (0.5, -0.10, 0.9), 0.2, T0 + DAY),      # a new fruit
    ]
    state = fuse(ms, observations, [], FusionConfig(match_tolerance=0.05))
    fruits = only_row(state).fruits
    assert len(fruits) == 2
    first = [f for f in fruits if len(f.history) == 2][0]
    assert [h[3] for h in first.history] == ['a', 'b']
    assert [h[1] for h in first.history] == [0.3, 0.45]
    # a tighter tolerance splits them
    state = fuse(ms, observations, [], FusionConfig(match_tolerance=0.02))
    assert len(only_row(state).fruits) == 3


def test_cart_frame_sightings_from_two_points_are_one_fruit_in_the_map():
    # fruit at map y = 1.2: seen from the point at 1.0 (base_link y = +0.2) and at 1.5 (-0.3)
    ms = [mission('a', 'a1')]
    observations = [obs('a', 'a1', 2, 1.0, (0.5, 0.2, 0.9), 0.5, T0),
                    obs('a', 'a1', 3, 1.5, (0.5, -0.3, 0.9), 0.5, T0 + 60),
                    obs('a', 'a1', 3, 1.5, (0.5, 0.0, 0.9), 0.5, T0 + 60, frame='map'),
                    obs('a', 'a1', 3, 1.5, (0.5, 0.0, 0.9), 0.5, T0 + 60, frame='camera'),
                    obs('a', 'a1', 3, 1.5, None, 0.1, T0 + 60)]
    state = fuse(ms, observations, [], FusionConfig())
    fruits = only_row(state).fruits
    assert len(fruits) == 2                    # the map-frame one at y = 0.0 is another fruit
    shared = [f for f in fruits if len(f.history) == 2][0]
    assert shared.position[1] == pytest.approx(1.2)
    assert shared.point == 2                   # nearest picking point along the track
    assert state.skipped == 2                  # unknown frame and no 3D point
    assert only_row(state).points[3].unlocalised == 2


def test_one_to_one_matching_within_a_scan():
    ms = [mission('a', 'a1'), mission('a', 'a2', started=T0 + DAY)]
    observations = [obs('a', 'a1', 0, 0.0, (0.5, 0.0, 0.9), 0.3, T0),
                    obs('a', 'a2', 0, 0.0, (0.5, 0.01, 0.9), 0.4, T0 + DAY),
                    obs('a', 'a2', 0, 0.0, (0.5, -0.02, 0.9), 0.4, T0 + DAY)]
    fruits = only_row(fuse(ms, observations, [], FusionConfig())).fruits
    assert sorted(len(f.history) for f in fruits) == [1, 2]
    matched = [f for f in fruits if len(f.history) == 2][0]
    assert matched.position[1] == pytest.approx(0.01)     # the nearest one was matched


def test_linear_ripening_model_fit_and_forecast():
    cfg = FusionConfig(default_rate=0.07, min_rate=0.01, max_rate=0.3, ripe_score=0.7)
    ms = [mission('a', 'a%d' % d, started=T0 + d * DAY) for d in range(3)]
    observations = [obs('a', 'a0', 0, 0.0, (0.5, 0.0, 0.9), 0.3, T0),
                    obs('a', 'a2', 0, 0.0, (0.5, 0.0, 0.9), 0.5, T0 + 2 * DAY),
                    obs('a', 'a0', 0, 0.0, (0.5, 0.3, 0.9), 0.42, T0)]   # seen once
    state = fuse(ms, observations, [], cfg)
    fitted, single = sorted(only_row(state).fruits, key=lambda f: -len(f.history))
    assert fitted.fitted and fitted.rate == pytest.approx(0.1)
    assert fitted.forecast(T0 + 3 * DAY) == pytest.approx(0.6)
    assert fitted.ready_at(0.7) == pytest.approx(T0 + 4 * DAY)
    assert fitted.forecast(T0) == pytest.approx(0.5)       # never back-cast
    assert not single.fitted and single.rate == pytest.approx(0.07)
    assert single.forecast(T0 + 4 * DAY) == pytest.approx(0.42 + 0.28)
    assert single.ready_at(0.7) == pytest.approx(T0 + 4 * DAY)


def test_fitted_rate_is_clamped_and_short_spans_use_the_default():
    cfg = FusionConfig(min_rate=0.02, max_rate=0.2, min_fit_span_days=0.5)
    ms = [mission('a', 'a0'), mission('a', 'a1', started=T0 + DAY)]
    observations = [  # fading fruit (noise) -> min_rate; far too fast -> max_rate
        obs('a', 'a0', 0, 0.0, (0.5, 0.0, 0.9), 0.5, T0),
        obs('a', 'a1', 0, 0.0, (0.5, 0.0, 0.9), 0.45, T0 + DAY),
        obs('a', 'a0', 0, 0.0, (0.5, 0.2, 0.9), 0.1, T0),
        obs('a', 'a1', 0, 0.0, (0.5, 0.2, 0.9), 0.9, T0 + DAY),
        obs('a', 'a0', 0, 0.0, (0.5, -0.2, 0.9), 0.1, T0),     # twice within an hour
        obs('a', 'a0', 0, 0.0, (0.5, -0.2, 0.9), 0.3, T0 + 3600)]
    by_y = dict((round(f.position[1], 1), f) for f in only_row(fuse(ms, observations, [],
                                                                      cfg)).fruits)
    assert by_y[0.0].rate == pytest.approx(0.02)
    assert by_y[0.2].rate == pytest.approx(0.2)
    assert by_y[-0.2].rate == pytest.approx(cfg.default_rate) and not by_y[-0.2].fitted


def test_picked_fruit_leaves_the_forecast_and_failed_picks_do_not():
    ms = [mission('a', 'a1')]
    observations = [obs('a', 'a1', 0, 1.0, (0.5, 0.0, 0.9), 0.9, T0),
                    obs('a', 'a1', 0, 1.0, (0.5, 0.15, 0.9), 0.9, T0)]
    picks = [pick('a', 'a1', 0, (0.505, 0.0, 0.9), T0 + 30, outcome=0),
             pick('a', 'a1', 0, (0.5, 0.15, 0.9), T0 + 60, outcome=1)]
    state = fuse(ms, observations, picks, FusionConfig())
    statuses = sorted(f.status for f in only_row(state).fruits)
    assert statuses == ['harvested', 'present']
    assert state.expected_ripe('row1', T0 + DAY) == {0: 1}
    assert state.unmatched_picks == 0


def test_fruit_not_seen_by_a_later_scan_is_missing_until_seen_again():
    ms = [mission('a', 'a%d' % d, started=T0 + d * DAY) for d in range(3)]
    base = [obs('a', 'a0', 0, 0.0, (0.5, 0.0, 0.9), 0.8, T0),
            obs('a', 'a0', 0, 0.0, (0.5, 0.2, 0.9), 0.8, T0),
            obs('a', 'a1', 0, 0.0, (0.5, 0.2, 0.9), 0.85, T0 + DAY)]
    state = fuse(ms, base, [], FusionConfig())
    assert sorted(f.status for f in only_row(state).fruits) == ['missing', 'present']
    assert state.expected_ripe('row1', T0 + 2 * DAY) == {0: 1}
    again = base + [obs('a', 'a2', 0, 0.0, (0.5, 0.0, 0.9), 0.95, T0 + 2 * DAY)]
    state = fuse(ms, again, [], FusionConfig())
    assert [f.status for f in only_row(state).fruits] == ['present', 'missing']


def test_simulated_time_stamps_fall_back_to_the_wall_clock_created_time():
    cfg = FusionConfig()
    assert fusion.sighting_time(12.5, T0, cfg) == T0
    assert fusion.sighting_time(T0 + 5, T0, cfg) == T0 + 5


def test_plan_lists_points_worth_visiting_in_travel_order():
    cfg = FusionConfig(min_expected=1, revisit_days=0)
    ms = [mission('a', 'a1')]
    # picking point indices deliberately not in track order
    observations = [obs('a', 'a1', 5, 2.0, (0.5, 0.0, 0.9), 0.9, T0),
                    obs('a', 'a1', 1, 0.5, (0.5, 0.0, 0.9), 0.8, T0),
                    obs('a', 'a1', 3, 1.0, (0.5, 0.0, 0.9), 0.1, T0),
                    obs('a', 'a1', 2, 3.0, (0.5, 0.0, 0.9), 0.75, T0)]
    state = fuse(ms, observations, [], cfg)
    plan = state.plan('a', DAY0 + datetime.timedelta(days=1))
    assert plan['picking_points'] == [1, 5, 2]
    assert plan['row'] == 'row1' and plan['expected_ripe'] == 3
    assert state.plan('nobody', DAY0) is None
    cfg2 = FusionConfig(min_expected=1, revisit_days=3)
    plan = fuse(ms, observations, [], cfg2).plan('a', DAY0 + datetime.timedelta(days=5))
    assert plan['picking_points'] == [1, 3, 5, 2]          # point 3 is due for a revisit
    assert plan['points'][1]['reasons'] == ['revisit']


def test_plan_changes_when_observations_change():
    cfg = FusionConfig(revisit_days=0)
    tomorrow = DAY0 + datetime.timedelta(days=1)
    ms = [mission('a', 'a1'), mission('b', 'b1', started=T0 + 3600)]
    day1 = [obs('a', 'a1', 0, 0.0, (0.5, 0.0, 0.9), 0.2, T0),      # green
            obs('a', 'a1', 1, 0.5, (0.5, 0.0, 0.9), 0.75, T0)]     # ripe
    assert fuse(ms, day1, [], cfg).plan('a', tomorrow)['picking_points'] == [1]
    # robot b picks point 1's fruit and sees point 0's turning red fast
    day1b = day1 + [obs('b', 'b1', 0, 0.0, (0.51, 0.0, 0.9), 0.69, T0 + 3600),
                    obs('b', 'b1', 1, 0.5, (0.5, 0.0, 0.9), 0.76, T0 + 3660)]
    picks = [pick('b', 'b1', 1, (0.5, 0.0, 0.9), T0 + 3700)]
    plan = fuse(ms, day1b, picks, cfg).plan('a', tomorrow)
    assert plan['picking_points'] == [0]
    # robot a's plan follows the data of robot b in the same row
    assert fuse(ms, day1b, picks, cfg).plan('b', tomorrow)['picking_points'] == [0]


def test_records_after_the_planned_day_are_ignored():
    cfg = FusionConfig(revisit_days=0)
    ms = [mission('a', 'a1'), mission('a', 'a2', started=T0 + 2 * DAY)]
    observations = [obs('a', 'a1', 0, 0.0, (0.5, 0.0, 0.9), 0.9, T0)]
    picks = [pick('a', 'a2', 0, (0.5, 0.0, 0.9), T0 + 2 * DAY)]
    assert fuse(ms, observations, picks, cfg, day=DAY0).plan('a', DAY0)['picking_points'] == [0]
    later = DAY0 + datetime.timedelta(days=3)
    assert fuse(ms, observations, picks, cfg, day=later).plan('a', later)['picking_points'] == []


def test_yields_per_robot_and_row():
    ms = [mission('a', 'a1', site='row1'), mission('b', 'b1', site='row2'),
          mission('c', 'c1', site='row2')]
    picks = [pick('a', 'a1', 0, (0.5, 0, 0.9), T0, 0, 20.0),
             pick('a', 'a1', 0, (0.5, 0.1, 0.9), T0 + 1, 0, 30.0),
             pick('a', 'a1', 0, (0.5, 0.2, 0.9), T0 + 2, 1, 50.0),
             pick('b', 'b1', 0, (0.5, 0, 0.9), T0 + 3, 0, 40.0)]
    robots, rows = fuse(ms, [], picks, FusionConfig()).yields(DAY0)
    a, b, c = robots
    assert (a['picked'], a['attempts'], a['mean_cycle_time'], a['picked_today']) == \
        (2, 3, 25.0, 2)
    assert a['outcomes']['unreachable'] == 1 and a['success_rate'] == pytest.approx(0.667)
    assert (b['picked'], b['mean_cycle_time']) == (1, 40.0)
    assert (c['robot'], c['picked'], c['missions'], c['mean_cycle_time']) == ('c', 0, 1, None)
    assert [(r['row'], r['picked'], r['attempts']) for r in rows] == [('row1', 2, 3),
                                                                      ('row2', 1, 1)]


def test_fruit_report_by_point_and_plant():
    cfg = FusionConfig(plant_spacing=0.35)
    ms = [mission('a', 'a1')]
    observations = [obs('a', 'a1', 0, 0.0, (0.5, 0.0, 0.9), 0.3, T0),
                    obs('a', 'a1', 0, 0.0, (0.5, 0.30, 0.9), 0.3, T0),
                    obs('a', 'a1', 1, 0.7, (0.5, 0.0, 0.9), 0.3, T0)]
    report = fuse(ms, observations, [], cfg).fruits('row1', T0 + DAY)
    assert [p['picking_point'] for p in report] == [0, 1]
    assert [pl['plant'] for pl in report[0]['plants']] == [0, 1]
    assert [pl['plant'] for pl in report[1]['plants']] == [2]
    fruit = report[0]['plants'][0]['fruits'][0]
    assert fruit['history'][0]['robot'] == 'a' and fruit['status'] == 'present'
    assert fruit['forecast_score'] == pytest.approx(0.37)


def test_config_rejects_unknown_and_bad_values():
    with pytest.raises(ValueError, match='unknown fusion parameter'):
        FusionConfig(tolerance=0.1)
    with pytest.raises(ValueError, match='match_tolerance'):
        FusionConfig(match_tolerance=0.0)
    with pytest.raises(ValueError, match='finite'):
        FusionConfig(ripe_score=float('nan'))
