"""Migration 3 of database_pkg.store: the outbox support used by network_pkg's uploader."""
import os
import sqlite3
import sys

import pytest

SRC = os.path.join(os.path.dirname(os.path.abspath(__file__)), '..', 'src')
try:
    from database_pkg import store as store_mod
except ImportError:  # not built / devel not sourced: use the source tree
    sys.path.insert(0, SRC)
    from database_pkg import store as store_mod

Store = store_mod.Store


def observation(i=0):
    return dict(detection_id=i, position=(0.5, 0.1 * i, 0.9), frame_id='base_link',
                radius=0.035, ripeness_stage=3, ripeness_score=0.9, pickable=True, pick_order=i,
                stamp=100.0 + i, image_id='img')


@pytest.fixture
def db_path(tmp_path):
    return str(tmp_path / 'harvest.db')


def mission_row(path, mission_id):
    conn = sqlite3.connect(path)
    try:
        return conn.execute('SELECT uploaded, revision, started, ended, summary FROM missions '
                            'WHERE mission_id = ?', (mission_id,)).fetchone()
    finally:
        conn.close()


def mark_all_uploaded(path):
    conn = sqlite3.connect(path)
    with conn:
        for table in store_mod.TABLES:
            conn.execute('UPDATE %s SET uploaded = 1' % table)
    conn.close()


def test_v2_file_is_upgraded_to_3_with_revision_and_pending_indices(db_path):
    conn = sqlite3.connect(db_path)
    for _version, _text, statements in store_mod.MIGRATIONS[:2]:
        for statement in statements:
            conn.execute(statement)
    conn.execute("INSERT INTO missions (id, created, mission_id, started, uploaded) "
                 "VALUES ('a', 1.0, 'old', 10.0, 1)")
    conn.execute('PRAGMA user_version = 2')
    conn.commit()
    conn.close()

    with Store(db_path) as s:
        assert s.schema_version >= 3
        row = s.mission('old')
        assert (row['uploaded'], row['revision']) == (1, 0)
    conn = sqlite3.connect(db_path)
    indices = {r[0] for r in conn.execute("SELECT name FROM sqlite_master WHERE type='index'")}
    assert {'missions_pending', 'observations_pending', 'pick_records_pending',
            'events_pending'} <= indices
    plan = conn.execute('EXPLAIN QUERY PLAN SELECT id FROM observations WHERE uploaded = 0 '
                        'ORDER BY rowid LIMIT 10').fetchall()
    assert 'observations_pending' in ' '.join(str(step[-1]) for step in plan)
    conn.close()


def test_mission_change_queues_it_again_with_a_new_revision(db_path):
    with Store(db_path) as s:
        s.add_observations('m1', 0, 0.5, [observation(0)])
        mark_all_uploaded(db_path)
        uploaded, revision, started, _ended, _summary = mission_row(db_path, 'm1')
        assert (uploaded, started) == (1, 100.0)

        s.end_mission('m1', 300.0, 'done: 1 picked')
        uploaded2, revision2, _s, ended, summary = mission_row(db_path, 'm1')
        assert (uploaded2, ended, summary) == (0, 300.0, 'done: 1 picked')
        assert revision2 == revision + 1

        # an earlier stamp widens `started`: a change, queued again
        mark_all_uploaded(db_path)
        s.add_observations('m1', 1, 1.0, [observation(1)], site='')
        assert mission_row(db_path, 'm1')[0] == 1  # later stamp: no change, stays uploaded
        s.ensure_mission('m1', started=50.0)
        uploaded3, revision3, started3, _e, _m = mission_row(db_path, 'm1')
        assert (uploaded3, started3, revision3) == (0, 50.0, revision2 + 1)


def test_same_values_written_again_do_not_requeue(db_path):
    with Store(db_path) as s:
        s.ensure_mission('m1', started=100.0)
        s.end_mission('m1', 300.0, 'done')
        mark_all_uploaded(db_path)
        before = mission_row(db_path, 'm1')
        s.end_mission('m1', 300.0, 'done')
        s.add_event(dict(mission_id='m1', stamp=400.0, kind='state', state='DO_START',
                         detail=''))
        assert mission_row(db_path, 'm1') == before


def test_other_tables_are_untouched_by_the_trigger(db_path):
    with Store(db_path) as s:
        s.add_observations('m1', 0, 0.5, [observation(0), observation(1)])
        mark_all_uploaded(db_path)
        s.end_mission('m1', 300.0, 'done')
        assert all(o['uploaded'] == 1 for o in s.observations('m1'))
