"""Scenarios of the simulated plant factory: data model, validation, YAML I/O and generator.

A scenario file (YAML, all lengths in metres, map frame: track along +y, the plant row toward +x,
z up) holds:

    name, description, seed         seed drives textures and sensor noise of the cameras
    track:    picking_points [y...]  cart positions (m along map +y), strictly increasing
              backdrop_x             x of the canopy behind the fruit (rendered backdrop)
              aisle_x                x of the opposite row (seen when the waist turns round)
    lighting: intensity, ambient, colour [r, g, b], direction [x, y, z] (the way light travels)
    look:     optional camera/illumination look of the renders (harvest_sim/look.py):
              kind daylight|led|warm (default daylight), background foliage|mixed|film
              (what the canopy plane behind the fruit shows; default mixed), variation 0..1
              (how far the per-camera random look spreads over its documented ranges; 1)
    stems:    [{id, kind: main|truss, radius, points: [[x, y, z], ...]}]
    leaves:   [{id, centre, normal, axis, length, width, colour}]
    fruits:   [{id, position, radius, ripeness, cluster, truss, peduncle, pedicel_top,
                picking_point, reachable, occluded_by: [leaf ids]}]
    generator: knobs that produced the file (informational)

Ripeness is 0..1 and rendered green -> turning -> pink -> red; ground truth "ripe" is
ripeness >= RIPE_THRESHOLD. The peduncle (where the shear cuts) is the stem point above the fruit:
centre + (0, 0, radius + PEDUNCLE_GAP). `reachable` is computed with motion_pkg.kinematics at the
fruit's picking point (cart at that point, waist at 0 or turned by the smallest angle that serves
both arms, RobotGeometry.inverse_waist): the right suction tcp must reach the fruit surface facing
it (target the centre with standoff = radius) and the left shear tcp the peduncle (with the right
arm at its suction pose for the clearance check). The generator's `waist_fraction` places fruit
beside the arms' fixed workspace (WAIST_VIEW_X, WAIST_VIEW_HALF_Y, still fully in both stereo
images at waist 0) that only a turn of the waist brings in reach.

load_scenario() raises ScenarioError naming the file, the field path and the problem.
"""

import copy
import math
import os
from collections import OrderedDict

import numpy as np
import yaml

from harvest_sim import camera_model, look as look_model

RIPE_THRESHOLD = 0.7
#: (stage name, lowest ripeness of the stage)
STAGES = (('green', 0.0), ('turning', 0.25), ('pink', 0.5), ('red', 0.7))
RADIUS_RANGE = (0.010, 0.050)
#: fruit radius (m) of the generator's size classes ('mixed': one class per truss)
SIZE_CLASSES = OrderedDict([('cherry', (0.011, 0.016)), ('round', (0.028, 0.042)),
                            ('large', (0.040, 0.048))])
FRUIT_SIZES = tuple(SIZE_CLASSES) + ('mixed',)
LOOK_KINDS = look_model.KINDS
BACKGROUNDS = ('foliage', 'mixed', 'film')
PEDUNCLE_GAP = 0.01
#: where fruit in view of a picking point sit: map x, z and |y - point| (issue text)
VIEW_X = (0.35, 0.65)
VIEW_Z = (0.82, 1.08)
VIEW_HALF_Y = 0.25
#: where the generator's waist-only fruit (knob waist_fraction) sit: map x and |y - point|
WAIST_VIEW_X = (0.35, 0.70)
WAIST_VIEW_HALF_Y = 0.40
#: `want_reach` of the generator for a fruit only the waist brings in reach
WAIST_ONLY = 'waist'
TRACK_RANGE = (0.0, 30.0)
STEM_KINDS = ('main', 'truss')


def ripeness_stage(ripeness):
    """Stage name of a ripeness value (green < 0.25 <= turning < 0.5 <= pink < 0.7 <= red)."""
    name = STAGES[0][0]
    for stage, lo in STAGES:
        if ripeness >= lo:
            name = stage
    return name


class ScenarioError(ValueError):
    """Invalid scenario: str() is 'FILE: FIELD: PROBLEM'."""

    def __init__(self, source, field, problem):
        self.source, self.field, self.problem = source, field, problem
        ValueError.__init__(self, '%s: %s: %s' % (source, field or '<top>', problem))


class Lighting(object):
    def __init__(self, intensity=1.0, ambient=0.35, colour=(1.0, 0.98, 0.92),
                 direction=(0.5, 0.15, -1.0)):
        self.intensity = float(intensity)
        self.ambient = float(ambient)
        self.colour = np.asarray(colour, dtype=float)
        d = np.asarray(direction, dtype=float)
        self.direction = d / np.linalg.norm(d)


class Look(object):
    """How the cameras render the scene: illumination kind, background, spread of the look."""

    def __init__(self, kind='daylight', background='mixed', variation=1.0):
        self.kind, self.background, self.variation = kind, background, float(variation)


class Track(object):
    def __init__(self, picking_points, backdrop_x=0.95, aisle_x=-1.2):
        self.picking_points = [float(v) for v in picking_points]
        self.backdrop_x = float(backdrop_x)
        self.aisle_x = float(aisle_x)


class Stem(object):
    def __init__(self, id, kind, radius, points):
        self.id, self.kind, self.radius = id, kind, float(radius)
        self.points = np.asarray(points, dtype=float).reshape(-1, 3)


class Leaf(object):
    def __init__(self, id, centre, normal, axis, length, width, colour=(0.25, 0.5, 0.15)):
        self.id = id
        self.centre = np.asarray(centre, dtype=float)
        n = np.asarray(normal, dtype=float)
        self.normal = n / np.linalg.norm(n)
        a = np.asarray(axis, dtype=float)
        a = a - self.normal * a.dot(self.normal)       # make the axis lie in the leaf plane
        self.axis = a / np.linalg.norm(a)
        self.length, self.width = float(length), float(width)
        self.colour = np.asarray(colour, dtype=float)


class Fruit(object):
    def __init__(self, id, position, radius, ripeness, cluster='', truss='', peduncle=None,
                 pedicel_top=None, picking_point=-1, reachable=False, occluded_by=()):
        self.id = id
        self.position = np.asarray(position, dtype=float)
        self.radius = float(radius)
        self.ripeness = float(ripeness)
        self.cluster, self.truss = cluster, truss
        self.peduncle = (np.asarray(peduncle, dtype=float) if peduncle is not None else
                         default_peduncle(self.position, self.radius))
        self.pedicel_top = (np.asarray(pedicel_top, dtype=float) if pedicel_top is not None
                            else self.peduncle + np.array([0.0, 0.0, 0.04]))
        self.picking_point = int(picking_point)
        self.reachable = bool(reachable)
        self.occluded_by = list(occluded_by)

    @property
    def ripe(self):
        return self.ripeness >= RIPE_THRESHOLD

    @property
    def stage(self):
        return ripeness_stage(self.ripeness)


def default_peduncle(position, radius):
    return np.asarray(position, dtype=float) + np.array([0.0, 0.0, radius + PEDUNCLE_GAP])


class Scenario(object):
    def __init__(self, name, track, lighting, fruits, stems=(), leaves=(), seed=0,
                 description='', generator=None, source='<memory>', look=None):
        self.name, self.description, self.seed = name, description, int(seed)
        self.track, self.lighting = track, lighting
        self.look = look if look is not None else Look()
        self.fruits, self.stems, self.leaves = list(fruits), list(stems), list(leaves)
        self.generator = generator or {}
        self.source = source

    def fruit(self, fruit_id):
        for f in self.fruits:
            if f.id == fruit_id:
                return f
        raise KeyError(fruit_id)

    def fruits_at(self, index):
        return [f for f in self.fruits if f.picking_point == index]

    def to_dict(self):
        """Plain data for YAML (floats rounded to 0.1 mm / 1e-4)."""
        def v(a):
            return [round(float(x), 4) for x in a]
        d = OrderedDict()
        d['name'] = self.name
        d['description'] = self.description
        d['seed'] = self.seed
        d['track'] = OrderedDict([('picking_points', v(self.track.picking_points)),
                                  ('backdrop_x', round(self.track.backdrop_x, 4)),
                                  ('aisle_x', round(self.track.aisle_x, 4))])
        lt = self.lighting
        d['lighting'] = OrderedDict([('intensity', round(lt.intensity, 4)),
                                     ('ambient', round(lt.ambient, 4)),
                                     ('colour', v(lt.colour)), ('direction', v(lt.direction))])
        d['look'] = OrderedDict([('kind', self.look.kind),
                                 ('background', self.look.background),
                                 ('variation', round(self.look.variation, 4))])
        d['stems'] = [OrderedDict([('id', s.id), ('kind', s.kind), ('radius', round(s.radius, 4)),
                                   ('points', [v(p) for p in s.points])]) for s in self.stems]
        d['leaves'] = [OrderedDict([('id', lf.id), ('centre', v(lf.centre)),
                                    ('normal', v(lf.normal)), ('axis', v(lf.axis)),
                                    ('length', round(lf.length, 4)),
                                    ('width', round(lf.width, 4)), ('colour', v(lf.colour))])
                       for lf in self.leaves]
        d['fruits'] = [OrderedDict([
            ('id', f.id), ('position', v(f.position)), ('radius', round(f.radius, 4)),
            ('ripeness', round(f.ripeness, 3)), ('cluster', f.cluster), ('truss', f.truss),
            ('peduncle', v(f.peduncle)), ('pedicel_top', v(f.pedicel_top)),
            ('picking_point', f.picking_point), ('reachable', f.reachable),
            ('occluded_by', list(f.occluded_by))]) for f in self.fruits]
        if self.generator:
            d['generator'] = self.generator
        return d


# ---------------------------------------------------------------------------- YAML I/O

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


# ---------------------------------------------------------------------------- kinematics

def reachability(geom, position, radius, cart_y, peduncle=None, waist=True):
    """(reachable, reason) of a fruit with the cart at cart_y.

    Right arm: suction tcp on the fruit surface facing it (target the centre, standoff radius).
    Left arm: shear tcp on the peduncle, with the right arm at that suction pose.
    waist True: at waist 0 or, if not there, at the smallest waist rotation that serves both
    arms (the robot's kinematics action, RobotGeometry.inverse_waist); False: at waist 0 only.
    """
    base = np.array([0.0, cart_y, 0.0])
    c = np.asarray(position, dtype=float) - base
    ped = (default_peduncle(position, radius) if peduncle is None else
           np.asarray(peduncle, dtype=float)) - base
    if waist:
        sol = geom.inverse_waist('right', c, standoff=radius, other_xyz=ped, other_standoff=0.0)
        if not sol.ik.reachable:
            return False, 'suction: ' + sol.ik.reason
        if not sol.other.reachable:
            return False, 'shear: ' + sol.other.reason
        return True, ''
    right = geom.inverse('right', c, standoff=radius)
    if not right.reachable:
        return False, 'suction: ' + right.reason
    left = geom.inverse('left', ped, standoff=0.0, other_arm_joints=right.joints)
    if not left.reachable:
        return False, 'shear: ' + left.reason
    return True, ''


def mark_reachability(scenario, geom):
    """Recompute every fruit's `reachable` flag (False for fruit in view of no picking point)."""
    for f in scenario.fruits:
        if f.picking_point < 0:
            f.reachable = False
        else:
            f.reachable = reachability(geom, f.position, f.radius,
                                       scenario.track.picking_points[f.picking_point],
                                       f.peduncle)[0]
    return scenario


def stereo_eyes(geom, cart_y):
    """Poses (4x4 in map) of the left and right stereo optical frames at a picking point."""
    poses = geom.frame_transforms({'cart_joint': cart_y})
    return poses['stereo_left_optical'], poses['stereo_right_optical']


def fully_in_view(camera, eyes, position, radius, margin_px=4.0):
    """True if the fruit's projected disc lies inside every camera image of `eyes`."""
    for T in eyes:
        pc = camera_model.to_camera(T, position)[0]
        if pc[2] <= radius + 0.05:
            return False
        u, v = camera.project(pc)[0]
        rp = camera.fx * radius / math.sqrt(max(pc[2] ** 2 - radius ** 2, 1e-9)) + margin_px
        if u - rp < 0 or u + rp > camera.width - 1 or v - rp < 0 or v + rp > camera.height - 1:
            return False
    return True


# ---------------------------------------------------------------------------- generator

DEFAULT_KNOBS = OrderedDict([
    ('name', 'generated'),
    ('description', ''),
    ('seed', 0),
    ('picking_points', 4),          # count, or an explicit list of cart positions (m)
    ('start', 0.5),                 # first picking point (m) when picking_points is a count
    ('spacing', 0.5),               # distance between picking points (m)
    ('fruit_per_view', [2, 4]),     # n, [min, max], or one n / [min, max] per picking point
    ('ripe_fraction', 0.5),         # chance that a fruit is ripe
    ('ripe_per_view', None),        # exact number of ripe fruit per view (overrides fraction)
    ('ripe_range', [0.8, 1.0]),     # ripeness of ripe fruit
    ('unripe_range', [0.0, 0.55]),  # ripeness of unripe fruit
    ('borderline_fraction', 0.0),   # chance of a ripeness near the threshold (0.6 .. 0.8)
    ('cluster_density', 0.5),       # 0..1: fruit per cluster (1..4) and how tightly they hang
    ('occlusion', 0.2),             # chance that a leaf hangs partly in front of a fruit
    ('leaves_per_view', 6),         # background leaves per picking point
    ('unreachable_fraction', 0.15),  # chance that a fruit is placed out of the arms' reach
    ('waist_fraction', 0.0),        # chance that a fruit is placed where only a turn of the waist reaches it
    ('intensity', 1.0),             # light intensity (1 = bright greenhouse day)
    ('ambient', 0.35),
    ('light_colour', [1.0, 0.98, 0.92]),
    ('light_direction', [0.5, 0.15, -1.0]),
    ('lighting_variation', 0.0),    # 0..1 random change of intensity, colour and direction
    ('backdrop_x', 0.95),
    ('stem_x', 0.75),               # x of the plants' main stems
    ('fruit_size', 'round'),        # size class: cherry, round, large, or mixed (per truss)
    ('look_kind', 'daylight'),      # camera look: daylight, led (plant factory) or warm
    ('background', 'mixed'),        # behind the canopy: foliage, mixed or film
    ('look_variation', 1.0),        # 0..1 spread of the per-camera look over its ranges
])

#: the shipped scenarios (scenarios/NAME.yaml are generated from these)
PRESETS = OrderedDict([
    ('default', dict(seed=11, picking_points=4, fruit_per_view=[2, 4], ripe_fraction=0.6,
                     occlusion=0.2, unreachable_fraction=0.15, lighting_variation=0.2,
                     description='Short row, four picking points, mixed ripeness, some fruit '
                                 'occluded or out of reach.')),
    ('three_targets', dict(seed=3, picking_points=2, fruit_per_view=4, ripe_per_view=3,
                           unreachable_fraction=0.0, occlusion=0.0, cluster_density=0.3,
                           ripe_range=[0.85, 1.0], unripe_range=[0.0, 0.2],
                           description='The paper\'s headline case: three ripe reachable fruit '
                                       '(plus one green) in view at each of two picking points.')),
    ('dense_cluster', dict(seed=5, picking_points=2, fruit_per_view=[7, 8], ripe_fraction=0.6,
                           cluster_density=1.0, occlusion=0.4, unreachable_fraction=0.1,
                           leaves_per_view=9,
                           description='Tight trusses of 7-8 fruit per view with leaves in '
                                       'front: selection and occlusion handling.')),
    ('low_light', dict(seed=7, picking_points=3, fruit_per_view=[3, 4], ripe_fraction=0.6,
                       intensity=0.35, ambient=0.25, light_colour=[1.0, 0.85, 0.7],
                       light_direction=[0.2, 0.6, -0.6], unreachable_fraction=0.1,
                       look_kind='warm',
                       description='Dim, warm, low-angle light (evening): colour segmentation '
                                   'under variable illumination.')),
    ('empty_point', dict(seed=9, picking_points=3, fruit_per_view=[3, 0, 2], ripe_per_view=2,
                         unreachable_fraction=0.0,
                         description='The middle picking point has no fruit: the robot must '
                                     'move on.')),
    ('unripe_only', dict(seed=13, picking_points=2, fruit_per_view=[3, 4], ripe_fraction=0.0,
                         unreachable_fraction=0.0,
                         description='Only unripe fruit (ripeness < 0.55): nothing to pick.')),
    ('waist_reach', dict(seed=36, picking_points=2, fruit_per_view=[3, 3], ripe_per_view=3,
                         waist_fraction=0.67, unreachable_fraction=0.0, occlusion=0.0,
                         cluster_density=0.0, ripe_range=[0.85, 1.0],
                         description='Ripe fruit beside the arms\' fixed workspace, diagonally '
                                     'in front: only a turn of the waist brings them in reach.')),
    ('out_of_reach', dict(seed=17, picking_points=2, fruit_per_view=[2, 3], ripe_fraction=1.0,
                          unreachable_fraction=1.0,
                          description='Ripe fruit in view but beyond the arms\' reach.')),
    ('long_row', dict(seed=21, picking_points=22, fruit_per_view=[0, 5], ripe_fraction=0.55,
                      occlusion=0.25, unreachable_fraction=0.15, lighting_variation=0.3,
                      borderline_fraction=0.1,
                      description='A long row of 22 picking points for continuous operation.')),
    ('plant_factory_led', dict(seed=23, picking_points=3, fruit_per_view=[3, 5],
                               ripe_fraction=0.55, cluster_density=0.6, occlusion=0.2,
                               unreachable_fraction=0.1, fruit_size='large', look_kind='led',
                               background='film', ambient=0.45, light_colour=[1.0, 1.0, 1.0],
                               light_direction=[0.3, 0.1, -1.0],
                               description='Plant factory under red/blue LED light (pink-magenta '
                                           'cast), white film walls, large round tomatoes.')),
    ('greenhouse_daylight', dict(seed=53, picking_points=3, fruit_per_view=[4, 7],
                                 ripe_fraction=0.5, cluster_density=0.8, occlusion=0.2,
                                 unreachable_fraction=0.1, borderline_fraction=0.1,
                                 fruit_size='mixed', look_kind='daylight', background='film',
                                 intensity=1.1, ambient=0.5, light_colour=[0.95, 0.98, 1.0],
                                 light_direction=[0.2, 0.3, -1.0],
                                 description='Greenhouse in diffuse daylight behind plastic film: '
                                             'cherry, round and large tomatoes on trusses.')),
])


def knobs_for(preset=None, **overrides):
    """DEFAULT_KNOBS updated by a preset and overrides (unknown knob names raise KeyError)."""
    k = copy.deepcopy(DEFAULT_KNOBS)
    upd = dict(PRESETS[preset]) if preset else {}
    if preset:
        upd.setdefault('name', preset)
    upd.update(overrides)
    for key, value in upd.items():
        if key not in k:
            raise KeyError('unknown generator knob %r (known: %s)' % (key, ', '.join(k)))
        k[key] = value
    return k


def _counts(spec, n_points, rng):
    """Fruit count per view from an int, [min, max] or a per-point list.

    With exactly two picking points a two-entry list is per point, not a range.
    """
    if isinstance(spec, int):
        return [spec] * n_points
    if isinstance(spec, (list, tuple)) and len(spec) == 2 and n_points != 2 and \
            all(isinstance(v, int) for v in spec):
        return [int(rng.integers(spec[0], spec[1] + 1)) for _ in range(n_points)]
    if isinstance(spec, (list, tuple)) and len(spec) == n_points:
        out = []
        for s in spec:
            out.append(s if isinstance(s, int) else int(rng.integers(s[0], s[1] + 1)))
        return out
    raise ValueError('fruit_per_view must be n, [min, max] or one entry per picking point')


def _unit(v):
    v = np.asarray(v, dtype=float)
    return v / np.linalg.norm(v)


class _Generator(object):
    def __init__(self, knobs, geom):
        self.k = knobs
        self.geom = geom
        self.rng = np.random.default_rng(int(knobs['seed']))
        self.camera = camera_model.stereo_camera()
        self.fruits, self.stems, self.leaves = [], [], []

    def run(self):
        k, rng = self.k, self.rng
        pp = k['picking_points']
        if isinstance(pp, int):
            points = [round(k['start'] + i * k['spacing'], 4) for i in range(pp)]
        else:
            points = [float(v) for v in pp]
        counts = _counts(k['fruit_per_view'], len(points), rng)
        self._plants(points)
        for index, y in enumerate(points):
            self._view(index, y, counts[index])
        for index, y in enumerate(points):
            self._filler_leaves(index, y)
        lighting = self._lighting()
        knobs = OrderedDict((key, list(v) if isinstance(v, tuple) else v)
                            for key, v in k.items() if key not in ('name', 'description'))
        look = Look(k['look_kind'], k['background'], k['look_variation'])
        return Scenario(k['name'], Track(points, k['backdrop_x']), lighting, self.fruits,
                        self.stems, self.leaves, int(k['seed']), k['description'], knobs,
                        look=look)

    def _plants(self, points):
        rng = self.rng
        y, y_end = points[0] - 0.6, points[-1] + 0.6
        i = 0
        while y <= y_end:
            x = self.k['stem_x'] + rng.uniform(-0.03, 0.03)
            self.stems.append(Stem('stem_%02d' % i, 'main', 0.008,
                                   [[x, y, 0.05], [x + rng.uniform(-0.03, 0.03), y, 2.3]]))
            i += 1
            y += rng.uniform(0.3, 0.4)

    def _main_stem_near(self, p):
        mains = [s for s in self.stems if s.kind == 'main']
        return min(mains, key=lambda s: abs(s.points[0][1] - p[1]))

    def _ripeness(self, ripe):
        k, rng = self.k, self.rng
        if rng.random() < k['borderline_fraction']:
            return round(float(rng.uniform(0.6, 0.8)), 3)
        lo, hi = k['ripe_range'] if ripe else k['unripe_range']
        return round(float(rng.uniform(lo, hi)), 3)

    def _view(self, index, y, n):
        k, rng = self.k, self.rng
        if n <= 0:
            return
        if k['ripe_per_view'] is not None:
            n_ripe = min(n, int(k['ripe_per_view']))
            ripe_flags = [True] * n_ripe + [False] * (n - n_ripe)
            rng.shuffle(ripe_flags)
        else:
            ripe_flags = [bool(rng.random() < k['ripe_fraction']) for _ in range(n)]
        per_cluster = 1 + int(round(k['cluster_density'] * 3))
        gap = 0.003 + (1.0 - k['cluster_density']) * 0.04
        eyes = stereo_eyes(self.geom, y)
        placed = 0
        cluster_no = 0
        while placed < n:
            size_class = self._size_class()
            # cherry tomatoes hang in long trusses: twice the fruit per truss
            size = min(per_cluster * (2 if size_class == 'cherry' else 1), n - placed)
            cluster_id = 'c%02d_%d' % (index, cluster_no)
            members = []
            for j in range(size):
                ripe = ripe_flags[placed + j]
                want_reach = bool(rng.random() >= k['unreachable_fraction'])
                if k['waist_fraction'] > 0.0 and rng.random() < k['waist_fraction']:
                    want_reach = WAIST_ONLY
                radius = round(float(rng.uniform(*SIZE_CLASSES[size_class])), 4)
                # cherry trusses are long and open: their fruit hang further apart
                pos = self._place(y, eyes, radius, members,
                                  gap + (0.012 if size_class == 'cherry' else 0.0), want_reach)
                fid = 'f%02d_%d' % (index, placed + j)
                members.append(Fruit(fid, pos, radius, self._ripeness(ripe), cluster_id,
                                     picking_point=index))
            self._truss(index, cluster_no, members)
            for f in members:
                f.reachable = reachability(self.geom, f.position, f.radius, y, f.peduncle)[0]
                if rng.random() < k['occlusion']:
                    self._occluding_leaf(f, eyes)
            self.fruits.extend(members)
            placed += size
            cluster_no += 1

    def _size_class(self):
        """Size class of the next truss (draws from the generator only for 'mixed')."""
        size = self.k['fruit_size']
        if size == 'mixed':
            return list(SIZE_CLASSES)[int(self.rng.integers(len(SIZE_CLASSES)))]
        return size

    def _place(self, y, eyes, radius, members, gap, want_reach):
        """A free position in view; want_reach True / False: reachable or not at waist 0,
        WAIST_ONLY: beside the fixed workspace, reachable only with the waist turned."""
        rng = self.rng
        best = None
        waist_only = want_reach == WAIST_ONLY
        view_x, half_y = (WAIST_VIEW_X, WAIST_VIEW_HALF_Y) if waist_only else (VIEW_X, VIEW_HALF_Y)
        for attempt in range(600):
            if members and attempt < 400 and not waist_only:
                a = members[int(rng.integers(len(members)))]
                d = _unit([rng.uniform(-0.4, 0.4), rng.uniform(-1, 1), rng.uniform(-1, 0.6)])
                p = a.position + d * (a.radius + radius + gap * rng.uniform(0.3, 1.2))
            else:
                p = np.array([rng.uniform(view_x[0] + radius, view_x[1] - radius),
                              y + rng.uniform(-half_y, half_y),
                              rng.uniform(*VIEW_Z)])
            p = np.round(p, 4)
            if not (view_x[0] <= p[0] <= view_x[1] and VIEW_Z[0] <= p[2] <= VIEW_Z[1] and
                    abs(p[1] - y) <= half_y):
                continue
            if any(np.linalg.norm(p - f.position) < f.radius + radius + 0.003
                   for f in self.fruits + members):
                continue
            if any(np.linalg.norm(p[:2] - f.position[:2]) < f.radius + radius and
                   abs(p[2] - f.position[2]) < 0.12 for f in self.fruits + members):
                continue          # keep the peduncle above each fruit free of other fruit
            if not fully_in_view(self.camera, eyes, p, radius):
                continue
            if best is None:
                best = p
            if waist_only:
                ok = not reachability(self.geom, p, radius, y, waist=False)[0] and \
                    reachability(self.geom, p, radius, y)[0]
            else:
                ok = reachability(self.geom, p, radius, y, waist=False)[0] == want_reach
            if ok or attempt >= 500:
                return p
        if best is None:
            raise RuntimeError('cannot place a fruit at picking point y=%.2f (view full?)' % y)
        return best

    def _truss(self, index, cluster_no, members):
        top = max(f.peduncle[2] for f in members) + self.rng.uniform(0.04, 0.07)
        cx = float(np.mean([f.position[0] for f in members]))
        cy = float(np.mean([f.position[1] for f in members]))
        node = np.round([cx + 0.03, cy, top], 4)
        main = self._main_stem_near(node)
        s = np.round([main.points[0][0], main.points[0][1], top + 0.08], 4)
        mid = np.round((s + node) / 2.0 + [0.0, 0.0, 0.03], 4)
        tid = 't%02d_%d' % (index, cluster_no)
        self.stems.append(Stem(tid, 'truss', 0.004, [s, mid, node]))
        for f in members:
            f.truss = tid
            f.pedicel_top = node.copy()

    def _leaf_colour(self):
        rng = self.rng
        return np.round([rng.uniform(0.18, 0.3), rng.uniform(0.42, 0.6),
                         rng.uniform(0.1, 0.2)], 3)

    def _occluding_leaf(self, fruit, eyes):
        rng = self.rng
        cam = (eyes[0][:3, 3] + eyes[1][:3, 3]) / 2.0
        ray = fruit.position - cam
        dist = np.linalg.norm(ray)
        ray /= dist
        length, width = rng.uniform(0.08, 0.14), rng.uniform(0.035, 0.055)
        centre = cam + ray * (dist - fruit.radius - rng.uniform(0.02, 0.05))
        side = _unit(np.cross(ray, [0.0, 0.0, 1.0]))
        up = np.cross(side, ray)
        ang = rng.uniform(0, 2 * math.pi)
        shift = rng.uniform(0.5, 0.9) * (width / 2.0 + fruit.radius)
        centre = centre + shift * (math.cos(ang) * side + math.sin(ang) * up)
        normal = _unit(-ray + rng.uniform(-0.3, 0.3, 3))
        axis = _unit(math.cos(ang + math.pi / 2) * side + math.sin(ang + math.pi / 2) * up +
                     rng.uniform(-0.2, 0.2, 3))
        lid = 'leaf_%s' % fruit.id
        self.leaves.append(Leaf(lid, np.round(centre, 4), normal, axis, length, width,
                                self._leaf_colour()))
        fruit.occluded_by.append(lid)

    def _filler_leaves(self, index, y):
        rng = self.rng
        for j in range(int(self.k['leaves_per_view'])):
            centre = np.round([rng.uniform(0.76, 0.92), y + rng.uniform(-0.35, 0.35),
                               rng.uniform(0.65, 1.35)], 4)
            normal = _unit([-1.0, rng.uniform(-0.4, 0.4), rng.uniform(-0.3, 0.5)])
            axis = _unit([0.0, rng.uniform(-1, 1), rng.uniform(-1, 0.2)])
            if np.linalg.norm(np.cross(normal, axis)) < 0.2:
                axis = _unit([0.0, 1.0, -0.3])
            self.leaves.append(Leaf('leaf_%02d_bg%d' % (index, j), centre, normal, axis,
                                    rng.uniform(0.09, 0.17), rng.uniform(0.04, 0.065),
                                    self._leaf_colour()))

    def _lighting(self):
        k, rng = self.k, self.rng
        v = float(k['lighting_variation'])
        intensity = k['intensity'] * (1.0 + v * rng.uniform(-0.5, 0.3))
        colour = np.clip(np.asarray(k['light_colour'], float) *
                         (1.0 + v * rng.uniform(-0.15, 0.15, 3)), 0.0, 2.0)
        direction = _unit(np.asarray(k['light_direction'], float) +
                          v * rng.uniform(-0.5, 0.5, 3))
        if direction[2] > -0.2:            # keep the light coming from above
            direction = _unit(direction + [0.0, 0.0, -0.5])
        return Lighting(round(intensity, 3), k['ambient'], np.round(colour, 3),
                        np.round(direction, 4))


def generate(knobs, geom):
    """Scenario from generator knobs (see DEFAULT_KNOBS) and a motion_pkg RobotGeometry.

    Deterministic: the same knobs (seed included) give the same scenario. The result is
    round-tripped through its YAML form, so it equals what load_scenario reads back.
    """
    full = knobs_for(**{key: v for key, v in knobs.items()})
    if full['fruit_size'] not in FRUIT_SIZES:
        raise ValueError('fruit_size must be one of %s, got %r'
                         % (', '.join(FRUIT_SIZES), full['fruit_size']))
    scenario = _Generator(full, geom).run()
    data = yaml.load(dump_scenario(scenario), Loader=yaml.SafeLoader)
    scenario = parse_scenario(data, '<generated %s>' % full['name'])
    return mark_reachability(scenario, geom)
