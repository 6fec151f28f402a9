"""Matching of fruit sightings across scans within a row: picking points, the position grid,
one-to-one nearest matching of a scan, pick records harvesting fruit, missing fruit.

Pure Python; the rules are described in the ``fusion`` module docstring.
"""

import bisect
import math

from farm_server.ripening import Fruit


class Point(object):
    __slots__ = ('picking_point', 'positions', 'scans', 'unlocalised')

    def __init__(self, picking_point):
        self.picking_point = picking_point
        self.positions = []
        self.scans = []             # scan times, sorted at the end
        self.unlocalised = 0

    @property
    def track_position(self):
        p = sorted(self.positions)
        n = len(p)
        return p[n // 2] if n % 2 else 0.5 * (p[n // 2 - 1] + p[n // 2])

    @property
    def last_scan(self):
        return self.scans[-1] if self.scans else None


class _Grid(object):
    """Fruit indices bucketed by position cells of the match tolerance (3D hashing)."""

    def __init__(self, cell):
        self.cell = cell
        self.cells = {}

    def _key(self, p):
        return tuple(int(math.floor(c / self.cell)) for c in p)

    def add(self, index, p):
        self.cells.setdefault(self._key(p), []).append(index)

    def remove(self, index, p):
        bucket = self.cells.get(self._key(p))
        if bucket and index in bucket:
            bucket.remove(index)

    def near(self, p):
        kx, ky, kz = self._key(p)
        for dx in (-1, 0, 1):
            for dy in (-1, 0, 1):
                for dz in (-1, 0, 1):
                    for index in self.cells.get((kx + dx, ky + dy, kz + dz), ()):
                        yield index


def _distance(a, b):
    return math.sqrt((a[0] - b[0]) ** 2 + (a[1] - b[1]) ** 2 + (a[2] - b[2]) ** 2)


class _Row(object):
    def __init__(self, name, cfg):
        self.name = name
        self.cfg = cfg
        self.points = {}
        self.fruits = []
        self.grid = _Grid(cfg.match_tolerance)

    def point(self, k):
        if k not in self.points:
            self.points[k] = Point(k)
        return self.points[k]

    def candidates(self, p, t):
        tol = self.cfg.match_tolerance
        for index in set(self.grid.near(p)):
            fruit = self.fruits[index]
            if fruit.status != 'harvested' and fruit.last_seen <= t:
                d = _distance(p, fruit.position)
                if d <= tol:
                    yield d, index

    def scan(self, t, sightings):
        """One scan: sightings = [(position, score, stage, robot, mission, point, obs_id)]."""
        pairs = []
        for si, s in enumerate(sightings):
            for d, fi in self.candidates(s[0], t):
                pairs.append((d, si, fi))
        pairs.sort()
        used_s, used_f = set(), set()
        assignment = {}
        for _d, si, fi in pairs:
            if si in used_s or fi in used_f:
                continue
            used_s.add(si)
            used_f.add(fi)
            assignment[si] = fi
        for si, s in enumerate(sightings):
            position, score, stage, robot, mission, pp, obs_id = s
            fi = assignment.get(si)
            if fi is None:
                fi = len(self.fruits)
                fruit = Fruit(obs_id, self.name, position)
                self.fruits.append(fruit)
            else:
                fruit = self.fruits[fi]
                self.grid.remove(fi, fruit.position)
                fruit.position = position
                fruit.status = 'present'
            self.grid.add(fi, position)
            fruit.history.append((t, score, stage, robot, mission, pp))
            fruit.last_scan = t

    def pick(self, t, position, robot):
        best = min(self.candidates(position, t), default=None)
        if best is not None:
            fruit = self.fruits[best[1]]
            fruit.status = 'harvested'
            fruit.harvested_at = t
            fruit.harvested_by = robot
            return True
        return False

    def finish(self):
        """Assign each fruit its picking point, decide missing ones, fit the model."""
        cfg = self.cfg
        layout = sorted((p.track_position, k) for k, p in self.points.items() if p.positions)
        positions = [tp for tp, _k in layout]
        for point in self.points.values():
            point.scans.sort()
        for fruit in self.fruits:
            if layout:
                i = bisect.bisect_left(positions, fruit.position[1])
                near = [j for j in (i - 1, i) if 0 <= j < len(layout)]
                j = min(near, key=lambda j: abs(positions[j] - fruit.position[1]))
                fruit.point = layout[j][1]
            if fruit.status == 'present' and fruit.point is not None:
                last = self.points[fruit.point].last_scan
                if last is not None and last > fruit.last_scan:
                    fruit.status = 'missing'
            fruit.fit(cfg)

