"""The executive's checkpoints in the store (schema version 4), no ROS."""
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
from test_store import old_file  # noqa: E402  (same folder: pytest puts it on the path)


def checkpoint(**overrides):
    cp = dict(mission_id='m1', robot='', stamp=100.0, points=[0, 2, 1], point_index=1,
              picking_point=2, targets_done=[(3, (0.5, -0.1, 0.9))], target_id=4,
              target_position=(0.52, -0.12, 0.95), phase='pull', holding=True, finished=False,
              outcome='')
    cp.update(overrides)
    return cp


@pytest.fixture
def store(tmp_path):
    s = Store(str(tmp_path / 'harvest.db'))
    yield s
    s.close()


def test_v3_file_is_upgraded_to_checkpoints_keeping_its_rows(tmp_path):
    path = str(tmp_path / 'v3.db')
    conn = old_file(path, 3)
    conn.execute("INSERT INTO missions (id, created, mission_id, started) "
                 "VALUES ('a', 1.0, 'old', 10.0)")
    conn.execute("INSERT INTO events (id, created, mission_id, stamp, kind, state, detail) "
                 "VALUES ('b', 1.0, 'old', 11.0, 'state', 'DO_START', 'v3 row')")
    conn.commit()
    conn.close()

    with Store(path) as s:
        assert s.schema_version == store_mod.SCHEMA_VERSION >= 4
        assert [e['detail'] for e in s.events('old')] == ['v3 row']
        assert s.latest_unfinished_checkpoint() is None
        assert s.put_checkpoint(checkpoint(mission_id='old'))
        assert s.checkpoint('old')['phase'] == 'pull'
        assert s.row_counts(store_mod.LOCAL_TABLES)['checkpoints'] == 1
    conn = sqlite3.connect(path)
    indices = {r[0] for r in conn.execute("SELECT name FROM sqlite_master WHERE type='index'")}
    assert 'checkpoints_unfinished' in indices
    conn.close()


def test_checkpoint_round_trip_and_replacement(store):
    store.put_checkpoint(checkpoint())
    got = store.checkpoint('m1')
    assert got['points'] == [0, 2, 1] and got['point_index'] == 1 and got['picking_point'] == 2
    assert got['targets_done'] == [(3, (0.5, -0.1, 0.9))]
    assert got['target_id'] == 4 and got['target_position'] == (0.52, -0.12, 0.95)
    assert got['holding'] is True and got['finished'] is False
    store.put_checkpoint(checkpoint(stamp=101.0, phase='', target_id=-1, target_position=None,
                                    holding=False))
    got = store.checkpoint('m1')
    assert got['phase'] == '' and got['target_position'] is None and got['holding'] is False
    assert store.row_counts(store_mod.LOCAL_TABLES)['checkpoints'] == 1          # one row per mission, replaced
    assert store.mission('m1') is not None                # the mission row exists


def test_latest_unfinished_is_per_robot_and_skips_finished(tmp_path):
    clock = iter(range(1000, 2000)).__next__
    with Store(str(tmp_path / 'h.db'), clock=lambda: float(clock())) as s:
        s.put_checkpoint(checkpoint(mission_id='a'))
        s.put_checkpoint(checkpoint(mission_id='b'))
        s.put_checkpoint(checkpoint(mission_id='c', robot='other'))
        assert s.latest_unfinished_checkpoint()['mission_id'] == 'b'
        assert s.latest_unfinished_checkpoint('other')['mission_id'] == 'c'
        s.put_checkpoint(checkpoint(mission_id='b', finished=True, outcome='succeeded'))
        assert s.latest_unfinished_checkpoint()['mission_id'] == 'a'
        s.put_checkpoint(checkpoint(mission_id='a', finished=True, outcome='aborted'))
        assert s.latest_unfinished_checkpoint() is None


def test_finished_checkpoint_stays_finished(store):
    assert store.put_checkpoint(checkpoint(finished=True, outcome='succeeded'))
    assert not store.put_checkpoint(checkpoint(stamp=200.0, phase='cut'))   # a late one
    got = store.checkpoint('m1')
    assert got['finished'] is True and got['outcome'] == 'succeeded' and got['phase'] == 'pull'


@pytest.mark.parametrize('field, value, match', [
    ('phase', 'dance', 'phase'),
    ('point_index', 7, 'point_index'),
    ('stamp', float('nan'), 'stamp'),
    ('holding', 1, 'holding'),
    ('targets_done', [(1, (0.0, float('inf'), 0.0))], 'position'),
    ('target_position', (0.1, 0.2), 'position'),
    ('mission_id', '', 'mission_id'),
])
def test_bad_checkpoint_is_rejected_and_nothing_stored(store, field, value, match):
    with pytest.raises(ValueError, match=match):
        store.put_checkpoint(checkpoint(**{field: value}))
    assert store.row_counts(store_mod.LOCAL_TABLES)['checkpoints'] == 0
    assert store.missions() == []
