"""The pick record is written in three places: harvest_msgs/PickRecord.msg (the executive's
record on the wire), database_pkg's pick_records table (the robot's store, uploaded as is) and
farm_server's PickRecord schema (what the server accepts). They must agree field for field and
on the outcome codes, or a record is refused (or silently mangled) on its way to the farm."""
import os
import sqlite3

from harvest_msgs.msg import PickRecord as PickRecordMsg

from database_pkg import store
from farm_server import schemas

# bookkeeping of the store and the upload, not part of the record itself
ROW_ONLY = {'id', 'created', 'uploaded'}
# the message's nested fields as the store flattens them
FLATTENED = {'pick_point': ('x', 'y', 'z', 'frame_id')}


def _message_fields():
    fields = []
    for name in PickRecordMsg.__slots__:
        fields.extend(FLATTENED.get(name, (name,)))
    return fields


def _store_columns(tmp_path):
    path = os.path.join(str(tmp_path), 'robot.db')
    store.Store(path).close()
    with sqlite3.connect(path) as conn:
        return [row[1] for row in conn.execute('PRAGMA table_info(pick_records)')]


def test_message_store_and_server_have_the_same_record_fields(tmp_path):
    message = set(_message_fields())
    columns = set(_store_columns(tmp_path)) - ROW_ONLY
    server = set(schemas.PickRecord.model_fields) - ROW_ONLY
    assert message == columns, ('PickRecord.msg vs store', message ^ columns)
    assert columns == server, ('store vs farm_server schema', columns ^ server)


def test_outcome_codes_agree():
    codes = sorted(getattr(PickRecordMsg, n) for n in dir(PickRecordMsg) if n.startswith('OUTCOME_'))
    assert tuple(codes) == tuple(store.OUTCOMES)
    field = schemas.PickRecord.model_fields['outcome']
    bounds = {type(m).__name__: m for m in field.metadata}
    assert bounds['Ge'].ge == min(codes) and bounds['Le'].le == max(codes)
    for code in codes:
        name = [n for n in dir(PickRecordMsg) if n.startswith('OUTCOME_') and
                getattr(PickRecordMsg, n) == code][0]
        assert '%d %s' % (code, name[len('OUTCOME_'):].lower()) in field.description, name
