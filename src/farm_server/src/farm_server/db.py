"""Farm server storage: SQLAlchemy Core over SQLite (embedded default) or PostgreSQL.

One code path for both: the only dialect-specific piece is the ``INSERT ... ON CONFLICT`` builder
(SQLAlchemy's sqlite and postgresql ``insert`` share one API) and, for SQLite, the connection
set-up (WAL, busy timeout, ``BEGIN IMMEDIATE`` for write transactions so that two concurrent
uploads queue on the database lock instead of failing on a stale read snapshot).

Schema versions and migrations are in ``db_schema`` (re-exported here).
"""

import hashlib
import json
import os
import secrets
import threading
import time

import sqlalchemy as sa
from sqlalchemy.dialects import postgresql as pg_dialect
from sqlalchemy.dialects import sqlite as sqlite_dialect

# Re-exported: ``farm_server.db`` keeps every name it had before the split.
from farm_server.db_schema import (METADATA, MIGRATIONS, RECORD_TABLES,  # noqa: F401
                                   SCHEMA_VERSION, TABLES, SchemaVersionError, _migration_1,
                                   _migrations_table, _tables_v1)

__all__ = ['FarmDB', 'MIGRATIONS', 'SCHEMA_VERSION', 'RECORD_TABLES', 'hash_token',
           'default_db_url']

# SQLite before 3.32 allows 999 bound parameters per statement (Ubuntu 20.04 ships 3.31).
_IN_CHUNK = 400


def default_db_url():
    path = os.path.expanduser(os.path.join('~', '.ros', 'harvest', 'farm_server.db'))
    return 'sqlite:///' + path


def hash_token(token):
    return hashlib.sha256(token.encode('utf-8')).hexdigest()


def new_token():
    """A random robot token (256 bits, URL-safe) that never starts with '-', so that it can
    be given on a command line (``--token TOKEN``) without being taken for an option."""
    while True:
        token = secrets.token_urlsafe(32)
        if not token.startswith('-'):
            return token


# ------------------------------------------------------------------------------- database

class FarmDB(object):
    """The farm database. Thread-safe (SQLAlchemy pools connections per thread)."""

    def __init__(self, url=None, sqlite_synchronous='FULL', echo=False):
        url = url or default_db_url()
        self.url = sa.engine.make_url(url)
        self.dialect = self.url.get_backend_name()
        if self.dialect not in ('sqlite', 'postgresql'):
            raise ValueError('unsupported database %r: use sqlite:///PATH or '
                             'postgresql://USER@HOST:PORT/DB' % self.dialect)
        kwargs = dict(echo=echo, future=True)
        if self.dialect == 'sqlite':
            database = self.url.database or ''
            if database and database != ':memory:':
                database = os.path.abspath(os.path.expanduser(database))
                parent = os.path.dirname(database)
                if parent and not os.path.isdir(parent):
                    os.makedirs(parent)
                self.url = self.url.set(database=database)
            kwargs['connect_args'] = {'timeout': 30.0, 'check_same_thread': False}
            self._insert = sqlite_dialect.insert
        else:
            kwargs.update(pool_pre_ping=True, pool_size=5, max_overflow=5)
            self._insert = pg_dialect.insert
        self.engine = sa.create_engine(self.url, **kwargs)
        if self.dialect == 'sqlite':
            self._sqlite_setup(sqlite_synchronous)
        self._write_lock = threading.Lock() if self.dialect == 'sqlite' else None
        self.migrate()

    # -------------------------------------------------------------- set-up and migrations

    def _sqlite_setup(self, synchronous):
        synchronous = str(synchronous).upper()
        if synchronous not in ('NORMAL', 'FULL'):
            raise ValueError('sqlite_synchronous must be NORMAL or FULL')

        @sa.event.listens_for(self.engine, 'connect')
        def _connect(dbapi_conn, _record):
            # Let SQLAlchemy, not pysqlite, issue BEGIN (pysqlite's implicit transactions
            # would defer the BEGIN and break transactional DDL and our IMMEDIATE writes).
            dbapi_conn.isolation_level = None
            cur = dbapi_conn.cursor()
            if self.url.database and self.url.database != ':memory:':
                cur.execute('PRAGMA journal_mode=WAL')
            cur.execute('PRAGMA synchronous=%s' % synchronous)
            cur.execute('PRAGMA busy_timeout=30000')
            cur.close()

        @sa.event.listens_for(self.engine, 'begin')
        def _begin(conn):
            mode = conn.get_execution_options().get('sqlite_begin', 'DEFERRED')
            conn.exec_driver_sql('BEGIN %s' % mode)

    def _writing(self):
        """A transaction for writes: BEGIN IMMEDIATE on SQLite, a plain one on PostgreSQL."""
        if self.dialect == 'sqlite':
            return self.engine.execution_options(sqlite_begin='IMMEDIATE').begin()
        return self.engine.begin()

    def schema_version(self):
        with self.engine.connect() as conn:
            if not sa.inspect(conn).has_table('schema_migrations'):
                return 0
            value = conn.execute(sa.select(sa.func.max(_migrations_table.c.version))).scalar()
            return int(value or 0)

    def migrate(self):
        with self._writing() as conn:
            _migrations_table.create(conn, checkfirst=True)
        for version, description, apply in MIGRATIONS:
            with self._writing() as conn:
                applied = conn.execute(sa.select(sa.func.max(
                    _migrations_table.c.version))).scalar() or 0
                if applied > SCHEMA_VERSION:
                    raise SchemaVersionError(
                        'database %s has schema version %d but this farm server knows versions '
                        'up to %d: upgrade network_pkg' % (self.safe_url(), applied,
                                                            SCHEMA_VERSION))
                if applied >= version:
                    continue
                apply(conn)
                conn.execute(_migrations_table.insert().values(
                    version=version, description=description, applied=time.time()))

    def safe_url(self):
        return self.url.render_as_string(hide_password=True)

    def dispose(self):
        self.engine.dispose()

    # -------------------------------------------------------------- robots and tokens

    def add_robot(self, name, token=None):
        """Register robot ``name`` (or give it a new token). Returns the token (store it!)."""
        token = token or new_token()
        robots = TABLES['robots']
        with self._writing() as conn:
            exists = conn.execute(sa.select(robots.c.name).where(robots.c.name == name)).first()
            if exists:
                conn.execute(robots.update().where(robots.c.name == name)
                             .values(token_sha256=hash_token(token)))
            else:
                conn.execute(robots.insert().values(name=name, token_sha256=hash_token(token),
                                                    created=time.time()))
        return token

    def remove_robot(self, name):
        robots = TABLES['robots']
        with self._writing() as conn:
            return conn.execute(robots.delete().where(robots.c.name == name)).rowcount > 0

    def robot_for_token(self, token):
        if not token:
            return None
        robots = TABLES['robots']
        with self.engine.connect() as conn:
            row = conn.execute(sa.select(robots.c.name).where(
                robots.c.token_sha256 == hash_token(token))).first()
        return row[0] if row else None

    def robots(self):
        robots = TABLES['robots']
        with self.engine.connect() as conn:
            rows = conn.execute(sa.select(robots.c.name, robots.c.created,
                                          robots.c.last_upload, robots.c.uploads,
                                          robots.c.rows_received)
                                .order_by(robots.c.name)).mappings().all()
        return [dict(r) for r in rows]

    # -------------------------------------------------------------- uploads

    def store_batch(self, robot, batch, attempts=3):
        """Store one batch atomically and idempotently (upsert by id).

        ``batch`` maps table name -> list of row dicts (wire format, without ``robot``).
        Record rows are immutable: an id already stored is left alone (first write wins).
        A mission row replaces the stored one only with a higher ``revision`` (same robot).
        Returns {'inserted': {table: n}, 'duplicates': n, 'rows': n}.

        New rows are found by reading which ids exist, then inserted with a plain multi-row
        INSERT (SQLAlchemy's "insertmanyvalues": one statement per 1000 rows on PostgreSQL;
        an ON CONFLICT clause would fall back to one round trip per row). SQLite writers are
        serialised, so the read is exact there; on PostgreSQL a concurrent upload of the same
        new ids (a retry racing its original) raises IntegrityError: the whole transaction is
        rolled back and tried again, and then sees those rows as existing.
        """
        for attempt in range(attempts):
            try:
                return self._store_batch(robot, batch)
            except sa.exc.IntegrityError:
                if attempt == attempts - 1:
                    raise

    def _store_batch(self, robot, batch):
        now = time.time()
        inserted = {}
        duplicates = 0
        total = 0
        lock = self._write_lock
        if lock is not None:
            lock.acquire()
        try:
            with self._writing() as conn:
                for name in RECORD_TABLES:
                    rows = batch.get(name) or []
                    if not rows:
                        inserted[name] = 0
                        continue
                    total += len(rows)
                    table = TABLES[name]
                    ids = [r['id'] for r in rows]
                    existing = set()
                    for start in range(0, len(ids), _IN_CHUNK):
                        chunk = ids[start:start + _IN_CHUNK]
                        existing.update(r[0] for r in conn.execute(
                            sa.select(table.c.id).where(table.c.id.in_(chunk))))
                    values = [self._row_values(name, robot, r, now) for r in rows]
                    new = [v for v in values if v['id'] not in existing]
                    if new:
                        conn.execute(table.insert(), new)
                    if name == 'missions' and len(new) < len(values):
                        # known missions: keep the highest revision, never another robot's
                        stmt = self._insert(table)
                        stmt = stmt.on_conflict_do_update(
                            index_elements=[table.c.id],
                            set_=dict((c, stmt.excluded[c]) for c in (
                                'started', 'ended', 'site', 'summary', 'revision', 'received')),
                            where=sa.and_(table.c.revision < stmt.excluded.revision,
                                          table.c.robot == stmt.excluded.robot))
                        conn.execute(stmt, [v for v in values if v['id'] in existing])
                    inserted[name] = len(new)
                    duplicates += len(values) - len(new)
                robots = TABLES['robots']
                conn.execute(robots.update().where(robots.c.name == robot).values(
                    last_upload=now, uploads=robots.c.uploads + 1,
                    rows_received=robots.c.rows_received + total))
        finally:
            if lock is not None:
                lock.release()
        return {'inserted': inserted, 'duplicates': duplicates, 'rows': total}

    @staticmethod
    def _row_values(name, robot, row, now):
        values = dict(row)
        values['robot'] = robot
        values['received'] = now
        if name == 'pick_records':
            values['state_names'] = json.dumps(list(values['state_names']))
            values['state_durations'] = json.dumps(list(values['state_durations']))
        return values

    # -------------------------------------------------------------- reads

    def rows(self, name, robot=None):
        """Every row of a record table (optionally one robot's), as dicts, in id order."""
        table = TABLES[name]
        query = sa.select(table).order_by(table.c.id)
        if robot is not None:
            query = query.where(table.c.robot == robot)
        with self.engine.connect() as conn:
            rows = [dict(r) for r in conn.execute(query).mappings()]
        if name == 'pick_records':
            for r in rows:
                r['state_names'] = json.loads(r['state_names'])
                r['state_durations'] = json.loads(r['state_durations'])
        return rows

    def counts(self):
        with self.engine.connect() as conn:
            return dict((name, conn.execute(sa.select(sa.func.count()).select_from(
                TABLES[name])).scalar()) for name in RECORD_TABLES)

    def fusion_input(self):
        """(missions, observations, pick_records) as plain dicts for the fusion module
        (only the columns fusion needs)."""
        m, o, p = TABLES['missions'], TABLES['observations'], TABLES['pick_records']
        with self.engine.connect() as conn:
            missions = [dict(r) for r in conn.execute(sa.select(
                m.c.robot, m.c.mission_id, m.c.site, m.c.started, m.c.created,
                m.c.revision)).mappings()]
            q = sa.select(o.c.id, o.c.robot, o.c.mission_id, o.c.picking_point,
                          o.c.track_position, o.c.x, o.c.y, o.c.z, o.c.frame_id,
                          o.c.ripeness_stage, o.c.ripeness_score, o.c.stamp, o.c.created)
            observations = [dict(r) for r in conn.execute(q.order_by(o.c.created)).mappings()]
            q = sa.select(p.c.id, p.c.robot, p.c.mission_id, p.c.picking_point, p.c.x, p.c.y,
                          p.c.z, p.c.frame_id, p.c.outcome, p.c.cycle_time, p.c.stamp,
                          p.c.created)
            picks = [dict(r) for r in conn.execute(q).mappings()]
        return missions, observations, picks

    def data_version(self):
        """A cheap value that changes whenever records are added (used to cache fusion)."""
        r = TABLES['robots']
        with self.engine.connect() as conn:
            row = conn.execute(sa.select(sa.func.coalesce(sa.func.sum(r.c.rows_received), 0),
                                         sa.func.coalesce(sa.func.max(r.c.last_upload), 0.0),
                                         sa.func.count())).first()
        return tuple(row)
