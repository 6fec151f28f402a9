"""The records are written in several places: harvest_msgs/PickRecord.msg (the executive's
record on the wire), database_pkg's tables (the robot's SQLite store, uploaded as is), farm_server's
SQLAlchemy tables (db_schema) and its API's pydantic models (schemas). They must agree field for
field, in kind and on the outcome codes, or a record is refused (or silently mangled) on its way
to the farm."""
import os
import sqlite3
import typing

from harvest_msgs.msg import PickRecord as PickRecordMsg

from database_pkg import store
from farm_server import db_schema, fusion_config, schemas

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


def _outcomes_of_the_message():
    return dict((getattr(PickRecordMsg, n), n[len('OUTCOME_'):].lower())
                for n in dir(PickRecordMsg) if n.startswith('OUTCOME_'))


def test_the_servers_outcome_names_are_the_messages():
    # the farm server runs off the robot without ROS: its copy of the enum is checked here
    assert fusion_config.OUTCOME_NAMES == _outcomes_of_the_message()
    assert fusion_config.OUTCOME_PICKED == PickRecordMsg.OUTCOME_PICKED


# --- the uploaded tables, three times: the robot's SQLite store, the server's SQLAlchemy tables
# and the API's pydantic models. Compared column for column: name, kind, null allowed, length.

#: the store's local upload flag; the server's own bookkeeping
STORE_ONLY = {'uploaded'}
SERVER_ONLY = {'robot', 'received'}
MODELS = {'missions': schemas.Mission, 'observations': schemas.Observation,
          'pick_records': schemas.PickRecord, 'events': schemas.Event}
#: columns the store and the server keep as JSON text of a list (the API has the list)
JSON_LISTS = {('pick_records', 'state_names'): 'list[str]',
              ('pick_records', 'state_durations'): 'list[float]'}
#: SQLite has no boolean: the store keeps 0/1 (the uploader sends a bool)
BOOLEANS = {('observations', 'pickable')}
SQLITE_KINDS = {'INTEGER': 'int', 'REAL': 'float', 'TEXT': 'str'}
SQLALCHEMY_KINDS = {'Integer': 'int', 'Float': 'float', 'String': 'str', 'Text': 'str',
                    'Boolean': 'bool'}


def _store_tables(tmp_path):
    """{table: {column: (kind, nullable)}} of a fresh store (every migration applied)."""
    path = os.path.join(str(tmp_path), 'robot.db')
    store.Store(path).close()
    out = {}
    with sqlite3.connect(path) as conn:
        for table in store.TABLES:
            columns = {}
            for _cid, name, sql_type, notnull, _default, pk in conn.execute(
                    'PRAGMA table_info(%s)' % table):
                kind = SQLITE_KINDS[sql_type]
                if (table, name) in BOOLEANS:
                    kind = 'bool'
                columns[name] = (JSON_LISTS.get((table, name), kind), not (notnull or pk))
            out[table] = columns
    return out


def _server_tables():
    out = {}
    for table in db_schema.RECORD_TABLES:
        columns = {}
        for col in db_schema.TABLES[table].columns:
            kind = SQLALCHEMY_KINDS[type(col.type).__name__]
            columns[col.name] = (JSON_LISTS.get((table, col.name), kind), bool(col.nullable))
        out[table] = columns
    return out


def _annotation_kind(annotation):
    """('float', True) for Optional[float], ('list[str]', False) for List[str], ..."""
    args = [a for a in typing.get_args(annotation) if a is not type(None)]
    if typing.get_origin(annotation) is typing.Union:
        return _annotation_kind(args[0])[0], True
    if typing.get_origin(annotation) is list:
        return 'list[%s]' % args[0].__name__, False
    return annotation.__name__, False


def _api_models():
    return dict((table, dict((name, _annotation_kind(field.annotation))
                             for name, field in model.model_fields.items()))
                for table, model in MODELS.items())


def test_the_same_tables_are_uploaded_stored_and_accepted():
    assert set(store.TABLES) == set(db_schema.RECORD_TABLES) == set(MODELS)


def test_store_server_and_api_agree_column_for_column(tmp_path):
    robot, server, api = _store_tables(tmp_path), _server_tables(), _api_models()
    for table in MODELS:
        stored = dict((k, v) for k, v in robot[table].items() if k not in STORE_ONLY)
        kept = dict((k, v) for k, v in server[table].items() if k not in SERVER_ONLY)
        assert stored == kept, (table, 'store vs server tables',
                                set(stored.items()) ^ set(kept.items()))
        assert kept == api[table], (table, 'server tables vs API',
                                    set(kept.items()) ^ set(api[table].items()))


def test_the_servers_text_columns_hold_what_the_api_accepts():
    for table, model in MODELS.items():
        for col in db_schema.TABLES[table].columns:
            if type(col.type).__name__ != 'String' or col.name in SERVER_ONLY:
                continue
            limits = dict((type(m).__name__, m) for m in model.model_fields[col.name].metadata)
            if 'MaxLen' in limits:
                assert limits['MaxLen'].max_length == col.type.length, (table, col.name)
            else:           # the row id: a pattern of exactly that many hex digits
                assert '{%d}' % col.type.length in schemas.ID_PATTERN, (table, col.name)
