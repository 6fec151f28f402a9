"""The columns the uploader sends (outbox.WIRE_COLUMNS) are the store's, less its local upload
flag, and exactly the fields the farm server's API accepts (farm_server.schemas): a column added
to one of them and not the others would be dropped on the way or refuse every batch."""
import sqlite3

from database_pkg.store import TABLES, Store
from farm_server import schemas
from network_pkg.outbox import TABLE_ORDER, WIRE_COLUMNS

MODELS = {'missions': schemas.Mission, 'observations': schemas.Observation,
          'pick_records': schemas.PickRecord, 'events': schemas.Event}


def store_columns(path, table):
    with sqlite3.connect(path) as conn:
        return tuple(row[1] for row in conn.execute('PRAGMA table_info(%s)' % table))


def test_every_uploaded_table_is_sent_once():
    assert sorted(WIRE_COLUMNS) == sorted(TABLE_ORDER) == sorted(TABLES) == sorted(MODELS)


def test_the_columns_sent_are_the_stores_less_the_upload_flag(tmp_path):
    path = str(tmp_path / 'robot.db')
    Store(path).close()
    for table in TABLES:
        sent = tuple(c for c in store_columns(path, table) if c != 'uploaded')
        assert WIRE_COLUMNS[table] == sent, table


def test_the_columns_sent_are_the_fields_the_server_accepts():
    for table, model in MODELS.items():
        assert WIRE_COLUMNS[table] == tuple(model.model_fields), table
