"""Scenario files: YAML text of a scenario, and reading and validating a file into one.

load_scenario() / parse_scenario() raise ScenarioError naming the file, the field path and the
problem. The format is in the docstring of harvest_sim/scenario.py.
"""

import math
import os
from collections import OrderedDict

import numpy as np
import yaml

from harvest_sim.scenario_model import (BACKGROUNDS, LOOK_KINDS, PEDUNCLE_GAP, RADIUS_RANGE,
                                        STEM_KINDS, TRACK_RANGE, Fruit, Leaf, Lighting, Look,
                                        Scenario, ScenarioError, Stem, Track)

class _Dumper(yaml.SafeDumper):
    pass


def _represent_odict(dumper, data):
    return dumper.represent_mapping('tag:yaml.org,2002:map', data.items())


_Dumper.add_representer(OrderedDict, _represent_odict)


def dump_scenario(scenario):
    """YAML text of a scenario (lists of numbers inline)."""
    header = ('# Scenario "%s" of the simulated plant factory (harvest_sim).\n'
              '# Format: harvest_sim/src/harvest_sim/scenario.py. Generated files say how in\n'
              '# `generator`; regenerate with `rosrun harvest_sim generate_scenario`.\n'
              % scenario.name)
    body = yaml.dump(scenario.to_dict(), Dumper=_Dumper, default_flow_style=None,
                     sort_keys=False, width=100)
    return header + body


def save_scenario(scenario, path):
    with open(path, 'w') as f:
        f.write(dump_scenario(scenario))


def load_scenario(path):
    """Read and validate a scenario file; raises ScenarioError (file, field, problem)."""
    try:
        with open(path) as f:
            data = yaml.load(f, Loader=yaml.SafeLoader)
    except (IOError, OSError) as e:
        raise ScenarioError(path, '', 'cannot read: %s' % e)
    except yaml.YAMLError as e:
        raise ScenarioError(path, '', 'not valid YAML: %s' % str(e).replace('\n', ' '))
    return parse_scenario(data, path)


def resolve_scenario(name_or_path, scenarios_dir):
    """A scenario name ('three_targets') or a file path -> file path."""
    if os.sep in name_or_path or name_or_path.endswith(('.yaml', '.yml')):
        return name_or_path
    return os.path.join(scenarios_dir, name_or_path + '.yaml')


class _Reader(object):
    """Field-path-aware checks for parse_scenario."""

    def __init__(self, source):
        self.source = source

    def fail(self, path, problem):
        raise ScenarioError(self.source, path, problem)

    def mapping(self, value, path, required, optional=()):
        if not isinstance(value, dict):
            self.fail(path, 'must be a mapping, got %s' % type(value).__name__)
        for key in required:
            if key not in value:
                self.fail(_join(path, key), 'missing required field')
        allowed = set(required) | set(optional)
        for key in value:
            if key not in allowed:
                self.fail(_join(path, str(key)), 'unknown field (allowed: %s)'
                          % ', '.join(sorted(allowed)))
        return value

    def number(self, value, path, lo=None, hi=None):
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            self.fail(path, 'must be a number, got %r' % (value,))
        x = float(value)
        if not math.isfinite(x):
            self.fail(path, 'must be finite, got %r' % (value,))
        if (lo is not None and x < lo) or (hi is not None and x > hi):
            self.fail(path, '%r outside [%s, %s]' % (value, lo, hi))
        return x

    def integer(self, value, path, lo=None, hi=None):
        if isinstance(value, bool) or not isinstance(value, int):
            self.fail(path, 'must be an integer, got %r' % (value,))
        if (lo is not None and value < lo) or (hi is not None and value > hi):
            self.fail(path, '%r outside [%s, %s]' % (value, lo, hi))
        return value

    def boolean(self, value, path):
        if not isinstance(value, bool):
            self.fail(path, 'must be true or false, got %r' % (value,))
        return value

    def string(self, value, path, allow_empty=False):
        if not isinstance(value, str) or (not allow_empty and not value):
            self.fail(path, 'must be a non-empty string, got %r' % (value,))
        return value

    def sequence(self, value, path, min_len=0):
        if not isinstance(value, list):
            self.fail(path, 'must be a list, got %s' % type(value).__name__)
        if len(value) < min_len:
            self.fail(path, 'needs at least %d entries, has %d' % (min_len, len(value)))
        return value

    def vec3(self, value, path, nonzero=False, lo=None, hi=None):
        if not isinstance(value, list) or len(value) != 3:
            self.fail(path, 'must be a list of 3 numbers, got %r' % (value,))
        v = np.array([self.number(x, '%s[%d]' % (path, i), lo, hi) for i, x in enumerate(value)])
        if nonzero and np.linalg.norm(v) < 1e-9:
            self.fail(path, 'must not be the zero vector')
        return v


def _join(path, key):
    return '%s.%s' % (path, key) if path else key


def parse_scenario(data, source='<memory>'):
    """Validate parsed YAML data and build a Scenario (ScenarioError on any problem)."""
    r = _Reader(source)
    if data is None:
        r.fail('', 'file is empty')
    r.mapping(data, '', ('name', 'track', 'lighting', 'fruits'),
              ('description', 'seed', 'stems', 'leaves', 'generator', 'look'))
    name = r.string(data['name'], 'name')
    description = r.string(data.get('description', ''), 'description', allow_empty=True)
    seed = r.integer(data.get('seed', 0), 'seed', 0)

    tr = r.mapping(data['track'], 'track', ('picking_points',), ('backdrop_x', 'aisle_x'))
    pts = r.sequence(tr['picking_points'], 'track.picking_points', 1)
    points = [r.number(p, 'track.picking_points[%d]' % i, *TRACK_RANGE) for i, p in enumerate(pts)]
    for i in range(1, len(points)):
        if points[i] <= points[i - 1]:
            r.fail('track.picking_points[%d]' % i, 'picking points must be strictly increasing '
                   '(%.3f after %.3f)' % (points[i], points[i - 1]))
    backdrop_x = r.number(tr.get('backdrop_x', 0.95), 'track.backdrop_x', 0.4, 5.0)
    aisle_x = r.number(tr.get('aisle_x', -1.2), 'track.aisle_x', -5.0, -0.3)
    track = Track(points, backdrop_x, aisle_x)

    lt = r.mapping(data['lighting'], 'lighting', ('intensity', 'colour', 'direction'),
                   ('ambient',))
    lighting = Lighting(r.number(lt['intensity'], 'lighting.intensity', 0.0, 3.0),
                        r.number(lt.get('ambient', 0.35), 'lighting.ambient', 0.0, 1.0),
                        r.vec3(lt['colour'], 'lighting.colour', True, 0.0, 2.0),
                        r.vec3(lt['direction'], 'lighting.direction', True))
    look = parse_look(r, data.get('look', {}), 'look')

    stems, stem_ids = [], {}
    for i, s in enumerate(r.sequence(data.get('stems', []), 'stems')):
        p = 'stems[%d]' % i
        r.mapping(s, p, ('id', 'kind', 'radius', 'points'))
        sid = r.string(s['id'], p + '.id')
        if sid in stem_ids:
            r.fail(p + '.id', 'duplicate stem id %r (also stems[%d])' % (sid, stem_ids[sid]))
        stem_ids[sid] = i
        kind = r.string(s['kind'], p + '.kind')
        if kind not in STEM_KINDS:
            r.fail(p + '.kind', '%r is not one of %s' % (kind, ', '.join(STEM_KINDS)))
        pl = r.sequence(s['points'], p + '.points', 2)
        stems.append(Stem(sid, kind, r.number(s['radius'], p + '.radius', 0.001, 0.03),
                          [r.vec3(q, '%s.points[%d]' % (p, j)) for j, q in enumerate(pl)]))

    leaves, leaf_ids = [], {}
    for i, lf in enumerate(r.sequence(data.get('leaves', []), 'leaves')):
        p = 'leaves[%d]' % i
        r.mapping(lf, p, ('id', 'centre', 'normal', 'axis', 'length', 'width'), ('colour',))
        lid = r.string(lf['id'], p + '.id')
        if lid in leaf_ids:
            r.fail(p + '.id', 'duplicate leaf id %r (also leaves[%d])' % (lid, leaf_ids[lid]))
        leaf_ids[lid] = i
        normal = r.vec3(lf['normal'], p + '.normal', True)
        axis = r.vec3(lf['axis'], p + '.axis', True)
        if np.linalg.norm(np.cross(normal, axis)) < 1e-6 * np.linalg.norm(normal) * \
                np.linalg.norm(axis):
            r.fail(p + '.axis', 'must not be parallel to the normal')
        leaves.append(Leaf(lid, r.vec3(lf['centre'], p + '.centre'), normal, axis,
                           r.number(lf['length'], p + '.length', 0.01, 0.5),
                           r.number(lf['width'], p + '.width', 0.005, 0.3),
                           r.vec3(lf.get('colour', [0.25, 0.5, 0.15]), p + '.colour',
                                  False, 0.0, 1.0)))

    fruits, fruit_ids = [], {}
    for i, fd in enumerate(r.sequence(data['fruits'], 'fruits')):
        p = 'fruits[%d]' % i
        r.mapping(fd, p, ('id', 'position', 'radius', 'ripeness'),
                  ('cluster', 'truss', 'peduncle', 'pedicel_top', 'picking_point', 'reachable',
                   'occluded_by'))
        fid = r.string(fd['id'], p + '.id')
        if fid in fruit_ids:
            r.fail(p + '.id', 'duplicate fruit id %r (also fruits[%d])' % (fid, fruit_ids[fid]))
        fruit_ids[fid] = i
        pos = r.vec3(fd['position'], p + '.position')
        if pos[2] <= 0.0:
            r.fail(p + '.position[2]', 'fruit must hang above the floor (z > 0), got %r'
                   % pos[2])
        radius = r.number(fd['radius'], p + '.radius', *RADIUS_RANGE)
        ripeness = r.number(fd['ripeness'], p + '.ripeness', 0.0, 1.0)
        truss = r.string(fd.get('truss', ''), p + '.truss', allow_empty=True)
        if truss and (truss not in stem_ids or stems[stem_ids[truss]].kind != 'truss'):
            r.fail(p + '.truss', 'no stem of kind truss with id %r' % truss)
        peduncle = None
        if 'peduncle' in fd:
            peduncle = r.vec3(fd['peduncle'], p + '.peduncle')
            if peduncle[2] <= pos[2] + 0.5 * radius or \
                    np.linalg.norm(peduncle[:2] - pos[:2]) > radius:
                r.fail(p + '.peduncle', 'must be above the fruit (near centre + (0, 0, radius + '
                       '%.2f))' % PEDUNCLE_GAP)
        pedicel_top = None
        if 'pedicel_top' in fd:
            pedicel_top = r.vec3(fd['pedicel_top'], p + '.pedicel_top')
        pp = r.integer(fd.get('picking_point', -1), p + '.picking_point', -1, len(points) - 1)
        occ = r.sequence(fd.get('occluded_by', []), p + '.occluded_by')
        for j, lid in enumerate(occ):
            if lid not in leaf_ids:
                r.fail('%s.occluded_by[%d]' % (p, j), 'no leaf with id %r' % (lid,))
        fruits.append(Fruit(fid, pos, radius, ripeness,
                            r.string(fd.get('cluster', ''), p + '.cluster', allow_empty=True),
                            truss, peduncle, pedicel_top, pp,
                            r.boolean(fd.get('reachable', False), p + '.reachable'), occ))
    for i, a in enumerate(fruits):
        for b in fruits[:i]:
            if np.linalg.norm(a.position - b.position) < a.radius + b.radius - 1e-4:
                r.fail('fruits[%d].position' % i, 'fruit %s overlaps fruit %s' % (a.id, b.id))
    gen = data.get('generator', {})
    if not isinstance(gen, dict):
        r.fail('generator', 'must be a mapping')
    return Scenario(name, track, lighting, fruits, stems, leaves, seed, description, gen, source,
                    look)


def parse_look(r, value, path):
    """Look of an optional `look` mapping (every field optional)."""
    lk = r.mapping(value if value is not None else {}, path, (),
                   ('kind', 'background', 'variation'))
    kind = r.string(lk.get('kind', 'daylight'), path + '.kind')
    if kind not in LOOK_KINDS:
        r.fail(path + '.kind', '%r is not one of %s' % (kind, ', '.join(LOOK_KINDS)))
    background = r.string(lk.get('background', 'mixed'), path + '.background')
    if background not in BACKGROUNDS:
        r.fail(path + '.background', '%r is not one of %s'
               % (background, ', '.join(BACKGROUNDS)))
    return Look(kind, background, r.number(lk.get('variation', 1.0), path + '.variation', 0.0,
                                           1.0))
