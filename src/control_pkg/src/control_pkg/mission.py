"""Mission bookkeeping for the executive, free of ROS: picking-point progress and the mission record.

The record keeps, per fruit, the time spent in each state and the outcome (picked, unreachable,
lost, failed with reason), and per run the totals that `make demo` prints.
"""
import datetime
import json
import math
import threading

OUTCOME_PICKED = 'picked'
OUTCOME_UNREACHABLE = 'unreachable'
OUTCOME_LOST = 'lost'
OUTCOME_FAILED = 'failed'
OUTCOMES = (OUTCOME_PICKED, OUTCOME_UNREACHABLE, OUTCOME_LOST, OUTCOME_FAILED)


class Progress(object):
    """Which picking point the mission is at; survives an emergency stop and a resume.

    `points` is the ordered list of picking-point indices to visit. `advance()` moves to the next
    one; after a resume the current point is visited again (re-scanned), so the interrupted target,
    still hanging, is the first one picked.
    """

    def __init__(self, points=None, loader=None):
        """Either the `points` list now, or a `loader()` returning it at the first advance()."""
        self.points = None
        self._loader = loader
        if points is not None:
            self._set(points)
        elif loader is None:
            raise ValueError('Progress needs picking points or a loader')
        self.index = -1          # index into self.points of the current point, -1 before the first
        self.interrupted = False

    def _set(self, points):
        points = list(points)
        for p in points:
            if not isinstance(p, int) or isinstance(p, bool) or p < 0:
                raise ValueError('picking points must be non-negative integers, got %r' % (p,))
        self.points = points

    def advance(self):
        """Return the next picking point to visit, or None when the mission is complete."""
        if self.points is None:
            self._set(self._loader())
        if self.interrupted:
            self.interrupted = False
            if 0 <= self.index < len(self.points):
                return self.points[self.index]
        self.index += 1
        if self.index < len(self.points):
            return self.points[self.index]
        return None

    def current(self):
        if self.points is not None and 0 <= self.index < len(self.points):
            return self.points[self.index]
        return None

    def mark_interrupted(self):
        self.interrupted = True


class FruitRecord(object):
    """The states one target went through and how it ended."""

    def __init__(self, picking_point, target_id, position, start_time):
        self.picking_point = picking_point
        self.target_id = target_id
        self.position = position
        self.start_time = start_time
        self.state_names = []
        self.state_durations = []
        self.outcome = None
        self.reason = ''
        self.end_time = None

    @property
    def cycle_time(self):
        if self.end_time is None:
            return float('nan')
        return self.end_time - self.start_time


class MissionRecorder(object):
    """Collects per-fruit records and mission totals. Times are plain seconds (ROS time).

    Thread-safe: states of a Concurrence report from several threads.
    """

    def __init__(self, mission_id):
        self.mission_id = mission_id
        self.fruits = []
        self.current = None
        self.start_time = None
        self.end_time = None
        self.points_visited = 0
        self.errors = []
        self._lock = threading.Lock()

    def start(self, now):
        with self._lock:
            if self.start_time is None:
                self.start_time = now

    def finish(self, now):
        with self._lock:
            self.end_time = now

    def visit_point(self):
        with self._lock:
            self.points_visited += 1

    def begin_fruit(self, picking_point, target_id, position, now):
        with self._lock:
            self.current = FruitRecord(picking_point, target_id, position, now)
            return self.current

    def add_state(self, name, duration):
        """Account `duration` seconds of state `name` to the fruit being picked, if any."""
        if duration < 0 or math.isnan(duration):
            raise ValueError('state duration must be a non-negative number, got %r' % (duration,))
        with self._lock:
            if self.current is not None:
                self.current.state_names.append(name)
                self.current.state_durations.append(duration)

    def end_fruit(self, outcome, now, reason=''):
        """Close the current fruit's record and return it (None when no fruit was open)."""
        if outcome not in OUTCOMES:
            raise ValueError('unknown fruit outcome %r (expected one of %s)' % (outcome, ', '.join(OUTCOMES)))
        with self._lock:
            record = self.current
            if record is None:
                return None
            record.outcome = outcome
            record.reason = reason
            record.end_time = now
            self.fruits.append(record)
            self.current = None
            return record

    def note_error(self, reason):
        with self._lock:
            self.errors.append(reason)

    def count(self, outcome):
        return sum(1 for f in self.fruits if f.outcome == outcome)

    def mean_cycle_time(self):
        """Mean time per picked fruit [s], NaN when nothing was picked."""
        times = [f.cycle_time for f in self.fruits if f.outcome == OUTCOME_PICKED]
        if not times:
            return float('nan')
        return sum(times) / len(times)

    def totals(self):
        return {
            'mission_id': self.mission_id,
            'points_visited': self.points_visited,
            'attempted': len(self.fruits),
            'picked': self.count(OUTCOME_PICKED),
            'unreachable': self.count(OUTCOME_UNREACHABLE),
            'lost': self.count(OUTCOME_LOST),
            'failed': self.count(OUTCOME_FAILED),
            'mean_cycle_time': finite_or_none(self.mean_cycle_time()),     # None: nothing picked
            'duration': finite_or_none((self.end_time - self.start_time)
                                       if (self.start_time is not None and self.end_time is not None)
                                       else None),
            'errors': list(self.errors),
        }


def finite_or_none(value):
    """value when it is a finite number, else None (JSON null): strict JSON has no NaN."""
    if isinstance(value, (int, float)) and not isinstance(value, bool) and not math.isfinite(value):
        return None
    return value


def _strict(value):
    if isinstance(value, dict):
        return dict((k, _strict(v)) for k, v in value.items())
    if isinstance(value, (list, tuple)):
        return [_strict(v) for v in value]
    return finite_or_none(value)


def summary_json(totals):
    """The mission summary as strict JSON: NaN and infinities become null (never `NaN`)."""
    return json.dumps(_strict(totals), default=str, allow_nan=False)


def make_mission_id(wall_time, token):
    """A mission id unique across runs and readable: UTC start (wall clock) and a random token.

    wall_time: seconds since the epoch (time.time(); not ROS time, which is 0 under
    /use_sim_time before the first /clock and restarts with each simulation); token: a short
    string (e.g. 4 hex digits) telling apart missions started in the same second.
    E.g. 'mission-20240521T081530Z-3fa9'.
    """
    if not isinstance(wall_time, (int, float)) or not math.isfinite(wall_time) or wall_time <= 0:
        raise ValueError('wall_time must be a positive number of seconds, got %r' % (wall_time,))
    if not token:
        raise ValueError('token must not be empty')
    stamp = datetime.datetime.fromtimestamp(wall_time, datetime.timezone.utc).strftime('%Y%m%dT%H%M%SZ')
    return 'mission-%s-%s' % (stamp, token)


def summary_line(picked, ripe_reachable, damaged, skipped, mean_cycle, wall):
    """The closing line of `make demo`."""
    cycle = 'n/a' if mean_cycle is None or math.isnan(mean_cycle) else '%.1f' % mean_cycle
    return ('mission: picked %d of %d ripe reachable, damaged %d, skipped %d, '
            'mean cycle %s s/fruit (sim), wall %.0f s' % (picked, ripe_reachable, damaged, skipped, cycle, wall))


def distance(a, b):
    """Euclidean distance of two 3D points given as sequences."""
    return math.sqrt((a[0] - b[0]) ** 2 + (a[1] - b[1]) ** 2 + (a[2] - b[2]) ** 2)


def choose_pull(centre, radius, obstacles, candidates, clearance=0.0, cut_height=0.01, cut_clearance=0.01):
    """The first pull in ``candidates`` that leaves a held fruit clear of every other fruit.

    centre, radius: the held fruit (base frame, m). obstacles: (centre, radius) of the other
    fruit seen at this picking point and still there. candidates: displacement vectors in order
    of preference. A pull is clear when, where it ends, the fruit's sphere is ``clearance`` away
    from each obstacle's sphere (one that already touches it must not come closer) and the cut
    point (``cut_height`` above the fruit's top, where the shear closes) is ``cut_clearance``
    outside every obstacle. The way there is not checked: fruit of a truss give way to each
    other; what must not happen is the shear closing in another fruit.
    Returns the vector (tuple) or None when none is clear (then the fruit is cut where it hangs).
    """
    cx, cy, cz = (float(v) for v in centre)
    r = float(radius)
    obs = [((float(o[0][0]), float(o[0][1]), float(o[0][2])), float(o[1])) for o in obstacles]
    dist = distance
    for cand in candidates:
        dx, dy, dz = (float(v) for v in cand)
        end = (cx + dx, cy + dy, cz + dz)
        cut = (end[0], end[1], end[2] + r + cut_height)
        if all(dist(end, o) >= min(r + orad + clearance, dist((cx, cy, cz), o)) and
               dist(cut, o) >= orad + cut_clearance for o, orad in obs):
            return (dx, dy, dz)
    return None
