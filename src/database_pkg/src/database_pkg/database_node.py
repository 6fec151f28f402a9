"""database_node: the data layer's ROS face (local store + DO_SPATIAL_TEMPORAL server).

Actions served:
  spatial_temporal (harvest_msgs/SpatialTemporal): ask image_processing for a SPATIAL_POSITIONING
      scan, store every returned tomato as an observation of (mission_id, picking_point,
      track_position); result.stored = number written. Aborted with a clear message if the goal
      is invalid, image_processing is missing, times out or fails, or the write fails (nothing
      is then stored). Preempting cancels the scan.
Actions used:
  image_processing (harvest_msgs/ImageProcessing)
Subscribed topics:
  mission/pick_records (harvest_msgs/PickRecord), mission/events (harvest_msgs/MissionEvent),
  mission/checkpoints (harvest_msgs/Checkpoint: the executive's progress, one row per mission)
Services:
  get_mission_records (harvest_msgs/GetMissionRecords): empty mission_id = the latest mission.
  get_checkpoint (harvest_msgs/GetCheckpoint): the latest unfinished checkpoint of a robot.
Published:
  /diagnostics (via diagnostic_updater): db path, size, schema, row counts, free disk, errors.
Params (private): db_path, synchronous, site, queue_size, server_timeout, result_timeout,
  ack_timeout, target_frame, min_ripeness (see config/database.yaml).
"""

import os
import shutil
import sqlite3
import threading

import actionlib
from actionlib.action_client import CommState
import diagnostic_updater
import rospy
from actionlib_msgs.msg import GoalStatus
from diagnostic_msgs.msg import DiagnosticStatus
from harvest_msgs.msg import (Checkpoint, ImageProcessingAction, ImageProcessingGoal, MissionEvent,
                              PickRecord, SpatialTemporalAction, SpatialTemporalFeedback,
                              SpatialTemporalResult)
from harvest_msgs.srv import (GetCheckpoint, GetCheckpointResponse, GetMissionRecords,
                              GetMissionRecordsResponse)

from database_pkg import convert
from database_pkg import names
from database_pkg.store import LOCAL_TABLES, TABLES, SchemaVersionError, Store, StoreError

DEFAULT_DB_PATH = '~/.ros/harvest/harvest.db'

# Diagnostics thresholds.
DISK_FREE_WARN_BYTES = 500 * 1024 * 1024
DISK_FREE_ERROR_BYTES = 50 * 1024 * 1024
REJECTED_INPUT_WARN_S = 60.0        # WARN while the last rejected message is this recent
DIAGNOSTICS_PERIOD_S = 1.0

# How often the scan wait re-checks its ROS-time deadline (done/preempt wake it at once).
_WAIT_SLICE_S = 0.05


def _status_name(status):
    for name in ('PENDING', 'ACTIVE', 'PREEMPTED', 'SUCCEEDED', 'ABORTED', 'REJECTED',
                 'PREEMPTING', 'RECALLING', 'RECALLED', 'LOST'):
        if getattr(GoalStatus, name) == status:
            return name
    return str(status)


class DatabaseNodeError(RuntimeError):
    """The node cannot start (bad db_path, newer schema, unusable file)."""


class _Health(object):
    """Write outcome bookkeeping for diagnostics (thread-safe)."""

    def __init__(self):
        self.lock = threading.Lock()
        self.writes = 0
        self.rejected = 0
        self.failed = 0
        self.last_error = ''
        self.last_error_time = None
        self.storage_broken = False     # last write hit a storage error, none succeeded since

    def ok(self):
        with self.lock:
            self.writes += 1
            self.storage_broken = False

    def error(self, text, storage):
        with self.lock:
            if storage:
                self.failed += 1
                self.storage_broken = True
            else:
                self.rejected += 1
            self.last_error = text
            self.last_error_time = rospy.get_rostime()


class DatabaseNode(object):

    def __init__(self):
        self._db_path = os.path.expanduser(str(rospy.get_param('~db_path', DEFAULT_DB_PATH)))
        self._site = str(rospy.get_param('~site', ''))
        self._server_timeout = float(rospy.get_param('~server_timeout', 2.0))
        self._result_timeout = float(rospy.get_param('~result_timeout', 10.0))
        self._ack_timeout = float(rospy.get_param('~ack_timeout', 2.0))
        self._target_frame = str(rospy.get_param('~target_frame', ''))
        self._min_ripeness = float(rospy.get_param('~min_ripeness', 0.0))
        queue_size = int(rospy.get_param('~queue_size', 1000))
        synchronous = str(rospy.get_param('~synchronous', 'FULL'))
        if not (self._server_timeout > 0.0 and self._result_timeout > 0.0 and
                self._ack_timeout > 0.0):
            raise DatabaseNodeError('~server_timeout, ~result_timeout and ~ack_timeout must be '
                                    '> 0 (got %g, %g, %g)' % (self._server_timeout,
                                                              self._result_timeout,
                                                              self._ack_timeout))

        directory = os.path.dirname(self._db_path)
        try:
            if directory:
                os.makedirs(directory, exist_ok=True)
            self._store = Store(self._db_path, synchronous=synchronous)
        except (OSError, ValueError, StoreError) as e:
            hint = '' if isinstance(e, SchemaVersionError) else ' (check ~db_path)'
            raise DatabaseNodeError('cannot open the database %s: %s%s' % (self._db_path, e, hint))
        rospy.loginfo('database: %s (schema %d, %s, synchronous=%s)', self._db_path,
                      self._store.schema_version, self._store.journal_mode,
                      self._store.synchronous)

        self._health = _Health()
        self._cond = threading.Condition()
        self._stopping = False
        self._scan_token = None         # the image_processing goal being waited for
        self._scan_done = False

        self._updater = diagnostic_updater.Updater()
        self._updater.setHardwareID('sqlite:%s' % self._db_path)
        self._updater.add('Local database', self._diagnose)

        self._ip = actionlib.SimpleActionClient(names.IMAGE_PROCESSING, ImageProcessingAction)
        self._server = actionlib.SimpleActionServer(names.SPATIAL_TEMPORAL, SpatialTemporalAction,
                                                    auto_start=False)
        self._server.register_goal_callback(self._wake)
        self._server.register_preempt_callback(self._wake)
        self._worker = threading.Thread(target=self._work, name='spatial_temporal')
        self._worker.daemon = True
        self._worker.start()
        self._server.start()

        self._subs = [
            rospy.Subscriber(names.PICK_RECORDS, PickRecord, self._on_pick_record,
                             queue_size=queue_size),
            rospy.Subscriber(names.EVENTS, MissionEvent, self._on_event, queue_size=queue_size),
            rospy.Subscriber(names.CHECKPOINTS, Checkpoint, self._on_checkpoint,
                             queue_size=queue_size),
        ]
        self._service = rospy.Service(names.GET_MISSION_RECORDS, GetMissionRecords,
                                      self._on_get_records)
        self._checkpoint_service = rospy.Service(names.GET_CHECKPOINT, GetCheckpoint,
                                                 self._on_get_checkpoint)
        self._timer = rospy.Timer(rospy.Duration(DIAGNOSTICS_PERIOD_S),
                                  lambda _event: self._updater.update())

    # ------------------------------------------------------------ writes from topics

    def _write(self, what, fn, *args):
        """Run a store write; book the outcome. Returns (ok, error text)."""
        try:
            fn(*args)
        except ValueError as e:
            text = 'rejected %s: %s' % (what, e)
            self._health.error(text, storage=False)
            rospy.logwarn_throttle(5.0, text)
            return False, text
        except sqlite3.Error as e:
            text = 'database write of %s failed: %s' % (what, e)
            self._health.error(text, storage=True)
            rospy.logerr_throttle(5.0, text)
            return False, text
        self._health.ok()
        return True, ''

    def _on_pick_record(self, msg):
        self._write('pick record', lambda: self._store.add_pick_record(
            convert.pick_record_to_dict(msg), site=self._site))

    def _on_event(self, msg):
        self._write('mission event', lambda: self._store.add_event(
            convert.event_to_dict(msg), site=self._site))

    def _on_checkpoint(self, msg):
        self._write('checkpoint', lambda: self._store.put_checkpoint(
            convert.checkpoint_to_dict(msg), site=self._site))

    # ------------------------------------------------------------ services

    def _on_get_checkpoint(self, req):
        resp = GetCheckpointResponse()
        try:
            row = self._store.latest_unfinished_checkpoint(req.robot)
        except sqlite3.Error as e:
            resp.found = False
            resp.message = 'database read failed: %s' % e
            return resp
        if row is None:
            resp.found = False
            resp.message = 'no unfinished mission of robot %r' % req.robot
            return resp
        resp.found = True
        resp.checkpoint = convert.checkpoint_from_dict(row)
        resp.message = 'mission %s at picking point %d, phase %r' % (
            row['mission_id'], row['picking_point'], row['phase'])
        return resp

    def _on_get_records(self, req):
        resp = GetMissionRecordsResponse()
        try:
            mission_id, records, events = self._store.mission_records(req.mission_id)
        except sqlite3.Error as e:
            resp.success = False
            resp.message = 'database read failed: %s' % e
            return resp
        if mission_id is None:
            resp.success = False
            resp.mission_id = req.mission_id
            resp.message = ('no mission %r in the database' % req.mission_id if req.mission_id
                            else 'the database holds no mission yet')
            return resp
        resp.success = True
        resp.mission_id = mission_id
        resp.records = [convert.pick_record_from_dict(r) for r in records]
        resp.events = [convert.event_from_dict(e) for e in events]
        resp.message = '%d pick records, %d events' % (len(resp.records), len(resp.events))
        return resp

    # ------------------------------------------------------------ spatial_temporal server

    def _wake(self):
        with self._cond:
            self._cond.notify_all()

    def _work(self):
        while True:
            with self._cond:
                while not self._stopping and not self._server.is_new_goal_available():
                    self._cond.wait()
                if self._stopping:
                    return
            goal = self._server.accept_new_goal()
            if goal is None:
                continue
            try:
                self._execute(goal)
            except Exception as e:  # keep the worker alive, never leave the goal active
                rospy.logerr('spatial_temporal: unexpected error: %s', e)
                if self._server.is_active():
                    self._abort('unexpected error: %s' % e)

    def _abort(self, text):
        rospy.logwarn_throttle(5.0, 'spatial_temporal aborted: %s' % text)
        self._server.set_aborted(SpatialTemporalResult(success=False, stored=0, message=text), text)

    def _on_scan_done(self, token):
        def done_cb(_state, _result):
            with self._cond:
                if self._scan_token is token:
                    self._scan_done = True
                    self._cond.notify_all()
        return done_cb

    def _scan_handle_done(self):
        # SimpleActionClient drops a transition that arrives before send_goal() has stored the
        # goal handle (ros/actionlib#206), so done_cb may never come for a very fast server:
        # read the handle's own state as well.
        handle = self._ip.gh
        return handle is not None and handle.get_comm_state() == CommState.DONE

    def _scan_unacknowledged(self, sent):
        """True when image_processing has published goal statuses for ~ack_timeout (ROS time)
        since the scan goal was sent at `sent` without ever listing it. The goal was lost on its
        way: the server went down (a respawn) after wait_for_server, and its successor never
        got it. actionlib's client only gives up on a goal the server has listed (LOST), so
        this one would be waited for until ~result_timeout."""
        handle = self._ip.gh
        if handle is None or handle.get_comm_state() != CommState.WAITING_FOR_GOAL_ACK:
            return False
        status = self._ip.action_client.last_status_msg
        return status is not None and \
            (status.header.stamp - sent).to_sec() >= self._ack_timeout

    def _execute(self, goal):
        problem = convert.check_spatial_temporal_goal(goal)
        if problem:
            self._abort('invalid goal: %s' % problem)
            return
        if not self._ip.wait_for_server(rospy.Duration(self._server_timeout)):
            self._abort('the %s action server is not available (waited %.1f s)'
                        % (self._ip.action_client.ns, self._server_timeout))
            return

        request = ImageProcessingGoal(request=ImageProcessingGoal.SPATIAL_POSITIONING,
                                      target_frame=self._target_frame,
                                      min_ripeness=self._min_ripeness)
        token = object()
        with self._cond:
            self._scan_token = token
            self._scan_done = False
        self._ip.send_goal(request, done_cb=self._on_scan_done(token))
        sent = rospy.get_rostime()
        deadline = sent + rospy.Duration(self._result_timeout)
        sends = 1
        with self._cond:
            while not (self._scan_done or self._scan_handle_done() or self._stopping
                       or self._server.is_preempt_requested()
                       or rospy.get_rostime() >= deadline):
                if self._scan_unacknowledged(sent):
                    if sends == 2:
                        break
                    # sent again once: the new goal replaces the lost one in the client
                    rospy.logwarn('spatial_temporal: %s did not acknowledge the scan goal '
                                  'within %.1f s (its server restarted?): sending it again'
                                  % (self._ip.action_client.ns, self._ack_timeout))
                    self._ip.send_goal(request, done_cb=self._on_scan_done(token))
                    sent = rospy.get_rostime()
                    sends += 1
                self._cond.wait(_WAIT_SLICE_S)
            done = self._scan_done or self._scan_handle_done()
            unacknowledged = not done and self._scan_unacknowledged(sent)
            self._scan_token = None
        if not done:
            self._ip.cancel_goal()
            if self._server.is_preempt_requested() or self._stopping:
                self._server.set_preempted(
                    SpatialTemporalResult(success=False, stored=0, message='preempted'),
                    'preempted')
            elif unacknowledged:
                self._abort('%s did not acknowledge the scan goal, sent twice, within %.1f s '
                            'each' % (self._ip.action_client.ns, self._ack_timeout))
            else:
                self._abort('%s gave no result within %.1f s'
                            % (self._ip.action_client.ns, self._result_timeout))
            return

        state = self._ip.get_state()
        scan = self._ip.get_result()
        if state != GoalStatus.SUCCEEDED or scan is None or not scan.success:
            detail = scan.message if scan is not None and scan.message else \
                self._ip.get_goal_status_text() or (
                    'its server no longer lists the goal (restarted?)'
                    if state == GoalStatus.LOST else 'no reason given')
            self._abort('%s scan failed (goal %s): %s'
                        % (self._ip.action_client.ns, _status_name(state), detail))
            return

        observations = convert.observations_from_tomatoes(scan.tomatoes)
        ok, error = self._write('observations', lambda: self._store.add_observations(
            goal.mission_id, goal.picking_point, goal.track_position, observations,
            site=self._site))
        if not ok:
            self._abort(error)
            return
        stored = len(observations)
        self._server.publish_feedback(SpatialTemporalFeedback(stored=stored))
        text = 'stored %d tomato observations (mission %s, picking point %d)' % (
            stored, goal.mission_id, goal.picking_point)
        rospy.loginfo('spatial_temporal: %s', text)
        self._server.set_succeeded(SpatialTemporalResult(success=True, stored=stored,
                                                         message=text), text)

    # ------------------------------------------------------------ diagnostics

    def _diagnose(self, stat):
        level, summary = DiagnosticStatus.OK, 'database OK'
        try:
            counts = self._store.row_counts(TABLES + LOCAL_TABLES)
        except sqlite3.Error as e:
            counts = {}
            level, summary = DiagnosticStatus.ERROR, 'database unreadable: %s' % e
        free = None
        try:
            free = shutil.disk_usage(os.path.dirname(self._db_path) or '.').free
        except OSError:
            pass
        with self._health.lock:
            h = self._health
            recent_reject = (h.last_error_time is not None and not h.storage_broken and
                             (rospy.get_rostime() - h.last_error_time).to_sec()
                             < REJECTED_INPUT_WARN_S)
            if level == DiagnosticStatus.OK:
                if h.storage_broken:
                    level, summary = DiagnosticStatus.ERROR, 'writes failing: %s' % h.last_error
                elif free is not None and free < DISK_FREE_ERROR_BYTES:
                    level, summary = DiagnosticStatus.ERROR, 'disk almost full'
                elif free is not None and free < DISK_FREE_WARN_BYTES:
                    level, summary = DiagnosticStatus.WARN, 'disk space low'
                elif recent_reject:
                    level, summary = DiagnosticStatus.WARN, 'input rejected recently'
            stat.summary(level, summary)
            stat.add('db_path', self._db_path)
            stat.add('file size [bytes]', self._store.file_size())
            stat.add('free disk [bytes]', free if free is not None else 'unknown')
            stat.add('schema version', self._store.schema_version)
            for table in sorted(counts):
                stat.add('rows: %s' % table, counts[table])
            stat.add('writes', h.writes)
            stat.add('rejected inputs', h.rejected)
            stat.add('failed writes', h.failed)
            stat.add('last write error', h.last_error or 'none')
        return stat

    # ------------------------------------------------------------ shutdown

    def shutdown(self):
        with self._cond:
            if self._stopping:
                return
            self._stopping = True
            self._cond.notify_all()
        self._timer.shutdown()
        self._worker.join(2.0)
        self._store.close()
