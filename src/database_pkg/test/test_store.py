"""Unit tests of database_pkg.store (no ROS)."""
import math
import os
import signal
import sqlite3
import subprocess
import sys
import textwrap
import threading

import pytest

SRC = os.path.join(os.path.dirname(os.path.abspath(__file__)), '..', 'src')
try:
    from database_pkg import store as store_mod
except ImportError:  # not built / devel not sourced: use the source tree
    sys.path.insert(0, SRC)
    from database_pkg import store as store_mod

Store = store_mod.Store

# Schema version 1 exactly as released. Frozen here on purpose: if someone edits migration 1,
# files written by the released version must still upgrade.
V1_SCHEMA = """
CREATE TABLE missions (
    id TEXT PRIMARY KEY, created REAL NOT NULL, mission_id TEXT NOT NULL UNIQUE,
    started REAL, ended REAL, site TEXT NOT NULL DEFAULT '', summary TEXT NOT NULL DEFAULT '');
CREATE TABLE observations (
    id TEXT PRIMARY KEY, created REAL NOT NULL,
    mission_id TEXT NOT NULL REFERENCES missions(mission_id),
    picking_point INTEGER NOT NULL, track_position REAL NOT NULL, detection_id INTEGER NOT NULL,
    x REAL, y REAL, z REAL, frame_id TEXT NOT NULL, radius REAL NOT NULL,
    ripeness_stage INTEGER NOT NULL, ripeness_score REAL NOT NULL, pickable INTEGER NOT NULL,
    pick_order INTEGER NOT NULL, stamp REAL NOT NULL, image_id TEXT NOT NULL);
CREATE TABLE pick_records (
    id TEXT PRIMARY KEY, created REAL NOT NULL,
    mission_id TEXT NOT NULL REFERENCES missions(mission_id),
    picking_point INTEGER NOT NULL, target_id INTEGER NOT NULL,
    x REAL NOT NULL, y REAL NOT NULL, z REAL NOT NULL, frame_id TEXT NOT NULL,
    outcome INTEGER NOT NULL, reason TEXT NOT NULL, state_names TEXT NOT NULL,
    state_durations TEXT NOT NULL, cycle_time REAL NOT NULL, stamp REAL NOT NULL);
CREATE TABLE events (
    id TEXT PRIMARY KEY, created REAL NOT NULL,
    mission_id TEXT NOT NULL REFERENCES missions(mission_id),
    stamp REAL NOT NULL, kind TEXT NOT NULL, state TEXT NOT NULL, detail TEXT NOT NULL);
PRAGMA user_version = 1;
"""


def observation(i=0, **overrides):
    obs = dict(detection_id=i, position=(0.5, 0.1 * i, 0.9), frame_id='base_link', radius=0.035,
               ripeness_stage=3, ripeness_score=0.9, pickable=True, pick_order=i,
               stamp=100.0 + i, image_id='img-100')
    obs.update(overrides)
    return obs


def pick_record(i=0, mission_id='m1', **overrides):
    rec = dict(mission_id=mission_id, picking_point=2, target_id=i, position=(0.5, 0.2, 0.95),
               frame_id='base_link', outcome=0, reason='', state_names=['DO_KINEMATICS',
                                                                       'DO_MOVE_ROBOT'],
               state_durations=[0.4, 2.5], cycle_time=2.9, stamp=200.0 + i)
    rec.update(overrides)
    return rec


def event(kind='state', mission_id='m1', stamp=50.0, **overrides):
    ev = dict(mission_id=mission_id, stamp=stamp, kind=kind, state='DO_START', detail='go')
    ev.update(overrides)
    return ev


@pytest.fixture
def db_path(tmp_path):
    return str(tmp_path / 'harvest.db')


@pytest.fixture
def store(db_path):
    s = Store(db_path)
    yield s
    s.close()


def raw(path):
    return sqlite3.connect(path)


def columns(conn, table):
    return [row[1] for row in conn.execute('PRAGMA table_info(%s)' % table)]


def old_file(path, version):
    """An open connection to a new file at schema `version` (the released migrations up to it,
    never edited), for upgrade tests to fill with rows of that version."""
    conn = sqlite3.connect(path)
    for reached, _description, statements in store_mod.MIGRATIONS[:version]:
        for statement in statements:
            conn.execute(statement)
        conn.execute('PRAGMA user_version=%d' % reached)
    return conn


# ---------------------------------------------------------------- schema and migrations

def test_migrations_are_numbered_in_order():
    assert [m[0] for m in store_mod.MIGRATIONS] == list(range(1, len(store_mod.MIGRATIONS) + 1))
    assert store_mod.SCHEMA_VERSION == len(store_mod.MIGRATIONS)


@pytest.mark.parametrize('existing', [False, True], ids=['no file', 'empty file'])
def test_new_file_is_migrated_to_current(tmp_path, existing):
    path = str(tmp_path / 'new.db')
    if existing:
        open(path, 'wb').close()
    with Store(path) as s:
        assert s.schema_version == store_mod.SCHEMA_VERSION
    conn = raw(path)
    assert conn.execute('PRAGMA user_version').fetchone()[0] == store_mod.SCHEMA_VERSION
    for table in store_mod.TABLES:
        cols = columns(conn, table)
        assert {'id', 'created', 'uploaded'} <= set(cols), table
    conn.close()


def test_v1_file_is_upgraded_keeping_its_rows(db_path):
    conn = raw(db_path)
    conn.executescript(V1_SCHEMA)
    conn.execute("INSERT INTO missions (id, created, mission_id, started) "
                 "VALUES ('a' , 1.0, 'old', 10.0)")
    conn.execute("INSERT INTO events (id, created, mission_id, stamp, kind, state, detail) "
                 "VALUES ('b', 1.0, 'old', 11.0, 'state', 'DO_START', 'v1 row')")
    conn.commit()
    conn.close()

    with Store(db_path) as s:
        assert s.schema_version == store_mod.SCHEMA_VERSION
        events = s.events('old')
        assert [(e['id'], e['detail'], e['uploaded']) for e in events] == [('b', 'v1 row', 0)]
        assert s.mission('old')['started'] == 10.0
        s.add_event(event(mission_id='old', stamp=12.0, detail='v2 row'))
        assert [e['detail'] for e in s.events('old')] == ['v1 row', 'v2 row']
    conn = raw(db_path)
    indices = {r[0] for r in conn.execute("SELECT name FROM sqlite_master WHERE type='index'")}
    assert {'observations_by_mission', 'pick_records_by_mission', 'events_by_mission'} <= indices
    conn.close()


def test_newer_file_is_refused_and_left_alone(db_path):
    conn = raw(db_path)
    conn.execute('CREATE TABLE future (x)')
    conn.execute('PRAGMA user_version = %d' % (store_mod.SCHEMA_VERSION + 1))
    conn.commit()
    conn.close()
    before = open(db_path, 'rb').read()
    with pytest.raises(store_mod.SchemaVersionError, match='newer'):
        Store(db_path)
    assert open(db_path, 'rb').read() == before
    assert not os.path.exists(db_path + '-wal')


def test_not_a_database_is_refused(db_path):
    with open(db_path, 'wb') as f:
        f.write(b'this is not sqlite' * 100)
    with pytest.raises(store_mod.StoreError, match='not a usable SQLite database'):
        Store(db_path)


def test_wal_and_synchronous(store, db_path):
    assert store.journal_mode == 'wal'
    assert store.synchronous == 'FULL'
    conn = raw(db_path)   # WAL is persistent: any other connection sees it
    assert conn.execute('PRAGMA journal_mode').fetchone()[0] == 'wal'
    conn.close()
    with Store(db_path, synchronous='normal') as s:
        assert s.synchronous == 'NORMAL'
    with pytest.raises(ValueError, match='synchronous'):
        Store(db_path, synchronous='OFF')


# ---------------------------------------------------------------- round trips

def test_observations_round_trip(db_path):
    clock = iter(range(1000, 2000)).__next__
    with Store(db_path, clock=lambda: float(clock())) as s:
        obs = [observation(0), observation(1),
               observation(2, position=None, frame_id='', pickable=False, pick_order=-1,
                           ripeness_stage=0, ripeness_score=0.1)]
        ids = s.add_observations('m1', 4, 2.75, obs, site='greenhouse-3')
    with Store(db_path) as s:   # reopened: everything was committed
        rows = s.observations('m1')
        assert [r['id'] for r in rows] == ids
        assert all(len(i) == 32 and int(i, 16) >= 0 for i in ids) and len(set(ids)) == 3
        for row, expected in zip(rows, obs):
            assert row['picking_point'] == 4 and row['track_position'] == 2.75
            assert row['created'] >= 1000.0 and row['uploaded'] == 0
            for key, value in expected.items():
                assert row[key] == (tuple(value) if key == 'position' and value else value), key
        assert s.observations('m1', picking_point=5) == []
        mission = s.mission('m1')
        assert mission['site'] == 'greenhouse-3' and mission['started'] == 100.0


def test_pick_records_events_and_mission_records(store):
    store.add_event(event('state', stamp=50.0))
    ids = [store.add_pick_record(pick_record(i)) for i in (1, 0)]   # out of stamp order
    store.add_pick_record(pick_record(0, outcome=1, reason='unreachable', stamp=199.0))
    store.add_event(event('summary', stamp=300.0, state='', detail='2 picked, 1 unreachable'))

    mission_id, records, events = store.mission_records('m1')
    assert mission_id == 'm1'
    assert [r['stamp'] for r in records] == [199.0, 200.0, 201.0]
    assert records[2]['id'] == ids[0]
    rec = records[1]
    expected = pick_record(0)
    for key, value in expected.items():
        assert rec[key] == (tuple(value) if key == 'position' else value), key
    assert records[0]['reason'] == 'unreachable' and records[0]['outcome'] == 1
    assert [e['kind'] for e in events] == ['state', 'summary']

    mission = store.mission('m1')
    assert mission['started'] == 50.0
    assert mission['ended'] == 300.0
    assert mission['summary'] == '2 picked, 1 unreachable'


def test_latest_mission_is_the_last_created(store):
    assert store.mission_records('') == (None, [], [])
    store.add_event(event(mission_id='first', stamp=500.0))
    store.add_event(event(mission_id='second', stamp=10.0))   # older stamp, created later
    store.add_event(event(mission_id='first', stamp=600.0))
    assert store.latest_mission_id() == 'second'
    assert store.mission_records('')[0] == 'second'
    assert store.mission_records('nope') == (None, [], [])
    assert [m['mission_id'] for m in store.missions()] == ['first', 'second']


def test_end_mission_and_ensure_mission(store):
    row_id = store.ensure_mission('m9', started=5.0, site='lab')
    assert store.ensure_mission('m9') == row_id
    store.end_mission('m9', 90.0, 'done')
    m = store.mission('m9')
    assert (m['started'], m['ended'], m['summary'], m['site']) == (5.0, 90.0, 'done', 'lab')


# ---------------------------------------------------------------- bad input, atomicity

@pytest.mark.parametrize('bad, message', [
    (dict(position=(0.5, math.nan, 0.9)), 'position.y must be finite'),
    (dict(position=None), 'position is required'),          # pickable needs a 3D point
    (dict(position=(1.0, 2.0)), '3 components'),
    (dict(radius=math.inf), 'radius must be finite'),
    (dict(radius=-0.01), 'radius must be >= 0'),
    (dict(ripeness_stage=7), 'ripeness_stage'),
    (dict(ripeness_score=math.nan), 'ripeness_score must be finite'),
    (dict(detection_id=1.5), 'detection_id must be an integer'),
    (dict(frame_id=''), 'frame_id must not be empty'),
    (dict(pick_order=-3), 'pick_order'),
])
def test_bad_observation_stores_nothing(store, bad, message):
    batch = [observation(0), observation(1), observation(2, **bad)]
    with pytest.raises(ValueError, match=message) as err:
        store.add_observations('m1', 0, 1.0, batch)
    assert 'tomato 2 of 3' in str(err.value)
    assert store.row_counts() == dict(missions=0, observations=0, pick_records=0, events=0)


def test_missing_field_is_named(store):
    obs = observation(0)
    del obs['ripeness_score']
    with pytest.raises(ValueError, match="missing field 'ripeness_score'"):
        store.add_observations('m1', 0, 1.0, [obs])
    rec = pick_record()
    del rec['cycle_time']
    with pytest.raises(ValueError, match="missing field 'cycle_time'"):
        store.add_pick_record(rec)
    with pytest.raises(ValueError, match="missing field 'kind'"):
        store.add_event(dict(mission_id='m1', stamp=1.0, state='', detail=''))
    assert sum(store.row_counts().values()) == 0


@pytest.mark.parametrize('bad, message', [
    (dict(position=(math.nan, 0.0, 0.0)), 'position.x must be finite'),
    (dict(state_durations=[0.4, math.nan]), r'state_durations\[1\] must be finite'),
    (dict(state_durations=[0.4]), '2 state names but 1 state durations'),
    (dict(cycle_time=math.inf), 'cycle_time must be finite'),
    (dict(outcome=9), 'outcome'),
    (dict(mission_id=''), 'mission_id must not be empty'),
    (dict(stamp=math.nan), 'stamp must be finite'),
])
def test_bad_pick_record_stores_nothing(store, bad, message):
    with pytest.raises(ValueError, match=message):
        store.add_pick_record(pick_record(**bad))
    assert sum(store.row_counts().values()) == 0


def test_failure_inside_the_transaction_rolls_back(store, monkeypatch):
    # Validation passes, then the second INSERT hits a duplicate primary key.
    monkeypatch.setattr(store, '_new_id', lambda: 'f' * 32)
    with pytest.raises(sqlite3.IntegrityError):
        store.add_observations('m1', 0, 1.0, [observation(0), observation(1)])
    monkeypatch.undo()
    assert sum(store.row_counts().values()) == 0
    store.add_observations('m1', 0, 1.0, [observation(0)])   # the store is still usable
    assert store.row_counts()['observations'] == 1


# ---------------------------------------------------------------- concurrency, durability

def _write_events(store, mission_id, n, errors):
    try:
        for i in range(n):
            store.add_event(event(mission_id=mission_id, stamp=float(i + 1), detail=str(i)))
    except Exception as e:  # reported to the main thread
        errors.append(e)


@pytest.mark.parametrize('shared', [True, False], ids=['one Store', 'two Stores'])
def test_concurrent_writers(db_path, shared):
    n = 60
    first = Store(db_path)
    second = first if shared else Store(db_path)
    errors = []
    threads = [threading.Thread(target=_write_events, args=(s, m, n, errors))
               for s, m in ((first, 'a'), (second, 'b'))]
    for t in threads:
        t.start()
    for t in threads:
        t.join(60.0)
    assert not any(t.is_alive() for t in threads)
    assert errors == []
    for s in {first, second}:
        s.close()
    with Store(db_path) as s:
        assert s.row_counts()['events'] == 2 * n
        assert [e['detail'] for e in s.events('a')] == [str(i) for i in range(n)]
        assert s.integrity_check() == 'ok'


CRASH_WRITER = textwrap.dedent("""
    import sys
    sys.path.insert(0, sys.argv[2])
    from database_pkg.store import Store
    s = Store(sys.argv[1])
    i = 0
    while True:
        s.add_observations('crash', i, float(i), [
            dict(detection_id=k, position=(0.5, 0.1, 0.9), frame_id='map', radius=0.03,
                 ripeness_stage=3, ripeness_score=0.9, pickable=True, pick_order=k,
                 stamp=1.0 + i, image_id='i%d' % i) for k in range(5)])
        i += 1
        print(i, flush=True)   # after COMMIT returned
""")


def test_rows_committed_before_sigkill_survive(db_path):
    proc = subprocess.Popen([sys.executable, '-c', CRASH_WRITER, db_path, os.path.abspath(SRC)],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                            universal_newlines=True)
    committed = 0
    try:
        for line in proc.stdout:
            committed = int(line)
            if committed >= 40:
                break
    finally:
        proc.send_signal(signal.SIGKILL)
        # read the rest through the same file object: the loop above may have read lines
        # past the one it stopped at into its buffer, which communicate() (reading the pipe
        # itself) would not see; the killed writer closes both pipes, so these reads end
        rest = proc.stdout.read()
        err = proc.stderr.read()
        proc.wait(timeout=30)
    assert committed >= 40, err
    for line in rest.split():
        committed = int(line)   # acknowledged before the kill landed
    assert proc.returncode == -signal.SIGKILL
    assert os.path.exists(db_path + '-wal')   # killed without a checkpoint

    with Store(db_path) as s:
        assert s.integrity_check() == 'ok'
        rows = s.observations('crash')
        batches = len(rows) // 5
        assert len(rows) % 5 == 0, 'a partial transaction was left behind'
        assert batches >= committed
        assert batches <= committed + 1   # at most the batch in flight
        assert sorted({r['picking_point'] for r in rows}) == list(range(batches))
