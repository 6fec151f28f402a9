"""Data model of a scenario: its constants and the plain classes read from a scenario file.

Track, lighting, camera look, stems, leaves and fruits (ripeness stages, peduncle) of the
simulated plant factory, and ScenarioError. The file format is in the docstring of
harvest_sim/scenario.py.
"""

from collections import OrderedDict

import numpy as np

RIPE_THRESHOLD = 0.7
#: (stage name, lowest ripeness of the stage)
STAGES = (('green', 0.0), ('turning', 0.25), ('pink', 0.5), ('red', 0.7))
RADIUS_RANGE = (0.010, 0.050)
#: fruit radius (m) of the generator's size classes ('mixed': one class per truss)
SIZE_CLASSES = OrderedDict([('cherry', (0.011, 0.016)), ('round', (0.028, 0.042)),
                            ('large', (0.040, 0.048))])
FRUIT_SIZES = tuple(SIZE_CLASSES) + ('mixed',)
#: camera look kinds (harvest_sim.look has the ranges of each; this module does not import it,
#: so that loading a scenario does not load OpenCV)
LOOK_KINDS = ('daylight', 'led', 'warm')
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
