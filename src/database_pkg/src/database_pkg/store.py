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
anything is written (``database_pkg.rows``), and any error inside the transaction rolls it back,
so bad input raises ``ValueError`` and leaves the file unchanged.

Schema versions and migrations: ``database_pkg.schema`` (its names are importable from here too).
"""

import os
import sqlite3
import threading
import time
import uuid

from database_pkg.rows import (_int, _real, _text, checkpoint_dict, checkpoint_row, event_row,
                               observation_dict, observation_row, pick_record_dict,
                               pick_record_row)
from database_pkg.schema import (LOCAL_TABLES, MIGRATIONS, OUTCOMES, PHASES,  # noqa: F401
                                 RIPENESS_STAGES, SCHEMA_VERSION, SYNCHRONOUS_MODES, TABLES,
                                 SchemaVersionError, StoreError)

__all__ = ['Store', 'StoreError', 'SchemaVersionError', 'MIGRATIONS', 'SCHEMA_VERSION',
           'OUTCOMES', 'RIPENESS_STAGES', 'PHASES']


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
                rows.append(observation_row(obs))
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
        row = pick_record_row(record)
        mission_id, stamp = row[0], row[-1]
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
        mission_id, stamp, kind, state, detail = event_row(event)
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
        mission_id, stamp, row = checkpoint_row(checkpoint)
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
        return [observation_dict(row) for row in rows]

    def pick_records(self, mission_id):
        rows = self._select('pick_records', 'mission_id = ?', (mission_id,), 'stamp, rowid')
        return [pick_record_dict(row) for row in rows]

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
        return checkpoint_dict(rows[0]) if rows else None

    def latest_unfinished_checkpoint(self, robot=''):
        """The unfinished checkpoint of ``robot`` written last, or None."""
        rows = self._select('checkpoints', 'finished = 0 AND robot = ?', (robot,),
                            'updated DESC, rowid DESC LIMIT 1')
        return checkpoint_dict(rows[0]) if rows else None

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
