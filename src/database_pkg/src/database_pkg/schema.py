"""Schema of the local mission store: tables, ordered migrations, errors of opening (no rospy).

Schema versions: ``PRAGMA user_version`` holds the number of migrations applied. Opening an older
file applies the missing migrations in order, each in its own transaction; opening a file written
by a newer version raises ``SchemaVersionError`` without touching the file. Released migrations
must never be edited: add a new one at the end of ``MIGRATIONS``.
"""

# PickRecord.OUTCOME_* and Tomato.STAGE_* (harvest_msgs), repeated here so this module needs no ROS
# (network_pkg's uploader opens the store without it); test/test_schema_codes.py checks the copies.
OUTCOMES = (0, 1, 2, 3, 4)
RIPENESS_STAGES = (0, 1, 2, 3)

SYNCHRONOUS_MODES = ('NORMAL', 'FULL', 'EXTRA')
TABLES = ('missions', 'observations', 'pick_records', 'events')     # the uploader's outbox
LOCAL_TABLES = ('checkpoints', )                                       # never uploaded
PHASES = ('', 'approach', 'suction', 'pull', 'cut', 'place', 'placed')  # Checkpoint.phase

# Ordered migrations: (version reached, description, statements). Never edit a released entry.
MIGRATIONS = (
    (1, 'missions, observations, pick records and events', (
        """CREATE TABLE missions (
            id TEXT PRIMARY KEY,
            created REAL NOT NULL,
            mission_id TEXT NOT NULL UNIQUE,
            started REAL,
            ended REAL,
            site TEXT NOT NULL DEFAULT '',
            summary TEXT NOT NULL DEFAULT ''
        )""",
        """CREATE TABLE observations (
            id TEXT PRIMARY KEY,
            created REAL NOT NULL,
            mission_id TEXT NOT NULL REFERENCES missions(mission_id),
            picking_point INTEGER NOT NULL,
            track_position REAL NOT NULL,
            detection_id INTEGER NOT NULL,
            x REAL, y REAL, z REAL,
            frame_id TEXT NOT NULL,
            radius REAL NOT NULL,
            ripeness_stage INTEGER NOT NULL,
            ripeness_score REAL NOT NULL,
            pickable INTEGER NOT NULL,
            pick_order INTEGER NOT NULL,
            stamp REAL NOT NULL,
            image_id TEXT NOT NULL
        )""",
        """CREATE TABLE pick_records (
            id TEXT PRIMARY KEY,
            created REAL NOT NULL,
            mission_id TEXT NOT NULL REFERENCES missions(mission_id),
            picking_point INTEGER NOT NULL,
            target_id INTEGER NOT NULL,
            x REAL NOT NULL, y REAL NOT NULL, z REAL NOT NULL,
            frame_id TEXT NOT NULL,
            outcome INTEGER NOT NULL,
            reason TEXT NOT NULL,
            state_names TEXT NOT NULL,
            state_durations TEXT NOT NULL,
            cycle_time REAL NOT NULL,
            stamp REAL NOT NULL
        )""",
        """CREATE TABLE events (
            id TEXT PRIMARY KEY,
            created REAL NOT NULL,
            mission_id TEXT NOT NULL REFERENCES missions(mission_id),
            stamp REAL NOT NULL,
            kind TEXT NOT NULL,
            state TEXT NOT NULL,
            detail TEXT NOT NULL
        )""",
    )),
    (2, 'uploaded flag for the network uploader; per-mission indices', (
        "ALTER TABLE missions ADD COLUMN uploaded INTEGER NOT NULL DEFAULT 0",
        "ALTER TABLE observations ADD COLUMN uploaded INTEGER NOT NULL DEFAULT 0",
        "ALTER TABLE pick_records ADD COLUMN uploaded INTEGER NOT NULL DEFAULT 0",
        "ALTER TABLE events ADD COLUMN uploaded INTEGER NOT NULL DEFAULT 0",
        "CREATE INDEX observations_by_mission ON observations(mission_id, picking_point)",
        "CREATE INDEX pick_records_by_mission ON pick_records(mission_id, stamp)",
        "CREATE INDEX events_by_mission ON events(mission_id, stamp)",
    )),
    # network_pkg's outbox: rows with uploaded = 0 are the queue (partial indices keep finding
    # and counting them cheap whatever the size of the uploaded history). Missions are the only
    # rows that change after insert: a change of started/ended/summary/site queues the mission
    # again and bumps its revision, so the uploader only marks uploaded the revision it sent and
    # the server keeps the highest revision.
    (3, 'outbox: pending-row indices; a changed mission is queued again with a new revision', (
        "ALTER TABLE missions ADD COLUMN revision INTEGER NOT NULL DEFAULT 0",
        "CREATE INDEX missions_pending ON missions(uploaded) WHERE uploaded = 0",
        "CREATE INDEX observations_pending ON observations(uploaded) WHERE uploaded = 0",
        "CREATE INDEX pick_records_pending ON pick_records(uploaded) WHERE uploaded = 0",
        "CREATE INDEX events_pending ON events(uploaded) WHERE uploaded = 0",
        """CREATE TRIGGER missions_changed AFTER UPDATE OF started, ended, summary, site
            ON missions
            WHEN OLD.started IS NOT NEW.started OR OLD.ended IS NOT NEW.ended
                 OR OLD.summary IS NOT NEW.summary OR OLD.site IS NOT NEW.site
            BEGIN
                UPDATE missions SET uploaded = 0, revision = OLD.revision + 1
                WHERE id = NEW.id;
            END""",
    )),
    # control_pkg's executive: where a restarted task planner continues (one row per mission,
    # replaced by every newer checkpoint; local only, not in the uploader's outbox)
    (4, 'checkpoints of the executive (crash-safe continuation)', (
        """CREATE TABLE checkpoints (
            id TEXT PRIMARY KEY,
            created REAL NOT NULL,
            updated REAL NOT NULL,
            mission_id TEXT NOT NULL UNIQUE REFERENCES missions(mission_id),
            robot TEXT NOT NULL,
            stamp REAL NOT NULL,
            points TEXT NOT NULL,
            point_index INTEGER NOT NULL,
            picking_point INTEGER NOT NULL,
            targets_done TEXT NOT NULL,
            target_id INTEGER NOT NULL,
            target_x REAL, target_y REAL, target_z REAL,
            phase TEXT NOT NULL,
            holding INTEGER NOT NULL,
            finished INTEGER NOT NULL,
            outcome TEXT NOT NULL
        )""",
        "CREATE INDEX checkpoints_unfinished ON checkpoints(robot, updated) WHERE finished = 0",
    )),
    # a pick record or event stored once however often it comes: the executive sends a
    # (re)started database_node every record and event of its mission again (nothing published
    # while the store was down is lost), and a file may hold copies from before (the first kept)
    (5, 'a pick record or event is stored once (the executive replays them to a new store)', (
        """DELETE FROM pick_records WHERE rowid NOT IN (SELECT MIN(rowid) FROM pick_records
            GROUP BY mission_id, picking_point, target_id, stamp)""",
        """CREATE UNIQUE INDEX pick_records_once
            ON pick_records(mission_id, picking_point, target_id, stamp)""",
        """DELETE FROM events WHERE rowid NOT IN (SELECT MIN(rowid) FROM events
            GROUP BY mission_id, stamp, kind, state, detail)""",
        "CREATE UNIQUE INDEX events_once ON events(mission_id, stamp, kind, state, detail)",
    )),
)
SCHEMA_VERSION = MIGRATIONS[-1][0]


class StoreError(RuntimeError):
    """The database file cannot be opened or used (not SQLite, unreadable, no WAL...)."""


class SchemaVersionError(StoreError):
    """The file was written by a newer schema version than this code knows."""

