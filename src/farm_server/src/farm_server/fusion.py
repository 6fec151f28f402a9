"""Fusion of many robots' records over many days, the ripening forecast and the day's plan.

Pure Python (no web framework, no database): ``fuse()`` takes plain dicts as read by
``FarmDB.fusion_input()``.

Rows and picking points. A mission's ``site`` names the row its robot works (one track per row;
an empty site is the row ``default``). Picking point ``k`` of a row is where robots stop to scan;
its track position is the median ``track_position`` of the scans made there.

Fruit positions. A fruit is matched across days and robots by its position in the farm (map)
frame. Observations in a map frame (``map_frames``, default ``map``) are used as they are; in a
cart frame (``cart_frames``, default ``base_link``: on the cart, x toward the row, y along the
track) the cart's ``track_position`` is added to y, since the track runs along map +y.
Observations in any other frame, or without a 3D point, cannot be matched and are only counted.

Time of a sighting: its ROS ``stamp`` when it looks like calendar time (>= ``min_calendar_stamp``,
i.e. the robot ran on wall time), else the row's ``created`` wall-clock time (simulated time).

Matching (per row, in time order). Each scan (one robot, mission and picking point) is matched
one-to-one against the fruit not yet harvested: nearest pairs first, accepted when closer than
``match_tolerance``; an unmatched sighting starts a new fruit. A fruit's position follows its
latest sighting. A successful pick record (outcome PICKED) marks the nearest fruit within the
tolerance seen before it as harvested. A fruit not seen by a later scan of its own picking point
(the one nearest to it along the track) is ``missing`` (fallen, picked by hand, or hidden); it
comes back if it is seen again. Plant: ``round(y_map / plant_spacing)``, the plant whose stem is
nearest when plants stand ``plant_spacing`` apart along the row.

Ripening model (ripeness score 0 green .. 1 red, picking stage at ``ripe_score``): linear in
time from the latest sighting, s(t) = s_last + r (t - t_last). The rate r of a fruit seen at
least twice over at least ``min_fit_span_days`` is the least-squares slope of its own sightings
clamped to [min_rate, max_rate] per day; otherwise r = ``default_rate``. The forecast for a time
before the last sighting is the last score (no back-casting). ``ready_at`` = when s(t) reaches
``ripe_score``.

Plan for a robot and a day: the picking points of the robot's row (its latest mission's site,
unless given) where the expected pickable fruit at the start of work (``work_hour`` local time,
``utc_offset_hours`` from UTC) is at least ``min_expected``, plus points not scanned for
``revisit_days`` (new fruit may have set there), in travel order (increasing track position).
Expected pickable fruit of a point = fruit present there whose forecast is >= ``ripe_score``.
"""

import bisect
import collections
import datetime
import math

__all__ = ['FusionConfig', 'fuse', 'FarmState', 'day_start', 'day_of', 'OUTCOME_PICKED',
           'DEFAULT_ROW']

OUTCOME_PICKED = 0          # harvest_msgs/PickRecord.OUTCOME_PICKED
OUTCOME_NAMES = {0: 'picked', 1: 'unreachable', 2: 'lost', 3: 'failed', 4: 'dropped'}
DEFAULT_ROW = 'default'
DAY = 86400.0


class FusionConfig(object):
    """Parameters of matching, the ripening model and planning (see the module docstring)."""

    DEFAULTS = dict(
        match_tolerance=0.05,       # m, same fruit if closer than this in the map frame
        plant_spacing=0.35,         # m, plants along the row
        ripe_score=0.7,             # ripeness score of the picking stage
        default_rate=0.07,          # score per day when a fruit's own rate is unknown
        min_rate=0.01,              # score per day, clamp of a fitted rate
        max_rate=0.30,
        min_fit_span_days=0.5,      # sightings must span this long to fit a fruit's own rate
        min_expected=1.0,           # plan a point with at least this many pickable fruit
        revisit_days=7.0,           # plan a point not scanned for this long (0 = never)
        work_hour=6.0,              # local hour at which the day's work starts
        utc_offset_hours=0.0,       # local time - UTC
        min_calendar_stamp=1.0e9,   # s; smaller ROS stamps are simulated time
        cart_frames=('base_link',),
        map_frames=('map',),
    )

    def __init__(self, **kwargs):
        unknown = set(kwargs) - set(self.DEFAULTS)
        if unknown:
            raise ValueError('unknown fusion parameter(s): %s (known: %s)'
                             % (', '.join(sorted(unknown)), ', '.join(sorted(self.DEFAULTS))))
        for key, default in self.DEFAULTS.items():
            value = kwargs.get(key, default)
            if key.endswith('_frames'):
                value = tuple(str(v) for v in value)
            else:
                value = float(value)
                if not math.isfinite(value):
                    raise ValueError('fusion parameter %s must be finite' % key)
            setattr(self, key, value)
        for key in ('match_tolerance', 'plant_spacing', 'default_rate', 'max_rate'):
            if getattr(self, key) <= 0.0:
                raise ValueError('fusion parameter %s must be > 0' % key)
        if not 0.0 <= self.min_rate <= self.max_rate:
            raise ValueError('fusion parameters need 0 <= min_rate <= max_rate')
        if not 0.0 <= self.work_hour < 24.0:
            raise ValueError('work_hour must be in [0, 24)')

    def as_dict(self):
        return dict((k, list(getattr(self, k)) if k.endswith('_frames') else getattr(self, k))
                    for k in self.DEFAULTS)

    def key(self):
        return tuple(sorted((k, str(v)) for k, v in self.as_dict().items()))


# ----------------------------------------------------------------------------- time

def day_start(day, cfg):
    """Unix time at which work starts on ``day`` (a datetime.date) in the farm's local time."""
    midnight = datetime.datetime(day.year, day.month, day.day, tzinfo=datetime.timezone.utc)
    return midnight.timestamp() + (cfg.work_hour - cfg.utc_offset_hours) * 3600.0


def day_of(t, cfg):
    """The farm's local date of Unix time ``t``."""
    local = datetime.datetime.fromtimestamp(t + cfg.utc_offset_hours * 3600.0,
                                            tz=datetime.timezone.utc)
    return local.date()


def _day_end(day, cfg):
    midnight = datetime.datetime(day.year, day.month, day.day, tzinfo=datetime.timezone.utc)
    return midnight.timestamp() + DAY - cfg.utc_offset_hours * 3600.0


def sighting_time(stamp, created, cfg):
    return stamp if stamp >= cfg.min_calendar_stamp else created


# ----------------------------------------------------------------------------- model

class Fruit(object):
    __slots__ = ('fruit_id', 'row', 'position', 'history', 'status', 'harvested_at',
                 'harvested_by', 'point', 'last_scan', 'rate', 's_ref', 't_ref', 'fitted')

    def __init__(self, fruit_id, row, position):
        self.fruit_id = fruit_id
        self.row = row
        self.position = position
        self.history = []           # (t, score, stage, robot, mission_id, picking_point)
        self.status = 'present'
        self.harvested_at = None
        self.harvested_by = None
        self.point = None
        self.last_scan = None
        self.rate = self.s_ref = self.t_ref = None
        self.fitted = False

    @property
    def last_seen(self):
        return self.history[-1][0]

    def fit(self, cfg):
        """The linear ripening model (module docstring)."""
        ts = [h[0] / DAY for h in self.history]
        ss = [h[1] for h in self.history]
        span = ts[-1] - ts[0]
        if len(ts) >= 2 and span >= cfg.min_fit_span_days:
            tm = sum(ts) / len(ts)
            sm = sum(ss) / len(ss)
            var = sum((t - tm) ** 2 for t in ts)
            slope = sum((t - tm) * (s - sm) for t, s in zip(ts, ss)) / var
            self.rate = min(max(slope, cfg.min_rate), cfg.max_rate)
            self.fitted = True
        else:
            self.rate = cfg.default_rate
            self.fitted = False
        self.s_ref, self.t_ref = ss[-1], self.history[-1][0]

    def forecast(self, t):
        """Ripeness score expected at Unix time t (not before the last sighting)."""
        t = max(t, self.last_seen)
        return self.s_ref + self.rate * (t - self.t_ref) / DAY

    def ready_at(self, ripe_score):
        """Unix time at which the forecast reaches ``ripe_score``."""
        if self.forecast(self.last_seen) >= ripe_score:
            return self.last_seen
        if self.rate <= 0.0:
            return None
        return self.t_ref + (ripe_score - self.s_ref) / self.rate * DAY

    def plant(self, cfg):
        return int(round(self.position[1] / cfg.plant_spacing))


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


class FarmState(object):
    """Result of ``fuse()``: rows of points and fruit, and the harvest records."""

    def __init__(self, cfg, until, rows, missions, picks, unmatched_picks, skipped):
        self.cfg = cfg
        self.until = until
        self.rows = rows                    # name -> _Row
        self.missions = missions            # list of dicts (robot, mission_id, site, start)
        self.picks = picks                  # list of dicts (robot, row, outcome, cycle_time, t)
        self.unmatched_picks = unmatched_picks
        self.skipped = skipped              # sightings without a usable map position

    # ------------------------------------------------------------------ per point

    def expected_ripe(self, row, t):
        """{picking_point: number of present fruit forecast ripe at time t}."""
        out = dict((k, 0) for k in self.rows[row].points) if row in self.rows else {}
        if row not in self.rows:
            return out
        for fruit in self.rows[row].fruits:
            if fruit.status == 'present' and fruit.point is not None and \
                    fruit.forecast(t) >= self.cfg.ripe_score:
                out[fruit.point] += 1
        return out

    def point_table(self, row, t):
        """Per picking point of a row: position, fruit present, forecast ripe at t, last scan."""
        if row not in self.rows:
            return []
        r = self.rows[row]
        ripe = self.expected_ripe(row, t)
        present = dict((k, 0) for k in r.points)
        for fruit in r.fruits:
            if fruit.status == 'present' and fruit.point is not None:
                present[fruit.point] += 1
        out = []
        for k, p in r.points.items():
            if not p.positions:
                continue
            out.append(dict(picking_point=k, track_position=round(p.track_position, 4),
                            expected_ripe=ripe[k], fruit_present=present[k],
                            last_scan=p.last_scan, scans=len(p.scans),
                            unlocalised=p.unlocalised))
        out.sort(key=lambda d: (d['track_position'], d['picking_point']))
        return out

    def fruits(self, row, t, picking_point=None):
        """Fruit of a row grouped by picking point and plant, with histories and forecasts."""
        if row not in self.rows:
            return []
        cfg = self.cfg
        groups = {}
        for fruit in self.rows[row].fruits:
            if picking_point is not None and fruit.point != picking_point:
                continue
            ready = fruit.ready_at(cfg.ripe_score)
            entry = dict(
                fruit_id=fruit.fruit_id, status=fruit.status,
                position=[round(c, 4) for c in fruit.position],
                rate_per_day=round(fruit.rate, 4), rate_fitted=fruit.fitted,
                forecast_score=round(fruit.forecast(t), 4),
                ready_at=ready, ready_day=day_of(ready, cfg).isoformat() if ready else None,
                harvested_at=fruit.harvested_at, harvested_by=fruit.harvested_by,
                history=[dict(t=h[0], day=day_of(h[0], cfg).isoformat(), score=h[1],
                              stage=h[2], robot=h[3], mission_id=h[4], picking_point=h[5])
                         for h in fruit.history])
            groups.setdefault(fruit.point, {}).setdefault(fruit.plant(cfg), []).append(entry)
        out = []
        for k in sorted(groups, key=lambda v: (v is None, v)):
            plants = [dict(plant=pl, fruits=groups[k][pl]) for pl in sorted(groups[k])]
            out.append(dict(picking_point=k, plants=plants))
        return out

    # ------------------------------------------------------------------ robots and rows

    def robot_row(self, robot):
        """The row of the robot's latest mission (by start time), or None."""
        mine = [m for m in self.missions if m['robot'] == robot]
        if not mine:
            return None
        return max(mine, key=lambda m: m['start'])['row']

    def plan(self, robot, day, row=None):
        """The day's plan for ``robot`` (dict), or None when the robot has no data yet."""
        cfg = self.cfg
        row = row or self.robot_row(robot)
        if row is None or row not in self.rows:
            return None
        t = day_start(day, cfg)
        points = []
        for p in self.point_table(row, t):
            reasons = []
            if p['expected_ripe'] >= cfg.min_expected and p['expected_ripe'] > 0:
                reasons.append('ripe')
            if cfg.revisit_days > 0 and p['last_scan'] is not None and \
                    t - p['last_scan'] >= cfg.revisit_days * DAY:
                reasons.append('revisit')
            if reasons:
                p = dict(p, reasons=reasons)
                points.append(p)
        return dict(robot=robot, row=row, day=day.isoformat(), start_of_work=t,
                    picking_points=[p['picking_point'] for p in points], points=points,
                    expected_ripe=sum(p['expected_ripe'] for p in points))

    def yields(self, day=None):
        """Harvest figures per robot and per row (all time, and on ``day`` if given)."""
        cfg = self.cfg
        robots, rows = {}, {}
        for p in self.picks:
            r = robots.setdefault(p['robot'], dict(robot=p['robot'], attempts=0, picked=0,
                                                   picked_today=0, cycle_times=[],
                                                   outcomes=dict((n, 0) for n in
                                                                 OUTCOME_NAMES.values())))
            w = rows.setdefault(p['row'], dict(row=p['row'], picked=0, picked_today=0,
                                               attempts=0))
            r['attempts'] += 1
            w['attempts'] += 1
            r['outcomes'][OUTCOME_NAMES.get(p['outcome'], 'failed')] += 1
            if p['outcome'] == OUTCOME_PICKED:
                today = day is not None and day_of(p['t'], cfg) == day
                r['picked'] += 1
                w['picked'] += 1
                r['picked_today'] += int(today)
                w['picked_today'] += int(today)
                r['cycle_times'].append(p['cycle_time'])
        missions = collections.Counter(m['robot'] for m in self.missions)
        for r in robots.values():
            times = r.pop('cycle_times')
            r['mean_cycle_time'] = round(sum(times) / len(times), 3) if times else None
            r['success_rate'] = round(r['picked'] / float(r['attempts']), 3)
            r['missions'] = missions[r['robot']]
        for robot, count in missions.items():
            robots.setdefault(robot, dict(
                robot=robot, attempts=0, picked=0, picked_today=0, mean_cycle_time=None,
                success_rate=None, outcomes=dict((n, 0) for n in OUTCOME_NAMES.values()),
                missions=count))
        return (sorted(robots.values(), key=lambda r: r['robot']),
                sorted(rows.values(), key=lambda r: r['row']))


# ----------------------------------------------------------------------------- fusion

def _map_position(frame_id, x, y, z, track_position, cfg):
    if x is None or y is None or z is None:
        return None
    if frame_id in cfg.map_frames:
        return (x, y, z)
    if frame_id in cfg.cart_frames:
        return (x, y + track_position, z)
    return None


def fuse(missions, observations, picks, cfg, day=None):
    """Fuse every robot's records into a FarmState.

    missions/observations/picks: dicts as returned by FarmDB.fusion_input(). ``day``
    (datetime.date): use only records up to the end of that local day (None = all).
    """
    until = _day_end(day, cfg) if day is not None else None
    mission_row = {}
    mission_list = []
    for m in missions:
        row = m['site'] or DEFAULT_ROW
        mission_row[(m['robot'], m['mission_id'])] = row
        start = m['started'] if m['started'] is not None and \
            m['started'] >= cfg.min_calendar_stamp else m['created']
        if until is None or start < until:
            mission_list.append(dict(robot=m['robot'], mission_id=m['mission_id'], row=row,
                                     start=start))

    rows = {}
    scans = {}          # (row, robot, mission, point, created) -> [time, sightings]
    scan_track = {}     # (robot, mission, point) -> track position (for pick records)
    skipped = 0
    for o in observations:
        t = sighting_time(o['stamp'], o['created'], cfg)
        if until is not None and t >= until:
            continue
        row = mission_row.get((o['robot'], o['mission_id']), DEFAULT_ROW)
        r = rows.get(row)
        if r is None:
            r = rows[row] = _Row(row, cfg)
        point = r.point(o['picking_point'])
        point.positions.append(o['track_position'])
        scan_track[(o['robot'], o['mission_id'], o['picking_point'])] = o['track_position']
        # one scan = one store transaction (database_pkg writes a scan's tomatoes together,
        # with one `created` time); a mission may scan the same point again later
        key = (row, o['robot'], o['mission_id'], o['picking_point'], o['created'])
        entry = scans.get(key)
        if entry is None:
            entry = scans[key] = [t, []]
        entry[0] = min(entry[0], t)
        position = _map_position(o['frame_id'], o['x'], o['y'], o['z'], o['track_position'], cfg)
        if position is None:
            point.unlocalised += 1
            skipped += 1
            continue
        entry[1].append((position, o['ripeness_score'], o['ripeness_stage'], o['robot'],
                         o['mission_id'], o['picking_point'], o['id']))

    # one timeline per row: scans and successful picks, in time order (scans first on ties)
    timeline = []
    for (row, _robot, _mission, pp, _created), (t, sightings) in scans.items():
        rows[row].point(pp).scans.append(t)
        timeline.append((t, 0, row, sightings))
    pick_list = []
    unmatched = 0
    for p in picks:
        t = sighting_time(p['stamp'], p['created'], cfg)
        if until is not None and t >= until:
            continue
        row = mission_row.get((p['robot'], p['mission_id']), DEFAULT_ROW)
        pick_list.append(dict(robot=p['robot'], row=row, outcome=p['outcome'],
                              cycle_time=p['cycle_time'], t=t, mission_id=p['mission_id'],
                              picking_point=p['picking_point']))
        if p['outcome'] != OUTCOME_PICKED:
            continue
        track = scan_track.get((p['robot'], p['mission_id'], p['picking_point']))
        if track is None and row in rows and p['picking_point'] in rows[row].points and \
                rows[row].points[p['picking_point']].positions:
            track = rows[row].points[p['picking_point']].track_position
        position = None
        if track is not None:
            position = _map_position(p['frame_id'], p['x'], p['y'], p['z'], track, cfg)
        elif p['frame_id'] in cfg.map_frames:
            position = (p['x'], p['y'], p['z'])
        if position is None:
            unmatched += 1
            continue
        timeline.append((t, 1, row, (position, p['robot'])))
    timeline.sort(key=lambda e: (e[0], e[1]))
    for t, kind, row, payload in timeline:
        if kind == 0:
            if payload:
                rows[row].scan(t, payload)
        elif row not in rows or not rows[row].pick(t, payload[0], payload[1]):
            unmatched += 1
    for r in rows.values():
        r.finish()
    return FarmState(cfg, until, rows, mission_list, pick_list, unmatched, skipped)
