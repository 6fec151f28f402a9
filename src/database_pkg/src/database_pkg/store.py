"""Local mission store of the data layer: an embedded SQLite file (no rospy here).

Every row of every table has a stable unique ``id`` (uuid4 hex), a ``created`` wall-clock time
(Unix seconds, time of insertion) and, from schema version 2, an ``uploaded`` flag for the
network uploader. Stamps that come from ROS messages (``stamp``, ``started``, ``ended``) are ROS
time in seconds, so they are simulated time when the robot runs under /use_sim_time.

Durability: the file is opened in WAL mode with ``synchronous=FULL`` by default. In WAL mode,
NORMAL already survives a crash of the process (a committed transaction is in the WAL file in the
OS page cache), but a power cut or kernel crash may lose the last commits, because NORMAL only
syncs the WAL at checkpoints. The robot can lose power in the field (emergency stop, battery),
and a record that the executive believes written must still be there afterwards, so the default
is FULL: one fsync of the WAL per commit. Our write rate is a few transactions per second, so
the cost is small (see benchmark/bench_store.py).

Atomicity: each public write method is one transaction. Input is validated completely before
anything is written, and any error inside the transaction rolls it back, so bad input raises
``ValueError`` and leaves the file unchanged.

Schema versions: ``PRAGMA user_version`` holds the number of migrations applied. Opening an older
file applies the missing migrations in order, each in its own transaction; opening a file written
by a newer version raises ``SchemaVersionError`` without touching the file. Released migrations
must never be edited: add a new one at the end of ``MIGRATIONS``.
"""

import json
import math
import numbers
import os
import sqlite3
import threading
import time
import uuid

__all__ = ['Store', 'StoreError', 'SchemaVersionError', 'MIGRATIONS', 'SCHEMA_VERSION',
           'OUTCOMES', 'RIPENESS_STAGES', 'PHASES']

# PickRecord.OUTCOME_* and Tomato.STAGE_* (harvest_msgs), repeated here so this module needs no ROS.
OUTCOMES = (0, 1, 2, 3, 4)
RIPENESS_STAGES = (0, 1, 2, 3)

SYNCHRONOUS_MODES = ('NORMAL', 'FULL', 'EXTRA')
TABLES = ('missions', 'observations', 'pick_records', 'events')     # the uploader's outbox
LOCAL_TABLES = ('checkpoints', )                                       # never uploaded
PHASES = ('', 'approach', 'suction', 'pull', 'cut', 'place', 'placed')  # Checkpoint.phase

# Ordered migrations: (version reached, description, statements). Never edit a released entry.
MIGRATIONS = (
    (1, 'missions, observations, pick records and events', (
        """CREATE TABLE missions (
            id TEXT PRIMARY KEY,
            created REAL NOT NULL,
            mission_id TEXT NOT NULL UNIQUE,
            started REAL,
            ended REAL,
            site TEXT NOT NULL DEFAULT '',
            summary TEXT NOT NULL DEFAULT ''
        )""",
        """CREATE TABLE observations (
            id TEXT PRIMARY KEY,
            created REAL NOT NULL,
            mission_id TEXT NOT NULL REFERENCES missions(mission_id),
            picking_point INTEGER NOT NULL,
            track_position REAL NOT NULL,
            detection_id INTEGER NOT NULL,
            x REAL, y REAL, z REAL,
            frame_id TEXT NOT NULL,
            radius REAL NOT NULL,
            ripeness_stage INTEGER NOT NULL,
            ripeness_score REAL NOT NULL,
            pickable INTEGER NOT NULL,
            pick_order INTEGER NOT NULL,
            stamp REAL NOT NULL,
            image_id TEXT NOT NULL
        )""",
        """CREATE TABLE pick_records (
            id TEXT PRIMARY KEY,
            created REAL NOT NULL,
            mission_id TEXT NOT NULL REFERENCES missions(mission_id),
            picking_point INTEGER NOT NULL,
            target_id INTEGER NOT NULL,
            x REAL NOT NULL, y REAL NOT NULL, z REAL NOT NULL,
            frame_id TEXT NOT NULL,
            outcome INTEGER NOT NULL,
            reason TEXT NOT NULL,
            state_names TEXT NOT NULL,
            state_durations TEXT NOT NULL,
            cycle_time REAL NOT NULL,
            stamp REAL NOT NULL
        )""",
        """CREATE TABLE events (
            id TEXT PRIMARY KEY,
            created REAL NOT NULL,
            mission_id TEXT NOT NULL REFERENCES missions(mission_id),
            stamp REAL NOT NULL,
            kind TEXT NOT NULL,
            state TEXT NOT NULL,
            detail TEXT NOT NULL
        )""",
    )),
    (2, 'uploaded flag for the network uploader; per-mission indices', (
        "ALTER TABLE missions ADD COLUMN uploaded INTEGER NOT NULL DEFAULT 0",
        "ALTER TABLE observations ADD COLUMN uploaded INTEGER NOT NULL DEFAULT 0",
        "ALTER TABLE pick_records ADD COLUMN uploaded INTEGER NOT NULL DEFAULT 0",
        "ALTER TABLE events ADD COLUMN uploaded INTEGER NOT NULL DEFAULT 0",
        "CREATE INDEX observations_by_mission ON observations(mission_id, picking_point)",
        "CREATE INDEX pick_records_by_mission ON pick_records(mission_id, stamp)",
        "CREATE INDEX events_by_mission ON events(mission_id, stamp)",
    )),
    # network_pkg's outbox: rows with uploaded = 0 are the queue (partial indices keep finding
    # and counting them cheap whatever the size of the uploaded history). Missions are the only
    # rows that change after insert: a change of started/ended/summary/site queues the mission
    # again and bumps its revision, so the uploader only marks uploaded the revision it sent and
    # the server keeps the highest revision.
    (3, 'outbox: pending-row indices; a changed mission is queued again with a new revision', (
        "ALTER TABLE missions ADD COLUMN revision INTEGER NOT NULL DEFAULT 0",
        "CREATE INDEX missions_pending ON missions(uploaded) WHERE uploaded = 0",
        "CREATE INDEX observations_pending ON observations(uploaded) WHERE uploaded = 0",
        "CREATE INDEX pick_records_pending ON pick_records(uploaded) WHERE uploaded = 0",
        "CREATE INDEX events_pending ON events(uploaded) WHERE uploaded = 0",
        """CREATE TRIGGER missions_changed AFTER UPDATE OF started, ended, summary, site
            ON missions
            WHEN OLD.started IS NOT NEW.started OR OLD.ended IS NOT NEW.ended
                 OR OLD.summary IS NOT NEW.summary OR OLD.site IS NOT NEW.site
            BEGIN
                UPDATE missions SET uploaded = 0, revision = OLD.revision + 1
                WHERE id = NEW.id;
            END""",
    )),
    # control_pkg's executive: where a restarted task planner continues (one row per mission,
    # replaced by every newer checkpoint; local only, not in the uploader's outbox)
    (4, 'checkpoints of the executive (crash-safe continuation)', (
        """CREATE TABLE checkpoints (
            id TEXT PRIMARY KEY,
            created REAL NOT NULL,
            updated REAL NOT NULL,
            mission_id TEXT NOT NULL UNIQUE REFERENCES missions(mission_id),
            robot TEXT NOT NULL,
            stamp REAL NOT NULL,
            points TEXT NOT NULL,
            point_index INTEGER NOT NULL,
            picking_point INTEGER NOT NULL,
            targets_done TEXT NOT NULL,
            target_id INTEGER NOT NULL,
            target_x REAL, target_y REAL, target_z REAL,
            phase TEXT NOT NULL,
            holding INTEGER NOT NULL,
            finished INTEGER NOT NULL,
            outcome TEXT NOT NULL
        )""",
        "CREATE INDEX checkpoints_unfinished ON checkpoints(robot, updated) WHERE finished = 0",
    )),
    # a pick record or event stored once however often it comes: the executive sends a
    # (re)started database_node every record and event of its mission again (nothing published
    # while the store was down is lost), and a file may hold copies from before (the first kept)
    (5, 'a pick record or event is stored once (the executive replays them to a new store)', (
        """DELETE FROM pick_records WHERE rowid NOT IN (SELECT MIN(rowid) FROM pick_records
            GROUP BY mission_id, picking_point, target_id, stamp)""",
        """CREATE UNIQUE INDEX pick_records_once
            ON pick_records(mission_id, picking_point, target_id, stamp)""",
        """DELETE FROM events WHERE rowid NOT IN (SELECT MIN(rowid) FROM events
            GROUP BY mission_id, stamp, kind, state, detail)""",
        "CREATE UNIQUE INDEX events_once ON events(mission_id, stamp, kind, state, detail)",
    )),
)
SCHEMA_VERSION = MIGRATIONS[-1][0]


class StoreError(RuntimeError):
    """The database file cannot be opened or used (not SQLite, unreadable, no WAL...)."""


class SchemaVersionError(StoreError):
    """The file was written by a newer schema version than this code knows."""


# ---------------------------------------------------------------- validation helpers

def _field(what, data, key):
    try:
        return data[key]
    except (KeyError, TypeError):
        raise ValueError('%s: missing field %r' % (what, key))


def _text(what, key, value, allow_empty=True):
    if not isinstance(value, str):
        raise ValueError('%s: %s must be a string, got %r' % (what, key, value))
    if not allow_empty and not value:
        raise ValueError('%s: %s must not be empty' % (what, key))
    return value


def _int(what, key, value):
    if isinstance(value, bool) or not isinstance(value, numbers.Integral):
        raise ValueError('%s: %s must be an integer, got %r' % (what, key, value))
    return int(value)


def _real(what, key, value, minimum=None, maximum=None):
    if isinstance(value, bool) or not isinstance(value, numbers.Real):
        raise ValueError('%s: %s must be a number, got %r' % (what, key, value))
    value = float(value)
    if not math.isfinite(value):
        raise ValueError('%s: %s must be finite, got %r' % (what, key, value))
    if minimum is not None and value < minimum:
        raise ValueError('%s: %s must be >= %g, got %g' % (what, key, minimum, value))
    if maximum is not None and value > maximum:
        raise ValueError('%s: %s must be <= %g, got %g' % (what, key, maximum, value))
    return value


def _position(what, value, allow_none):
    if value is None:
        if allow_none:
            return None, None, None
        raise ValueError('%s: position is required' % what)
    try:
        values = list(value)
    except TypeError:
        raise ValueError('%s: position must be a sequence of 3 numbers, got %r' % (what, value))
    if len(values) != 3:
        raise ValueError('%s: position must have 3 components, got %d' % (what, len(values)))
    return tuple(_real(what, 'position.' + axis, v) for axis, v in zip('xyz', values))


def _mission_id(what, data):
    return _text(what, 'mission_id', _field(what, data, 'mission_id'), allow_empty=False)


class Store(object):
    """The local store. Thread-safe: one connection, every call serialised by a lock.

    Several Store objects (threads or processes) may open the same file; SQLite's WAL mode and
    busy timeout arbitrate between them.
    """

    def __init__(self, path, synchronous='FULL', busy_timeout=5.0, clock=time.time):
        """Open (creating or upgrading) the store at ``path`` (':memory:' for a throw-away one).

        Raises SchemaVersionError for a file from a newer version, StoreError when the file
        cannot be used, ValueError for a bad argument.
        """
        synchronous = str(synchronous).upper()
        if synchronous not in SYNCHRONOUS_MODES:
            raise ValueError('synchronous must be one of %s, got %r'
                             % (', '.join(SYNCHRONOUS_MODES), synchronous))
        self.path = path
        self._clock = clock
        self._lock = threading.RLock()
        try:
            self._conn = sqlite3.connect(path, timeout=float(busy_timeout), isolation_level=None,
                                         check_same_thread=False)
        except sqlite3.Error as e:
            raise StoreError('cannot open database %s: %s' % (path, e))
        try:
            self._open(synchronous)
        except BaseException:
            self._conn.close()
            raise

    def _open(self, synchronous):
        conn = self._conn
        try:
            version = conn.execute('PRAGMA user_version').fetchone()[0]
        except sqlite3.DatabaseError as e:
            raise StoreError('%s is not a usable SQLite database: %s' % (self.path, e))
        if version > SCHEMA_VERSION:
            raise SchemaVersionError(
                'database %s has schema version %d but this database_pkg only knows versions up '
                'to %d: it was written by a newer version. Upgrade database_pkg or point db_path '
                'at another file.' % (self.path, version, SCHEMA_VERSION))
        if self.path != ':memory:':
            mode = conn.execute('PRAGMA journal_mode=WAL').fetchone()[0]
            if str(mode).lower() != 'wal':
                raise StoreError('cannot switch %s to WAL mode (journal_mode is %s)'
                                 % (self.path, mode))
        conn.execute('PRAGMA synchronous=%s' % synchronous)
        conn.execute('PRAGMA foreign_keys=ON')
        self._migrate()

    def _migrate(self):
        for target, _description, statements in MIGRATIONS:
            with self._transaction() as cur:
                # Re-read inside the write lock: another process may have migrated meanwhile.
                version = cur.execute('PRAGMA user_version').fetchone()[0]
                if version > SCHEMA_VERSION:
                    raise SchemaVersionError('database %s was upgraded to version %d by a newer '
                                             'version meanwhile' % (self.path, version))
                if version >= target:
                    continue
                if version != target - 1:
                    raise StoreError('database %s: cannot apply migration %d to version %d'
                                     % (self.path, target, version))
                for statement in statements:
                    cur.execute(statement)
                cur.execute('PRAGMA user_version=%d' % target)

    # ------------------------------------------------------------ plumbing

    class _Transaction(object):
        def __init__(self, store):
            self._store = store

        def __enter__(self):
            self._store._lock.acquire()
            try:
                self._cur = self._store._conn.cursor()
                self._cur.execute('BEGIN IMMEDIATE')
            except BaseException:
                self._store._lock.release()
                raise
            return self._cur

        def __exit__(self, exc_type, exc, tb):
            try:
                if exc_type is None:
                    try:
                        self._cur.execute('COMMIT')
                    except BaseException:
                        self._rollback()
                        raise
                else:
                    self._rollback()
            finally:
                self._store._lock.release()
            return False

        def _rollback(self):
            if self._store._conn.in_transaction:
                self._cur.execute('ROLLBACK')

    def _transaction(self):
        return Store._Transaction(self)

    def _query(self, sql, args=()):
        with self._lock:
            return self._conn.execute(sql, args).fetchall()

    def _new_id(self):
        return uuid.uuid4().hex

    def close(self):
        with self._lock:
            self._conn.close()

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()
        return False

    @property
    def schema_version(self):
        return self._query('PRAGMA user_version')[0][0]

    @property
    def journal_mode(self):
        return str(self._query('PRAGMA journal_mode')[0][0]).lower()

    @property
    def synchronous(self):
        return {0: 'OFF', 1: 'NORMAL', 2: 'FULL', 3: 'EXTRA'}[self._query('PRAGMA synchronous')[0][0]]

    # ------------------------------------------------------------ writes

    def _ensure_mission(self, cur, mission_id, stamp, site):
        """Create the mission row if needed; widen its start to ``stamp`` (> 0 only)."""
        now = self._clock()
        cur.execute('INSERT OR IGNORE INTO missions (id, created, mission_id, site) '
                    'VALUES (?, ?, ?, ?)', (self._new_id(), now, mission_id, site))
        if stamp is not None and stamp > 0.0:
            cur.execute('UPDATE missions SET started = ? WHERE mission_id = ? '
                        'AND (started IS NULL OR started > ?)', (stamp, mission_id, stamp))

    def ensure_mission(self, mission_id, started=None, site=''):
        """Create mission ``mission_id`` if it is new. Returns its row id."""
        what = 'mission'
        mission_id = _text(what, 'mission_id', mission_id, allow_empty=False)
        if started is not None:
            started = _real(what, 'started', started)
        site = _text(what, 'site', site)
        with self._transaction() as cur:
            self._ensure_mission(cur, mission_id, started, site)
            return cur.execute('SELECT id FROM missions WHERE mission_id = ?',
                               (mission_id,)).fetchone()[0]

    def end_mission(self, mission_id, ended, summary=''):
        """Mark a mission ended (creating it if needed) with an optional summary text."""
        what = 'mission'
        mission_id = _text(what, 'mission_id', mission_id, allow_empty=False)
        ended = _real(what, 'ended', ended)
        summary = _text(what, 'summary', summary)
        with self._transaction() as cur:
            self._ensure_mission(cur, mission_id, None, '')
            cur.execute('UPDATE missions SET ended = ?, summary = ? WHERE mission_id = ?',
                        (ended, summary, mission_id))

    @staticmethod
    def _check_observation(obs):
        what = 'observation'
        pickable = _field(what, obs, 'pickable')
        if not isinstance(pickable, (bool, int)) or isinstance(pickable, float):
            raise ValueError('%s: pickable must be a bool, got %r' % (what, pickable))
        pickable = bool(pickable)
        # A fruit without a valid 3D point (None) can only be a non-pickable one.
        x, y, z = _position(what, _field(what, obs, 'position'), allow_none=not pickable)
        stage = _int(what, 'ripeness_stage', _field(what, obs, 'ripeness_stage'))
        if stage not in RIPENESS_STAGES:
            raise ValueError('%s: ripeness_stage must be one of %s, got %d'
                             % (what, RIPENESS_STAGES, stage))
        pick_order = _int(what, 'pick_order', _field(what, obs, 'pick_order'))
        if pick_order < -1:
            raise ValueError('%s: pick_order must be >= -1, got %d' % (what, pick_order))
        return (
            _int(what, 'detection_id', _field(what, obs, 'detection_id')),
            x, y, z,
            _text(what, 'frame_id', _field(what, obs, 'frame_id'), allow_empty=x is None),
            _real(what, 'radius', _field(what, obs, 'radius'), minimum=0.0),
            stage,
            _real(what, 'ripeness_score', _field(what, obs, 'ripeness_score')),
            int(pickable),
            pick_order,
            _real(what, 'stamp', _field(what, obs, 'stamp'), minimum=0.0),
            _text(what, 'image_id', _field(what, obs, 'image_id')),
        )

    def add_observations(self, mission_id, picking_point, track_position, observations,
                         site=''):
        """Store the tomatoes seen at one picking point, all or none. Returns their ids.

        Each observation is a dict with detection_id, position ((x, y, z) or None when the
        fruit has no valid 3D point; only allowed when not pickable), frame_id, radius,
        ripeness_stage, ripeness_score, pickable, pick_order, stamp, image_id.
        """
        what = 'observations'
        mission_id = _text(what, 'mission_id', mission_id, allow_empty=False)
        picking_point = _int(what, 'picking_point', picking_point)
        track_position = _real(what, 'track_position', track_position)
        site = _text(what, 'site', site)
        rows = []
        for index, obs in enumerate(observations):
            try:
                rows.append(self._check_observation(obs))
            except ValueError as e:
                raise ValueError('tomato %d of %d: %s' % (index, len(observations), e))
        stamps = [row[-2] for row in rows if row[-2] > 0.0]
        ids = [self._new_id() for _ in rows]
        with self._transaction() as cur:
            self._ensure_mission(cur, mission_id, min(stamps) if stamps else None, site)
            now = self._clock()
            cur.executemany(
                'INSERT INTO observations (id, created, mission_id, picking_point, '
                'track_position, detection_id, x, y, z, frame_id, radius, ripeness_stage, '
                'ripeness_score, pickable, pick_order, stamp, image_id) '
                'VALUES (?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?)',
                [(row_id, now, mission_id, picking_point, track_position) + row
                 for row_id, row in zip(ids, rows)])
        return ids

    def add_pick_record(self, record, site=''):
        """Store one PickRecord (a dict, see harvest_msgs/PickRecord) once: the same record
        (mission, picking point, target, stamp) again changes nothing. Returns its id."""
        what = 'pick record'
        mission_id = _mission_id(what, record)
        x, y, z = _position(what, _field(what, record, 'position'), allow_none=False)
        outcome = _int(what, 'outcome', _field(what, record, 'outcome'))
        if outcome not in OUTCOMES:
            raise ValueError('%s: outcome must be one of %s, got %d' % (what, OUTCOMES, outcome))
        names = _field(what, record, 'state_names')
        durations = _field(what, record, 'state_durations')
        if isinstance(names, str) or isinstance(durations, str):
            raise ValueError('%s: state_names and state_durations must be lists' % what)
        names = [_text(what, 'state_names[%d]' % i, n) for i, n in enumerate(names)]
        durations = [_real(what, 'state_durations[%d]' % i, d, minimum=0.0)
                     for i, d in enumerate(durations)]
        if len(names) != len(durations):
            raise ValueError('%s: %d state names but %d state durations'
                             % (what, len(names), len(durations)))
        stamp = _real(what, 'stamp', _field(what, record, 'stamp'), minimum=0.0)
        row = (
            mission_id,
            _int(what, 'picking_point', _field(what, record, 'picking_point')),
            _int(what, 'target_id', _field(what, record, 'target_id')),
            x, y, z,
            _text(what, 'frame_id', _field(what, record, 'frame_id'), allow_empty=False),
            outcome,
            _text(what, 'reason', _field(what, record, 'reason')),
            json.dumps(names),
            json.dumps(durations),
            _real(what, 'cycle_time', _field(what, record, 'cycle_time'), minimum=0.0),
            stamp,
        )
        row_id = self._new_id()
        with self._transaction() as cur:
            self._ensure_mission(cur, mission_id, stamp, _text(what, 'site', site))
            cur.execute(
                'INSERT INTO pick_records (id, created, mission_id, picking_point, target_id, '
                'x, y, z, frame_id, outcome, reason, state_names, state_durations, cycle_time, '
                'stamp) VALUES (?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?) '
                'ON CONFLICT(mission_id, picking_point, target_id, stamp) DO NOTHING',
                (row_id, self._clock()) + row)
            if cur.rowcount == 0:
                row_id = cur.execute(
                    'SELECT id FROM pick_records WHERE mission_id = ? AND picking_point = ? AND '
                    'target_id = ? AND stamp = ?', (row[0], row[1], row[2], stamp)).fetchone()[0]
        return row_id

    def add_event(self, event, site=''):
        """Store one MissionEvent (a dict) once (the same mission, stamp, kind, state and detail
        again changes nothing). kind 'summary' also ends the mission. Returns its id."""
        what = 'event'
        mission_id = _mission_id(what, event)
        stamp = _real(what, 'stamp', _field(what, event, 'stamp'), minimum=0.0)
        kind = _text(what, 'kind', _field(what, event, 'kind'), allow_empty=False)
        state = _text(what, 'state', _field(what, event, 'state'))
        detail = _text(what, 'detail', _field(what, event, 'detail'))
        row_id = self._new_id()
        with self._transaction() as cur:
            self._ensure_mission(cur, mission_id, stamp, _text(what, 'site', site))
            cur.execute('INSERT INTO events (id, created, mission_id, stamp, kind, state, detail) '
                        'VALUES (?, ?, ?, ?, ?, ?, ?) '
                        'ON CONFLICT(mission_id, stamp, kind, state, detail) DO NOTHING',
                        (row_id, self._clock(), mission_id, stamp, kind, state, detail))
            if cur.rowcount == 0:
                return cur.execute(
                    'SELECT id FROM events WHERE mission_id = ? AND stamp = ? AND kind = ? AND '
                    'state = ? AND detail = ?', (mission_id, stamp, kind, state, detail)).fetchone()[0]
            if kind == 'summary':
                cur.execute('UPDATE missions SET ended = ?, summary = ? WHERE mission_id = ?',
                            (stamp, detail, mission_id))
        return row_id

    def put_checkpoint(self, checkpoint, site=''):
        """Store the executive's checkpoint of a mission (a dict), replacing the older one.

        Keys: mission_id, robot, stamp, points (ints), point_index, picking_point,
        targets_done ([(target_id, (x, y, z)), ...]), target_id (-1 = none), target_position
        ((x, y, z) or None), phase (one of PHASES), holding, finished, outcome.
        A finished checkpoint stays finished: a late unfinished one of the same mission is
        ignored. Returns True when it was stored.
        """
        what = 'checkpoint'
        mission_id = _mission_id(what, checkpoint)
        robot = _text(what, 'robot', _field(what, checkpoint, 'robot'))
        stamp = _real(what, 'stamp', _field(what, checkpoint, 'stamp'), minimum=0.0)
        points = _field(what, checkpoint, 'points')
        if isinstance(points, str):
            raise ValueError('%s: points must be a list' % what)
        points = [_int(what, 'points[%d]' % i, p) for i, p in enumerate(points)]
        point_index = _int(what, 'point_index', _field(what, checkpoint, 'point_index'))
        if point_index < -1 or point_index > len(points):
            raise ValueError('%s: point_index must be in [-1, %d], got %d'
                             % (what, len(points), point_index))
        done = []
        for i, item in enumerate(_field(what, checkpoint, 'targets_done')):
            try:
                target, position = item
            except (TypeError, ValueError):
                raise ValueError('%s: targets_done[%d] must be (target_id, (x, y, z))' % (what, i))
            done.append([_int(what, 'targets_done[%d]' % i, target),
                         list(_position(what, position, allow_none=False))])
        phase = _text(what, 'phase', _field(what, checkpoint, 'phase'))
        if phase not in PHASES:
            raise ValueError('%s: phase must be one of %s, got %r' % (what, PHASES, phase))
        holding = _field(what, checkpoint, 'holding')
        finished = _field(what, checkpoint, 'finished')
        for key, value in (('holding', holding), ('finished', finished)):
            if not isinstance(value, bool):
                raise ValueError('%s: %s must be a bool, got %r' % (what, key, value))
        tx, ty, tz = _position(what, _field(what, checkpoint, 'target_position'), allow_none=True)
        row = (robot, stamp, json.dumps(points), point_index,
               _int(what, 'picking_point', _field(what, checkpoint, 'picking_point')),
               json.dumps(done), _int(what, 'target_id', _field(what, checkpoint, 'target_id')),
               tx, ty, tz, phase, int(holding), int(finished),
               _text(what, 'outcome', _field(what, checkpoint, 'outcome')))
        with self._transaction() as cur:
            self._ensure_mission(cur, mission_id, stamp, _text(what, 'site', site))
            now = self._clock()
            cur.execute(
                'INSERT INTO checkpoints (id, created, updated, mission_id, robot, stamp, points, '
                'point_index, picking_point, targets_done, target_id, target_x, target_y, '
                'target_z, phase, holding, finished, outcome) '
                'VALUES (?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?) '
                'ON CONFLICT(mission_id) DO UPDATE SET updated = excluded.updated, '
                'robot = excluded.robot, stamp = excluded.stamp, points = excluded.points, '
                'point_index = excluded.point_index, picking_point = excluded.picking_point, '
                'targets_done = excluded.targets_done, target_id = excluded.target_id, '
                'target_x = excluded.target_x, target_y = excluded.target_y, '
                'target_z = excluded.target_z, phase = excluded.phase, '
                'holding = excluded.holding, finished = excluded.finished, '
                'outcome = excluded.outcome WHERE checkpoints.finished = 0',
                (self._new_id(), now, now, mission_id) + row)
            return cur.rowcount > 0

    # ------------------------------------------------------------ reads

    @staticmethod
    def _dicts(cursor_rows, columns):
        return [dict(zip(columns, row)) for row in cursor_rows]

    def _select(self, table, where, args, order):
        with self._lock:
            cur = self._conn.execute('SELECT * FROM %s WHERE %s ORDER BY %s'
                                     % (table, where, order), args)
            columns = [d[0] for d in cur.description]
            return self._dicts(cur.fetchall(), columns)

    def latest_mission_id(self):
        """The mission created last in this file (insertion order), or None."""
        rows = self._query('SELECT mission_id FROM missions ORDER BY rowid DESC LIMIT 1')
        return rows[0][0] if rows else None

    def missions(self):
        return self._select('missions', '1', (), 'rowid')

    def mission(self, mission_id):
        rows = self._select('missions', 'mission_id = ?', (mission_id,), 'rowid')
        return rows[0] if rows else None

    def observations(self, mission_id, picking_point=None):
        """Observation rows of a mission (one picking point if given), positions as tuples."""
        if picking_point is None:
            rows = self._select('observations', 'mission_id = ?', (mission_id,), 'rowid')
        else:
            rows = self._select('observations', 'mission_id = ? AND picking_point = ?',
                                (mission_id, picking_point), 'rowid')
        for row in rows:
            xyz = (row.pop('x'), row.pop('y'), row.pop('z'))
            row['position'] = None if xyz[0] is None else xyz
            row['pickable'] = bool(row['pickable'])
        return rows

    def pick_records(self, mission_id):
        rows = self._select('pick_records', 'mission_id = ?', (mission_id,), 'stamp, rowid')
        for row in rows:
            row['position'] = (row.pop('x'), row.pop('y'), row.pop('z'))
            row['state_names'] = json.loads(row['state_names'])
            row['state_durations'] = json.loads(row['state_durations'])
        return rows

    def events(self, mission_id):
        return self._select('events', 'mission_id = ?', (mission_id,), 'stamp, rowid')

    def mission_records(self, mission_id=''):
        """(mission_id, pick records, events) of a mission; '' = the latest one.

        Returns (None, [], []) when there is no such mission.
        """
        if not mission_id:
            mission_id = self.latest_mission_id()
            if mission_id is None:
                return None, [], []
        elif self.mission(mission_id) is None:
            return None, [], []
        return mission_id, self.pick_records(mission_id), self.events(mission_id)

    def checkpoint(self, mission_id):
        """The checkpoint of a mission (a dict, see put_checkpoint), or None."""
        rows = self._select('checkpoints', 'mission_id = ?', (mission_id,), 'rowid')
        return self._checkpoint_dict(rows[0]) if rows else None

    def latest_unfinished_checkpoint(self, robot=''):
        """The unfinished checkpoint of ``robot`` written last, or None."""
        rows = self._select('checkpoints', 'finished = 0 AND robot = ?', (robot,),
                            'updated DESC, rowid DESC LIMIT 1')
        return self._checkpoint_dict(rows[0]) if rows else None

    @staticmethod
    def _checkpoint_dict(row):
        row['points'] = json.loads(row['points'])
        row['targets_done'] = [(d[0], tuple(d[1])) for d in json.loads(row['targets_done'])]
        xyz = (row.pop('target_x'), row.pop('target_y'), row.pop('target_z'))
        row['target_position'] = None if xyz[0] is None else xyz
        row['holding'] = bool(row['holding'])
        row['finished'] = bool(row['finished'])
        return row

    def row_counts(self, tables=TABLES):
        """Rows per table (the outbox's TABLES unless given, e.g. TABLES + LOCAL_TABLES)."""
        with self._lock:
            return dict((t, self._conn.execute('SELECT COUNT(*) FROM %s' % t).fetchone()[0])
                        for t in tables)

    def file_size(self):
        """Bytes on disk: the database file plus its WAL (0 for ':memory:')."""
        total = 0
        for suffix in ('', '-wal'):
            try:
                total += os.path.getsize(self.path + suffix)
            except OSError:
                pass
        return total

    def integrity_check(self):
        return self._query('PRAGMA integrity_check')[0][0]
