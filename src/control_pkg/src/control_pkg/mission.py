"""Mission bookkeeping for the executive, free of ROS: picking-point progress and the mission record.

The record keeps, per fruit, the time spent in each state and the outcome (picked, unreachable,
lost, failed with reason), one record per fruit even when an emergency stop cut an attempt short,
and per run the totals that `make demo` prints.
"""
import datetime
import json
import math
import threading

from harvest_msgs.msg import PickRecord

#: the one outcome enum: harvest_msgs/PickRecord's OUTCOME_* constants (the wire contract); a
#: fruit's outcome here is the constant's name in lower case (OUTCOME_PICKED = 0 -> 'picked')
OUTCOME_NAMES = dict((getattr(PickRecord, c), c[len('OUTCOME_'):].lower())
                     for c in dir(PickRecord) if c.startswith('OUTCOME_'))
OUTCOME_CODES = dict((name, code) for code, name in OUTCOME_NAMES.items())
OUTCOME_PICKED = OUTCOME_NAMES[PickRecord.OUTCOME_PICKED]
OUTCOME_UNREACHABLE = OUTCOME_NAMES[PickRecord.OUTCOME_UNREACHABLE]
OUTCOME_LOST = OUTCOME_NAMES[PickRecord.OUTCOME_LOST]
OUTCOME_FAILED = OUTCOME_NAMES[PickRecord.OUTCOME_FAILED]
OUTCOME_DROPPED = OUTCOME_NAMES[PickRecord.OUTCOME_DROPPED]     # cut, then lost on the way to the box
#: every outcome, in the order of their codes (the summary's counts come in this order)
OUTCOMES = tuple(OUTCOME_NAMES[code] for code in sorted(OUTCOME_NAMES))
#: the state label a fruit's record shows where an emergency stop cut its attempt short (0 s)
STOP_STATE = 'DO_STOP'
#: the reason of a fruit whose attempt an emergency stop cut short and that was not tried again
INTERRUPTED = 'interrupted by emergency stop'


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

    def resume_at(self, points, index):
        """Continue a plan after a restart of the executive: the next advance() returns
        points[index] again (scanned again), then the points after it."""
        self._set(points)
        if not 0 <= int(index) <= len(self.points):
            raise ValueError('resume index %r outside the plan of %d points' % (index, len(self.points)))
        self.index = int(index)
        self.interrupted = True


class FruitRecord(object):
    """The states one target went through and how it ended.

    An attempt an emergency stop cut short leaves the record open (`interruptions`, a DO_STOP
    state of 0 s where it stopped); the time until the fruit is taken again (`paused`: the
    pause, the self-test and the new scan) is not its cycle time."""

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
        self.interruptions = 0
        self.interrupted_at = None
        self.paused = 0.0

    @property
    def attempts(self):
        return self.interruptions + 1

    @property
    def cycle_time(self):
        if self.end_time is None:
            return float('nan')
        return self.end_time - self.start_time - self.paused


class MissionRecorder(object):
    """Collects per-fruit records and mission totals. Times are plain seconds (ROS time).

    Thread-safe: states of a Concurrence report from several threads.

    One fruit, one record: an attempt an emergency stop cuts short (`interrupt`) is no outcome;
    the record waits in `interrupted` and goes on when the fruit is taken again (`begin_fruit`
    at the same picking point within `same_fruit` m: target ids of two scans may differ), or is
    closed `failed` (INTERRUPTED) once the mission leaves that point without it
    (`close_interrupted`).
    """

    def __init__(self, mission_id, same_fruit=0.03):
        self.mission_id = mission_id
        self.same_fruit = float(same_fruit)
        self.fruits = []
        self.current = None
        self.interrupted = []
        self.start_time = None
        self.end_time = None
        self.points_visited = 0
        self.errors = []
        self.steps = {}            # pipelined schedule: {step: [overlapped, in the paper order]}
        self._lock = threading.Lock()

    def start(self, now):
        with self._lock:
            if self.start_time is None:
                self.start_time = now

    def finish(self, now):
        with self._lock:
            self.end_time = now

    def restore(self, records, points_visited=0):
        """A mission continued after a restart: the fruit recorded before it (tuples of
        picking_point, target_id, position, outcome, reason, cycle_time) count in the totals."""
        with self._lock:
            for point, target, position, outcome, reason, cycle in records:
                if outcome not in OUTCOMES:
                    raise ValueError('unknown fruit outcome %r' % (outcome, ))
                fruit = FruitRecord(point, target, tuple(position), 0.0)
                fruit.outcome, fruit.reason, fruit.end_time = outcome, reason, float(cycle)
                self.fruits.append(fruit)
            self.points_visited = int(points_visited)

    def visit_point(self):
        with self._lock:
            self.points_visited += 1

    def begin_fruit(self, picking_point, target_id, position, now):
        """Open the record of a target taken; the record an emergency stop left open when the
        target is that fruit again (then with this scan's id and position)."""
        with self._lock:
            record = self._reopen(picking_point, position)
            if record is None:
                record = FruitRecord(picking_point, target_id, position, now)
            else:
                record.paused += max(0.0, now - record.interrupted_at)
                record.interrupted_at = None
                record.target_id, record.position = target_id, position
            self.current = record
            return record

    def _reopen(self, picking_point, position):
        near = [(distance(r.position, position), i) for i, r in enumerate(self.interrupted)
                if r.picking_point == picking_point]
        near = [d_i for d_i in near if d_i[0] <= self.same_fruit]
        if not near:
            return None
        return self.interrupted.pop(min(near)[1])

    def interrupt(self, now):
        """An emergency stop cut the current fruit's attempt short: its record stays open
        (returned; None when no fruit was open) until the fruit is taken again."""
        with self._lock:
            record = self.current
            if record is None:
                return None
            record.state_names.append(STOP_STATE)
            record.state_durations.append(0.0)
            record.interruptions += 1
            record.interrupted_at = now
            self.interrupted.append(record)
            self.current = None
            return record

    def close_interrupted(self, reason, keep_point=None, record=None):
        """Close as `failed` (`reason`) every record an emergency stop left open (only `record`
        when given), but those of picking point `keep_point`; each ends where it was stopped.
        Returns them."""
        with self._lock:
            closed = [r for r in self.interrupted if r.picking_point != keep_point and
                      (record is None or r is record)]
            self.interrupted = [r for r in self.interrupted if r not in closed]
            for fruit in closed:
                fruit.outcome, fruit.reason = OUTCOME_FAILED, reason
                fruit.end_time, fruit.interrupted_at = fruit.interrupted_at, None
                self.fruits.append(fruit)
            return closed

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

    def note_step(self, step, overlapped):
        """Count one step of the pipelined schedule, overlapped or in the paper's order."""
        with self._lock:
            counts = self.steps.setdefault(step, [0, 0])
            counts[0 if overlapped else 1] += 1

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

    def interruptions(self):
        """How many fruit attempts an emergency stop cut short."""
        with self._lock:
            records = self.fruits + self.interrupted + ([self.current] if self.current else [])
            return sum(r.interruptions for r in records)

    def totals(self):
        totals = self._totals()
        interrupted = self.interruptions()
        if interrupted:            # only after an emergency stop: otherwise the summary is unchanged
            totals['interrupted'] = interrupted
        if self.steps:             # the pipelined schedule only: the paper's summary is unchanged
            with self._lock:
                totals['overlaps'] = dict((k, {'overlapped': v[0], 'sequential': v[1]})
                                          for k, v in sorted(self.steps.items()))
        return totals

    def _totals(self):
        totals = {
            'mission_id': self.mission_id,
            'points_visited': self.points_visited,
            'attempted': len(self.fruits),
        }
        totals.update((outcome, self.count(outcome)) for outcome in OUTCOMES)   # 'picked': n, ...
        totals.update([
            ('mean_cycle_time', finite_or_none(self.mean_cycle_time())),     # None: nothing picked
            ('duration', finite_or_none((self.end_time - self.start_time)
                                        if (self.start_time is not None and self.end_time is not None)
                                        else None)),
            ('errors', list(self.errors)),
        ])
        return totals


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


# --- the pipelined schedule: may two arm moves run at once? --------------------------------------
SCHEDULE_PAPER = 'paper'
SCHEDULE_PIPELINED = 'pipelined'
SCHEDULES = (SCHEDULE_PAPER, SCHEDULE_PIPELINED)


def trapezoid_position(start, goal, speed, acceleration, t):
    """Where an axis moving rest to rest from `start` to `goal` with a trapezoidal (or
    triangular) speed profile, `speed` and `acceleration` > 0, is `t` seconds (a number or a
    numpy array) after it set off."""
    import numpy as np
    dist = goal - start
    d = abs(dist)
    t = np.asarray(t, dtype=float)
    if d == 0.0:
        return start + 0.0 * t
    sign = 1.0 if dist > 0.0 else -1.0
    t_acc = speed / acceleration
    if d < speed * t_acc:                       # triangle: top speed never reached
        t_acc = math.sqrt(d / acceleration)
        speed = acceleration * t_acc
    total = 2.0 * t_acc + (d - speed * t_acc) / speed
    tc = np.clip(t, 0.0, total)
    s = np.where(tc < t_acc, 0.5 * acceleration * tc * tc,
                 np.where(tc < total - t_acc, 0.5 * speed * t_acc + speed * (tc - t_acc),
                          d - 0.5 * acceleration * (total - tc) ** 2))
    return start + sign * s


def arm_path(start, goal, speeds, accelerations, dt):
    """Joint configurations (n x 3 array of lift, boom, forearm) every `dt` seconds of an arm
    moving from `start` to `goal`, each axis on its own trapezoid (as the motion controller runs
    them: every axis at its own speed, all starting together), both ends included. A resting
    arm (no goal, or goal == start) is its start alone."""
    import numpy as np
    start = tuple(float(v) for v in start)
    if goal is None:
        return np.array([start])
    goal = tuple(float(v) for v in goal)
    times = []
    for a, b, v, acc in zip(start, goal, speeds, accelerations):
        d = abs(b - a)
        times.append(0.0 if d == 0.0 else
                     (d / v + v / acc if d >= v * v / acc else 2.0 * math.sqrt(d / acc)))
    total = max(times)
    steps = max(1, int(math.ceil(total / dt)))
    t = np.linspace(0.0, total, steps + 1)
    return np.stack([trapezoid_position(a, b, v, acc, t)
                     for a, b, v, acc in zip(start, goal, speeds, accelerations)], axis=1)


def _segments_distance_2d(a0, a1, b0, b1):
    """Shortest distances (n x m) between the 2-D segments a0[i]-a1[i] and b0[j]-b1[j]
    (arrays n x 2 and m x 2)."""
    import numpy as np

    def point_segment2(px, py, sx, sy, ex, ey):
        """Squared distances of points (px, py) to segments (sx, sy)-(ex, ey), broadcast."""
        dx, dy = ex - sx, ey - sy
        dd = np.maximum(dx * dx + dy * dy, 1e-30)
        t = np.clip(((px - sx) * dx + (py - sy) * dy) / dd, 0.0, 1.0)
        qx, qy = px - sx - dx * t, py - sy - dy * t
        return qx * qx + qy * qy

    ax0, ay0 = a0[:, 0:1], a0[:, 1:2]          # n x 1
    ax1, ay1 = a1[:, 0:1], a1[:, 1:2]
    bx0, by0 = b0[None, :, 0], b0[None, :, 1]  # 1 x m
    bx1, by1 = b1[None, :, 0], b1[None, :, 1]
    best = np.minimum(np.minimum(point_segment2(ax0, ay0, bx0, by0, bx1, by1),
                                 point_segment2(ax1, ay1, bx0, by0, bx1, by1)),
                      np.minimum(point_segment2(bx0, by0, ax0, ay0, ax1, ay1),
                                 point_segment2(bx1, by1, ax0, ay0, ax1, ay1)))

    def cross(ox, oy, px, py, qx, qy):
        return (px - ox) * (qy - oy) - (py - oy) * (qx - ox)
    crossing = (cross(ax0, ay0, ax1, ay1, bx0, by0) * cross(ax0, ay0, ax1, ay1, bx1, by1) < 0.0) & \
        (cross(bx0, by0, bx1, by1, ax0, ay0) * cross(bx0, by0, bx1, by1, ax1, ay1) < 0.0)
    return np.where(crossing, 0.0, np.sqrt(best))


def arm_segments(geometry, arm, configs):
    """The forearm+tool segments of `arm` in `configs` ((lift, boom, forearm) each), vectorised:
    (elbow xy (n x 2), tool xy (n x 2), height (n)), the points RobotGeometry.arm_points gives
    (the segment motion_pkg's kinematics keeps `arm_clearance` from the other arm's)."""
    import numpy as np
    base, elbow0, _ = geometry.arm_points(arm, 0.0, 0.0, 0.0)
    yaw = math.atan2(elbow0[1] - base[1], elbow0[0] - base[0])
    q = np.asarray(configs, dtype=float).reshape(-1, 3)
    a1 = yaw + q[:, 1]
    a2 = a1 + q[:, 2]
    elbow = base[:2] + geometry.boom * np.stack([np.cos(a1), np.sin(a1)], axis=1)
    tip = elbow + (geometry.forearm + geometry.tool) * np.stack([np.cos(a2), np.sin(a2)], axis=1)
    return elbow, tip, base[2] + q[:, 0]


def thin_path(segments, spacing):
    """Indices of the samples of a path (arm_segments) to keep so that every sample is within
    `spacing` m of a kept one: the way each end of the forearm+tool segment and its height have
    come since the last kept sample stays below `spacing` (a point of a segment moves at most
    as far as its farther end)."""
    import numpy as np
    elbow, tip, z = segments
    if len(z) < 3:
        return list(range(len(z)))
    step = np.maximum(np.hypot(*(elbow[1:] - elbow[:-1]).T), np.hypot(*(tip[1:] - tip[:-1]).T))
    step = np.hypot(step, np.diff(z))
    travelled = np.concatenate([[0.0], np.cumsum(step)])
    keep = np.flatnonzero(np.diff(np.floor(travelled / spacing), prepend=-1.0) > 0).tolist()
    if keep[-1] != len(z) - 1:
        keep.append(len(z) - 1)
    return keep


def arms_min_distance(geometry, left_configs, right_configs, spacing=0.0):
    """The smallest distance between the left arm's forearm+tool segment in any of
    `left_configs` and the right arm's in any of `right_configs` (every pair, whatever the
    timing); with `spacing` > 0 only samples about that many metres of travel apart are
    compared (thin_path), and the result can then be up to 2 * `spacing` larger. The segments are
    horizontal, so a pair's distance is the plane distance combined with their difference in
    height."""
    import numpy as np
    segs = []
    for arm, configs in (('left', left_configs), ('right', right_configs)):
        elbow, tip, z = arm_segments(geometry, arm, configs)
        if spacing > 0.0:
            keep = thin_path((elbow, tip, z), spacing)
            elbow, tip, z = elbow[keep], tip[keep], z[keep]
        segs.append((elbow, tip, z))
    (le, lt, lz), (re_, rt, rz) = segs
    plane = _segments_distance_2d(le, lt, re_, rt)
    dz = lz[:, None] - rz[None, :]
    return float(np.sqrt(plane * plane + dz * dz).min())


class OverlapVerdict(object):
    """Whether two arm moves may run at once (`clear`), the smallest distance found between the
    arms over both paths (m, None when not computed) and why not (text)."""

    def __init__(self, clear, distance=None, why=''):
        self.clear = clear
        self.distance = distance
        self.why = why


#: m: arms that start closer than the clearance (both hands at one fruit) may overlap moves
#: that never bring them more than this closer than they start
START_TOLERANCE = 0.001


def overlap_clear(geometry, starts, goals, clearance, resolution=0.01, floor=None):
    """May the two arms move from `starts` to `goals` ({'left': joints, 'right': joints};
    a goal None = that arm rests) at the same time?

    Every configuration each arm passes through (its axes on their trapezoids at robot.yaml's
    speeds and accelerations, sampled so that every configuration is within `resolution` / 2
    of a sample) is checked against every configuration of the other arm, whatever the timing
    (either arm may start late, pause or be halted), on the forearm+tool segments that
    motion_pkg's kinematics keeps `arm_clearance` apart. Clear when the smallest distance found
    is `clearance` + `resolution` (the sampling's own error), or, for arms that start closer
    than that (both hands at one fruit), when they never come closer than they start; and in
    any case `floor` (default `clearance`) + `resolution`. An unknown start is not clear."""
    floor = clearance if floor is None else floor
    for arm in ('left', 'right'):
        if starts.get(arm) is None:
            return OverlapVerdict(False, why='%s arm position unknown' % arm)
        if goals.get(arm) is not None and len(goals[arm]) != 3:
            # a 4th value turns the waist, and both arms with it: never beside another move
            return OverlapVerdict(False, why='the %s arm\'s move turns the waist' % arm)
    speeds = [geometry.speed[j] for j in ('lift', 'boom', 'forearm')]
    accel = geometry.config.get('motion', {}).get('acceleration', {})
    accels = [float(accel.get(j, 3.0 * v)) for j, v in zip(('lift', 'boom', 'forearm'), speeds)]
    # fine samples (no point of the segment moves more than `resolution` / 8 between two, at
    # the axes' top speeds), thinned to those 3/8 `resolution` of travel apart: every
    # configuration of an arm on its way is within `resolution` / 2 of a compared one
    reach = geometry.boom + geometry.forearm + geometry.tool
    tool_speed = speeds[0] + reach * speeds[1] + (geometry.forearm + geometry.tool) * speeds[2]
    dt = resolution / 8.0 / tool_speed
    paths = {arm: arm_path(starts[arm], goals.get(arm), speeds, accels, dt)
             for arm in ('left', 'right')}
    distance = arms_min_distance(geometry, paths['left'], paths['right'], 0.375 * resolution)
    at_start = arms_min_distance(geometry, paths['left'][:1], paths['right'][:1])
    if distance < floor + resolution:
        return OverlapVerdict(False, distance, 'the arms would come %.3f m close (< %.3f m)'
                              % (distance, floor + resolution))
    if distance < clearance + resolution and distance < at_start - START_TOLERANCE:
        return OverlapVerdict(False, distance, 'the arms would come %.3f m close (< %.3f m, and '
                              'closer than the %.3f m they start at)'
                              % (distance, clearance + resolution, at_start))
    return OverlapVerdict(True, distance)


#: rad: a joint goal's waist angle this close to the waist's is no waist move
WAIST_TOLERANCE = 1e-3


def without_waist(goal, waist):
    """An arm's joint goal as [lift, boom, forearm] when its optional 4th value (the waist angle
    the move turns to) is where the waist already is (`waist`, rad; None: unknown); else as it
    is (a waist move: both arms turn with it)."""
    if goal is None or len(goal) != 4 or waist is None:
        return goal
    return tuple(goal[:3]) if abs(float(goal[3]) - float(waist)) <= WAIST_TOLERANCE else goal


def schedule_step(geometry, starts, goals, margin=0.0, waist=None):
    """The pipelined schedule's guard of one overlap: may the arms move from `starts` to `goals`
    at once (overlap_clear with robot.yaml's `arm_clearance` + `margin`)? A goal that turns the
    waist from `waist` never overlaps; without the robot's geometry nothing does."""
    if geometry is None:
        return OverlapVerdict(False, why='no robot geometry for the collision check')
    goals = dict((arm, without_waist(g, waist)) for arm, g in goals.items())
    return overlap_clear(geometry, starts, goals, float(geometry.arm_clearance) + float(margin),
                         floor=float(geometry.arm_clearance))
