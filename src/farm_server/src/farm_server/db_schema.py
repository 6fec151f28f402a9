"""Farm server database schema: the tables, their versioned migrations, the current tables.

Schema versions: table ``schema_migrations`` holds one row per applied migration. ``MIGRATIONS``
is an ordered list of (version, description, function(connection)); opening a database applies
the missing ones, each in its own transaction. Never edit a released migration: append one.

Pure SQLAlchemy Core table definitions, no engine; ``db.FarmDB`` applies the migrations.
"""

import sqlalchemy as sa

RECORD_TABLES = ('missions', 'observations', 'pick_records', 'events')


def _tables_v1(metadata):
    """Version 1 of the schema. Frozen: later versions change it through new migrations."""
    robots = sa.Table(
        'robots', metadata,
        sa.Column('name', sa.String(64), primary_key=True),
        sa.Column('token_sha256', sa.String(64), nullable=False, unique=True),
        sa.Column('created', sa.Float, nullable=False),
        sa.Column('last_upload', sa.Float),
        sa.Column('uploads', sa.Integer, nullable=False, server_default='0'),
        sa.Column('rows_received', sa.Integer, nullable=False, server_default='0'),
    )
    missions = sa.Table(
        'missions', metadata,
        sa.Column('id', sa.String(32), primary_key=True),
        sa.Column('robot', sa.String(64), nullable=False),
        sa.Column('created', sa.Float, nullable=False),
        sa.Column('mission_id', sa.String(200), nullable=False),
        sa.Column('started', sa.Float),
        sa.Column('ended', sa.Float),
        sa.Column('site', sa.String(200), nullable=False),
        sa.Column('summary', sa.Text, nullable=False),
        sa.Column('revision', sa.Integer, nullable=False),
        sa.Column('received', sa.Float, nullable=False),
        sa.Index('missions_by_robot', 'robot', 'mission_id'),
    )
    observations = sa.Table(
        'observations', metadata,
        sa.Column('id', sa.String(32), primary_key=True),
        sa.Column('robot', sa.String(64), nullable=False),
        sa.Column('created', sa.Float, nullable=False),
        sa.Column('mission_id', sa.String(200), nullable=False),
        sa.Column('picking_point', sa.Integer, nullable=False),
        sa.Column('track_position', sa.Float, nullable=False),
        sa.Column('detection_id', sa.Integer, nullable=False),
        sa.Column('x', sa.Float), sa.Column('y', sa.Float), sa.Column('z', sa.Float),
        sa.Column('frame_id', sa.String(100), nullable=False),
        sa.Column('radius', sa.Float, nullable=False),
        sa.Column('ripeness_stage', sa.Integer, nullable=False),
        sa.Column('ripeness_score', sa.Float, nullable=False),
        sa.Column('pickable', sa.Boolean, nullable=False),
        sa.Column('pick_order', sa.Integer, nullable=False),
        sa.Column('stamp', sa.Float, nullable=False),
        sa.Column('image_id', sa.String(200), nullable=False),
        sa.Column('received', sa.Float, nullable=False),
        sa.Index('observations_by_mission', 'robot', 'mission_id', 'picking_point'),
    )
    pick_records = sa.Table(
        'pick_records', metadata,
        sa.Column('id', sa.String(32), primary_key=True),
        sa.Column('robot', sa.String(64), nullable=False),
        sa.Column('created', sa.Float, nullable=False),
        sa.Column('mission_id', sa.String(200), nullable=False),
        sa.Column('picking_point', sa.Integer, nullable=False),
        sa.Column('target_id', sa.Integer, nullable=False),
        sa.Column('x', sa.Float, nullable=False),
        sa.Column('y', sa.Float, nullable=False),
        sa.Column('z', sa.Float, nullable=False),
        sa.Column('frame_id', sa.String(100), nullable=False),
        sa.Column('outcome', sa.Integer, nullable=False),
        sa.Column('reason', sa.Text, nullable=False),
        sa.Column('state_names', sa.Text, nullable=False),       # JSON array
        sa.Column('state_durations', sa.Text, nullable=False),   # JSON array
        sa.Column('cycle_time', sa.Float, nullable=False),
        sa.Column('stamp', sa.Float, nullable=False),
        sa.Column('received', sa.Float, nullable=False),
        sa.Index('pick_records_by_mission', 'robot', 'mission_id'),
    )
    events = sa.Table(
        'events', metadata,
        sa.Column('id', sa.String(32), primary_key=True),
        sa.Column('robot', sa.String(64), nullable=False),
        sa.Column('created', sa.Float, nullable=False),
        sa.Column('mission_id', sa.String(200), nullable=False),
        sa.Column('stamp', sa.Float, nullable=False),
        sa.Column('kind', sa.String(64), nullable=False),
        sa.Column('state', sa.String(64), nullable=False),
        sa.Column('detail', sa.Text, nullable=False),
        sa.Column('received', sa.Float, nullable=False),
        sa.Index('events_by_mission', 'robot', 'mission_id'),
    )
    return dict(robots=robots, missions=missions, observations=observations,
                pick_records=pick_records, events=events)


def _migration_1(conn):
    metadata = sa.MetaData()
    _tables_v1(metadata)
    metadata.create_all(conn)


MIGRATIONS = (
    (1, 'robots, missions, observations, pick records, events', _migration_1),
)
SCHEMA_VERSION = MIGRATIONS[-1][0]

# The current schema, for queries (equal to the result of all migrations).
METADATA = sa.MetaData()
TABLES = _tables_v1(METADATA)

_migrations_table = sa.Table(
    'schema_migrations', sa.MetaData(),
    sa.Column('version', sa.Integer, primary_key=True, autoincrement=False),
    sa.Column('description', sa.Text, nullable=False),
    sa.Column('applied', sa.Float, nullable=False),
)


class SchemaVersionError(RuntimeError):
    """The database was migrated by a newer farm server than this one."""
