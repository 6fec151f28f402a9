"""Schema 5: a pick record or event is stored once, however often it comes (the executive sends a
respawned database_node every record and event of its mission again)."""
from database_pkg import store as store_mod
from database_pkg.store import Store
from test_store import event, old_file, pick_record


def test_the_same_record_and_event_again_change_nothing(tmp_path):
    with Store(str(tmp_path / 'h.db')) as s:
        first = s.add_pick_record(pick_record(1))
        assert s.add_pick_record(pick_record(1)) == first
        s.add_pick_record(pick_record(1, stamp=300.0))              # the same fruit, later: kept
        s.add_pick_record(pick_record(2))
        ev = s.add_event(event('summary', stamp=400.0, state='', detail='{"picked": 2}'))
        assert s.add_event(event('summary', stamp=400.0, state='', detail='{"picked": 2}')) == ev
        s.add_event(event('summary', stamp=400.0, state='', detail='{"picked": 3}'))
        assert [(r['target_id'], r['stamp']) for r in s.pick_records('m1')] == [
            (1, 201.0), (2, 202.0), (1, 300.0)]
        assert len(s.events('m1')) == 2
        assert s.row_counts(store_mod.TABLES)['pick_records'] == 3


def test_v4_file_with_copies_keeps_the_first_of_each(tmp_path):
    path = str(tmp_path / 'v4.db')
    conn = old_file(path, 4)
    conn.execute("INSERT INTO missions (id, created, mission_id, started) VALUES ('a', 1.0, 'old', 10.0)")
    for row_id, reason in (('r1', 'first'), ('r2', 'copy')):
        conn.execute("INSERT INTO pick_records (id, created, mission_id, picking_point, target_id, x, y, z, "
                     "frame_id, outcome, reason, state_names, state_durations, cycle_time, stamp) "
                     "VALUES (?, 1.0, 'old', 0, 3, 0.5, 0.1, 1.0, 'base_link', 0, ?, '[]', '[]', 9.0, 20.0)",
                     (row_id, reason))
    for row_id in ('e1', 'e2'):
        conn.execute("INSERT INTO events (id, created, mission_id, stamp, kind, state, detail) "
                     "VALUES (?, 1.0, 'old', 11.0, 'state', 'DO_START', 'go')", (row_id, ))
    conn.commit()
    conn.close()
    with Store(path) as s:
        assert s.schema_version == store_mod.SCHEMA_VERSION >= 5
        assert [r['reason'] for r in s.pick_records('old')] == ['first']
        assert len(s.events('old')) == 1
