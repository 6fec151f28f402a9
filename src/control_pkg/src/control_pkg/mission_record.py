"""The mission record, free of ROS: per fruit the time spent in each state and the outcome.

The record keeps, per fruit, the time spent in each state and the outcome (picked, unreachable,
lost, failed with reason), one record per fruit even when an emergency stop cut an attempt short,
and per run the totals that `make demo` prints; the summary as strict JSON and the mission id.

Re-exported by control_pkg.mission.
"""
import datetime
import json
import math
import threading

from harvest_msgs.msg import PickRecord

from control_pkg.mission_planning import distance

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
