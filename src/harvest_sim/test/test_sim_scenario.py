"""Scenario files: every shipped scenario loads and is consistent; malformed files fail with
the file, the field path and the problem; the generator is deterministic."""

import os

import numpy as np
import pytest
import yaml

from sim_fixtures import GEOM, SCENARIOS, scn

NAMED = ['default', 'three_targets', 'dense_cluster', 'low_light', 'empty_point',
         'unripe_only', 'out_of_reach', 'long_row', 'plant_factory_led', 'greenhouse_daylight',
         'waist_reach']


def load(name):
    return scn.load_scenario(os.path.join(SCENARIOS, name + '.yaml'))


@pytest.mark.parametrize('name', NAMED)
def test_named_scenario_loads_and_is_consistent(name):
    s = load(name)
    assert s.name == name
    pts = s.track.picking_points
    for f in s.fruits:
        assert scn.RADIUS_RANGE[0] <= f.radius <= scn.RADIUS_RANGE[1]
        assert 0.0 <= f.ripeness <= 1.0
        assert np.allclose(f.peduncle, f.position + [0, 0, f.radius + scn.PEDUNCLE_GAP])
        if f.picking_point >= 0:      # in view: the box of the issue, in front of the robot
            # (fruit only the waist reaches: the wider box beside the fixed workspace)
            waist_only = f.reachable and not scn.reachability(
                GEOM, f.position, f.radius, pts[f.picking_point], f.peduncle, waist=False)[0]
            view_x = scn.WAIST_VIEW_X if waist_only else scn.VIEW_X
            half_y = scn.WAIST_VIEW_HALF_Y if waist_only else scn.VIEW_HALF_Y
            assert view_x[0] <= f.position[0] <= view_x[1]
            assert scn.VIEW_Z[0] <= f.position[2] <= scn.VIEW_Z[1]
            assert abs(f.position[1] - pts[f.picking_point]) <= half_y
            eyes = scn.stereo_eyes(GEOM, pts[f.picking_point])
            from harvest_sim import camera_model
            assert scn.fully_in_view(camera_model.stereo_camera(), eyes, f.position, f.radius)
        # the stored flag agrees with the kinematics
        expect = f.picking_point >= 0 and scn.reachability(
            GEOM, f.position, f.radius, pts[f.picking_point], f.peduncle)[0]
        assert f.reachable == expect, f.id


def test_named_scenarios_have_their_character():
    def per_point(s, pred):
        return [sum(1 for f in s.fruits_at(i) if pred(f)) for i in range(len(s.track.picking_points))]

    s = load('three_targets')
    assert per_point(s, lambda f: f.ripe and f.reachable) == [3, 3]
    s = load('empty_point')
    assert per_point(s, lambda f: True)[1] == 0
    assert all(n > 0 for i, n in enumerate(per_point(s, lambda f: True)) if i != 1)
    s = load('unripe_only')
    assert s.fruits and not any(f.ripe for f in s.fruits)
    assert all(f.ripeness <= 0.55 for f in s.fruits)
    s = load('out_of_reach')
    assert s.fruits and all(f.ripe and not f.reachable for f in s.fruits)
    s = load('waist_reach')         # ripe fruit beside the fixed workspace, on both sides
    pts = s.track.picking_points
    turns = []
    for f in s.fruits:
        assert f.ripe and f.reachable
        if not scn.reachability(GEOM, f.position, f.radius, pts[f.picking_point], f.peduncle,
                                waist=False)[0]:
            base = np.array([0.0, pts[f.picking_point], 0.0])
            turns.append(GEOM.inverse_waist('right', f.position - base, f.radius,
                                            other_xyz=f.peduncle - base).waist)
    assert len(turns) >= 4 and min(turns) < 0.0 < max(turns)
    s = load('long_row')
    assert len(s.track.picking_points) >= 20
    s = load('low_light')
    assert s.lighting.intensity < 0.5
    s = load('dense_cluster')
    assert max(per_point(s, lambda f: True)) >= 7 and any(f.occluded_by for f in s.fruits)
    s = load('default')
    assert 3 <= len(s.track.picking_points) <= 4
    assert any(f.ripe for f in s.fruits) and any(not f.ripe for f in s.fruits)


@pytest.mark.parametrize('name', NAMED)
def test_shipped_scenarios_equal_their_regenerated_preset(name):
    text = scn.dump_scenario(scn.generate(scn.knobs_for(name), GEOM))
    with open(os.path.join(SCENARIOS, name + '.yaml')) as f:
        assert f.read() == text, 'regenerate with: generate_scenario --all-presets'


def test_generator_is_deterministic_and_follows_knobs():
    k = scn.knobs_for(None, seed=42, picking_points=3, fruit_per_view=[8, 0, 5],
                      occlusion=1.0, unreachable_fraction=0.0, borderline_fraction=1.0)
    a, b = scn.generate(k, GEOM), scn.generate(k, GEOM)
    assert scn.dump_scenario(a) == scn.dump_scenario(b)
    assert [len(a.fruits_at(i)) for i in range(3)] == [8, 0, 5]
    assert all(f.occluded_by for f in a.fruits)
    assert all(0.6 <= f.ripeness <= 0.8 for f in a.fruits)
    c = scn.generate(scn.knobs_for(None, seed=43, picking_points=3), GEOM)
    assert scn.dump_scenario(c) != scn.dump_scenario(a)
    with pytest.raises(KeyError):
        scn.knobs_for(None, fruits_per_view=3)


def test_look_and_size_classes_of_the_new_presets():
    s = load('plant_factory_led')
    assert (s.look.kind, s.look.background) == ('led', 'film')
    assert all(f.radius >= scn.SIZE_CLASSES['large'][0] for f in s.fruits)
    s = load('greenhouse_daylight')
    assert (s.look.kind, s.look.background) == ('daylight', 'film')
    sizes = set(c for f in s.fruits for c, (lo, hi) in scn.SIZE_CLASSES.items()
                if lo <= f.radius <= hi)
    assert {'cherry', 'large'} <= sizes
    assert load('low_light').look.kind == 'warm'
    assert load('three_targets').look.kind == 'daylight'
    with pytest.raises(ValueError, match='fruit_size'):
        scn.generate(scn.knobs_for(None, fruit_size='huge'), GEOM)


def test_ripeness_stages():
    assert [scn.ripeness_stage(r) for r in (0.0, 0.24, 0.25, 0.49, 0.5, 0.69, 0.7, 1.0)] == \
        ['green', 'green', 'turning', 'turning', 'pink', 'pink', 'red', 'red']


def minimal():
    return {'name': 'm', 'track': {'picking_points': [0.5, 1.0]},
            'lighting': {'intensity': 1.0, 'colour': [1, 1, 1], 'direction': [0, 0, -1]},
            'stems': [{'id': 't0', 'kind': 'truss', 'radius': 0.004,
                       'points': [[0.7, 0.5, 1.2], [0.5, 0.5, 1.1]]}],
            'fruits': [{'id': 'a', 'position': [0.5, 0.5, 0.9], 'radius': 0.03,
                        'ripeness': 0.8, 'truss': 't0', 'picking_point': 0}]}


def broken(edit):
    d = minimal()
    edit(d)
    return d


def _set(path, value):
    def edit(d):
        node = d
        for key in path[:-1]:
            node = node[key]
        node[path[-1]] = value
    return edit


def _del(path):
    def edit(d):
        node = d
        for key in path[:-1]:
            node = node[key]
        del node[path[-1]]
    return edit


MALFORMED = [
    (_del(['fruits', 0, 'radius']), 'fruits[0].radius', 'missing required field'),
    (_set(['fruits', 0, 'radius'], 0.08), 'fruits[0].radius', 'outside'),
    (_set(['fruits', 0, 'ripeness'], 1.5), 'fruits[0].ripeness', 'outside'),
    (_set(['fruits', 0, 'position'], [0.5, 0.5]), 'fruits[0].position', 'list of 3 numbers'),
    (_set(['fruits', 0, 'position'], [0.5, 'x', 1.0]), 'fruits[0].position[1]', 'number'),
    (_set(['fruits', 0, 'colour'], 'red'), 'fruits[0].colour', 'unknown field'),
    (_set(['fruits', 0, 'truss'], 'nope'), 'fruits[0].truss', 'no stem of kind truss'),
    (_set(['fruits', 0, 'picking_point'], 5), 'fruits[0].picking_point', 'outside'),
    (_set(['fruits', 0, 'reachable'], 'yes'), 'fruits[0].reachable', 'true or false'),
    (_set(['track', 'picking_points'], [1.0, 0.5]), 'track.picking_points[1]',
     'strictly increasing'),
    (_set(['track', 'picking_points'], []), 'track.picking_points', 'at least 1'),
    (_set(['lighting', 'direction'], [0, 0, 0]), 'lighting.direction', 'zero vector'),
    (_set(['stems', 0, 'kind'], 'branch'), 'stems[0].kind', 'not one of'),
    (lambda d: d['fruits'].append(dict(d['fruits'][0], position=[0.5, 0.6, 0.9])),
     'fruits[1].id', 'duplicate fruit id'),
    (lambda d: d['fruits'].append(dict(d['fruits'][0], id='b', position=[0.51, 0.5, 0.9])),
     'fruits[1].position', 'overlaps'),
    (_del(['lighting']), 'lighting', 'missing required field'),
    (_set(['fruits'], {'id': 'a'}), 'fruits', 'must be a list'),
    (_set(['look'], {'kind': 'sodium'}), 'look.kind', 'not one of daylight, led, warm'),
    (_set(['look'], {'background': 'sky'}), 'look.background', 'not one of'),
    (_set(['look'], {'variation': 2.0}), 'look.variation', 'outside'),
    (_set(['look'], {'glare': 1}), 'look.glare', 'unknown field'),
    (_set(['look'], 'led'), 'look', 'must be a mapping'),
]


@pytest.mark.parametrize('edit,field,problem', MALFORMED)
def test_malformed_scenarios_fail_clearly(tmp_path, edit, field, problem):
    path = str(tmp_path / 'bad.yaml')
    with open(path, 'w') as f:
        yaml.safe_dump(broken(edit), f)
    with pytest.raises(scn.ScenarioError) as e:
        scn.load_scenario(path)
    text = str(e.value)
    assert text.startswith(path + ': ' + field + ': '), text
    assert problem in text, text


@pytest.mark.parametrize('content,problem', [('', 'file is empty'),
                                             ('name: [unclosed', 'not valid YAML'),
                                             ('- 1\n- 2\n', 'must be a mapping')])
def test_unparsable_files_fail_clearly(tmp_path, content, problem):
    path = str(tmp_path / 'bad.yaml')
    with open(path, 'w') as f:
        f.write(content)
    with pytest.raises(scn.ScenarioError) as e:
        scn.load_scenario(path)
    assert str(e.value).startswith(path + ': ') and problem in str(e.value)


def test_missing_file_fails_clearly():
    with pytest.raises(scn.ScenarioError) as e:
        scn.load_scenario('/nonexistent/x.yaml')
    assert '/nonexistent/x.yaml' in str(e.value) and 'cannot read' in str(e.value)


def test_minimal_file_loads_with_defaults(tmp_path):
    path = str(tmp_path / 'ok.yaml')
    with open(path, 'w') as f:
        yaml.safe_dump(minimal(), f)
    s = scn.load_scenario(path)
    f0 = s.fruits[0]
    assert f0.ripe and f0.stage == 'red' and not f0.reachable
    assert np.allclose(f0.peduncle, [0.5, 0.5, 0.94])


def test_a_fruit_outside_the_suction_sleeves_sizes_is_unreachable():
    # same place, three sizes: the cherry tomato does not seal on the sleeve's lip (robot.yaml
    # robot.arms.right.fruit_radius), whatever the arms can reach
    lo, hi = GEOM.fruit_radius['right']
    s = load('three_targets')
    f = next(f for f in s.fruits if f.reachable)
    point = s.track.picking_points[f.picking_point]
    assert scn.reachability(GEOM, f.position, 0.5 * (lo + hi), point)[0]
    small = scn.reachability(GEOM, f.position, 0.7 * lo, point)
    assert small[0] is False and 'suction sleeve' in small[1]
    large = scn.reachability(GEOM, f.position, 1.1 * hi, point)
    assert large[0] is False and 'suction sleeve' in large[1]
