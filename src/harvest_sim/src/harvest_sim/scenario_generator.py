"""Procedural generation of scenarios: generator knobs, the shipped presets and the generator.

generate() makes a scenario deterministically from knobs (seed included) and a motion_pkg
RobotGeometry; PRESETS are the knobs of the files in scenarios/.
"""

import copy
import math
from collections import OrderedDict

import numpy as np
import yaml

from harvest_sim import camera_model
from harvest_sim.scenario_model import (FRUIT_SIZES, SIZE_CLASSES, VIEW_HALF_Y, VIEW_X, VIEW_Z,
                                        WAIST_ONLY, WAIST_VIEW_HALF_Y, WAIST_VIEW_X, Fruit,
                                        Leaf, Lighting, Look, Scenario, Stem, Track)
from harvest_sim.scenario_reach import (fully_in_view, mark_reachability, reachability,
                                        stereo_eyes)
from harvest_sim.scenario_yaml import dump_scenario, parse_scenario

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
