"""ROS glue of the task-planning node: parameters, emergency stop and resume, records, introspection.

This module holds the node (TaskPlanner); its configuration is in executive_config.py, its
emergency stop and resume in executive_estop.py (TaskPlanner's base class), the checkpoint
message and the publishers' listeners in executive_publishers.py (each re-exported here).

Node `task_planner`
  Action clients (relative names, see config/executive.yaml `actions`): self_test, move_base,
    tomato_scan, spatial_temporal, kinematics, move_robot, end_effector, visual_servo
  Subscribes: emergency_stop (std_msgs/Bool, latched by publishers: the stop button's level; its
              rise to true stops, its fall to false resumes),
              plan/picking_points (std_msgs/Int32MultiArray, latched: the day's plan, visit order)
  Services:   ~start, ~emergency_stop, ~resume (std_srvs/Trigger; ~start when ~autostart is false;
              ~resume ends an emergency stop, or continues a mission that DO_ERROR ended once the
              operator has cleared the fault: continue_after_fault)
  Calls:      halt_all (std_srvs/Trigger, motion_pkg) on DO_STOP and DO_ERROR;
              get_checkpoint, get_mission_records (database_pkg) once at start (~resume_unfinished)
  Master:     looks up `watched_nodes` every `node_watch_period`: a node registered again from a
              new process (respawned) is a mission event `restart` with the node's name as state
  Publishes:  mission/pick_records (harvest_msgs/PickRecord), mission/events (harvest_msgs/MissionEvent)
              (both sent again in full to a subscriber that connects later: _Replayed),
              mission/checkpoints (harvest_msgs/Checkpoint, latched, synchronous: the progress),
              mission/summary (std_msgs/String, JSON totals, latched), ~state (std_msgs/String, latched)
  Introspection: <~introspection_name>/smach/container_structure, container_status, container_init
  Subscribes (schedule pipelined): joint_states (sensor_msgs/JointState: where the arms are)
  Params: ~mission_id, ~picking_points (list of indices; default all of /track/picking_points),
    ~autostart (true), ~shutdown_when_done (false), ~robot_description_yaml (pipelined: robot.yaml,
    default harvest_description's), ~robot_name (''), ~starts (written by the node: how often it
    started in this launch), and everything of config/executive.yaml.
"""
import os
import threading
import time
import warnings

import rosgraph
import rospy
from sensor_msgs.msg import JointState
from std_msgs.msg import Bool, Int32MultiArray, String
from std_srvs.srv import Trigger

from harvest_msgs.msg import Checkpoint, MissionEvent, PickRecord
from harvest_msgs.srv import GetCheckpoint, GetMissionRecords
from control_pkg.smach_compat import IntrospectionServer
from control_pkg import checkpoint as checkpoint_lib
from control_pkg import executive
from control_pkg.executive_config import defaults_path, load_defaults, merged_config  # noqa: F401
from control_pkg.executive_estop import EmergencyStopAndResume
from control_pkg.executive_publishers import (  # noqa: F401 - re-exported
    snapshot_to_msg, snapshot_from_msg, _Subscribed, _Replayed)
from control_pkg.executive_states import MissionContext
from control_pkg import mission as mission_lib
from control_pkg import names
from control_pkg import node_watch

#: mission outcomes that finish its checkpoint (a preempted one, the node shut down, goes on)
_FINISHED = ('succeeded', 'aborted')


class TaskPlanner(EmergencyStopAndResume):
    """Builds the state machine, wires emergency stop/resume and records, and runs the mission.

    The emergency stop and resume (topic, services, halt_all) are its base class's
    (executive_estop.EmergencyStopAndResume)."""

    def __init__(self):
        defaults = load_defaults()
        private = rospy.get_param('~', {})        # one call to the master, not two per key
        overrides = {k: private[k] for k in defaults if k in private}
        try:
            self.config = merged_config(overrides, defaults)
        except ValueError as exc:
            rospy.logfatal('task_planner: bad configuration: %s', exc)
            raise
        # every (re)start of the node in this launch counts (the parameter server outlives it)
        self.starts = int(rospy.get_param('~starts', 0)) + 1
        rospy.set_param('~starts', self.starts)
        self.robot_name = str(rospy.get_param('~robot_name', ''))
        # synchronous (no queue): once publish() returns the checkpoint is on its way in the
        # kernel, so a SIGKILL right after it does not lose it; latched for a respawned store
        self._checkpoint_listener = _Subscribed()
        with warnings.catch_warnings():     # rospy warns of queue_size None: deliberate here
            warnings.simplefilter('ignore', SyntaxWarning)
            self._checkpoint_pub = rospy.Publisher(names.CHECKPOINTS, Checkpoint, latch=True,
                                                   subscriber_listener=self._checkpoint_listener,
                                                   queue_size=None)
        resumed = self._unfinished_checkpoint()
        # wall clock, not ROS time: rospy.get_time() is 0 before the first /clock under sim time
        self.mission_id = resumed.mission_id if resumed is not None else (
            rospy.get_param('~mission_id', '') or mission_lib.make_mission_id(
                time.time(), os.urandom(2).hex()))
        self._plan = None
        self._plan_received = threading.Event()
        self._plan_sub = rospy.Subscriber(names.PLAN, Int32MultiArray, self._plan_cb, queue_size=1)
        self.progress = mission_lib.Progress(loader=self._load_points)
        # a fruit tried again after an emergency stop: the same one within resume_skip_tolerance
        self.recorder = mission_lib.MissionRecorder(
            self.mission_id, same_fruit=float(self.config['resume_skip_tolerance']))
        self.shutdown_when_done = rospy.get_param('~shutdown_when_done', False)

        self._record_listener = _Replayed()
        self._record_pub = rospy.Publisher(names.PICK_RECORDS, PickRecord, queue_size=100,
                                           subscriber_listener=self._record_listener)
        self._event_listener = _Replayed()
        self._event_pub = rospy.Publisher(names.EVENTS, MissionEvent, queue_size=100,
                                          subscriber_listener=self._event_listener)
        self._summary_pub = rospy.Publisher(names.SUMMARY, String, queue_size=1, latch=True)
        self._state_pub = rospy.Publisher(names.STATE, String, queue_size=1, latch=True)
        self._halt = None                  # persistent halt_all proxy, made on first use
        self._halt_lock = threading.Lock()

        self.estop = threading.Event()
        self.resume = threading.Event()
        self._estop_level = False          # the emergency_stop topic's last value (or true: motion)
        self._estop_level_lock = threading.Lock()
        self.checkpoints = checkpoint_lib.CheckpointKeeper(self.mission_id, self.robot_name,
                                                           publish=self.publish_checkpoint)
        self.context = MissionContext(self.config, self.progress, self.recorder,
                                      publish_event=self.publish_event,
                                      publish_record=self.publish_record, halt=self.halt_axes,
                                      checkpoint=self.checkpoints)
        self.context.stopping = self.estop.is_set
        self.context.request_stop = self.stop_heard_by_motion
        self.resuming = resumed is not None
        if resumed is not None:
            self._prepare_resume(resumed)
        self._load_geometry()
        if self.config['schedule'] == mission_lib.SCHEDULE_PIPELINED:
            self._setup_pipelined()
        self.sm = executive.build_state_machine(self.context, self.estop, self.resume)
        self._introspection = IntrospectionServer(rospy.get_param('~introspection_name', names.INTROSPECTION_SERVER),
                                                  self.sm, '/SM_ROOT')
        self._introspection.start()
        rospy.Subscriber(names.EMERGENCY_STOP, Bool, self._estop_topic_cb, queue_size=10)
        rospy.Service(names.EMERGENCY_STOP_SERVICE, Trigger, self._estop_srv)
        rospy.Service(names.RESUME, Trigger, self._resume_srv)
        rospy.Service(names.START, Trigger, self._start_srv)
        self.outcome = None
        self._thread = None
        self._run_lock = threading.Lock()     # ~start and ~resume after a fault
        self._fault_snapshot = None           # the checkpoint DO_ERROR ended the mission at
        rospy.on_shutdown(self.on_shutdown)
        self._watch_nodes_setup()
        if self.starts > 1:
            self._event_listener.event.wait(float(self.config['checkpoint_wait']))
            plan = self.context.resume
            self.publish_event('restart', 'RESTART', checkpoint_lib.restart_detail(
                self.starts, self.mission_id if self.resuming else None,
                plan.why if plan is not None else ''))
        rospy.loginfo('task_planner: mission %s ready', self.mission_id)

    # --- restarts of other nodes ---------------------------------------------------------------
    def _watch_nodes_setup(self):
        """Look up `watched_nodes` with the master every `node_watch_period` (ROS time): a node
        registered again from a new process (respawned) is a mission event `restart`."""
        watched = [rospy.resolve_name(n) for n in self.config['watched_nodes']]
        self._restarts = node_watch.RestartTracker(watched)
        self._master = rosgraph.Master(rospy.get_name())
        period = float(self.config['node_watch_period'])
        self._node_watch_timer = None
        if period > 0 and watched:
            self._watch_nodes()
            self._node_watch_timer = rospy.Timer(rospy.Duration(period), self._watch_nodes)

    def _watch_nodes(self, _event=None):
        uris = {}
        for name in self._restarts.names:
            try:
                uris[name] = self._master.lookupNode(name)
            except (rosgraph.MasterException, OSError):
                uris[name] = None           # not running (or not in this launch), or no master
        for name, old, new in self._restarts.update(uris):
            detail = node_watch.restart_detail(name, old, new)
            rospy.logwarn('task_planner: %s', detail)
            self.publish_event('restart', name, detail)

    # --- crash-safe continuation ---------------------------------------------------------------
    def _unfinished_checkpoint(self):
        """The latest unfinished checkpoint of this robot to continue (a Snapshot), or None.
        One not to continue (a new mission id asked for, or a new launch with
        resume_after_relaunch false) is closed as 'abandoned'."""
        if not self.config['resume_unfinished']:
            return None
        wait = float(self.config['checkpoint_wait'])
        try:
            rospy.wait_for_service(names.GET_CHECKPOINT, timeout=wait)
            resp = rospy.ServiceProxy(names.GET_CHECKPOINT, GetCheckpoint)(robot=self.robot_name)
        except (rospy.ROSException, rospy.ServiceException) as exc:
            rospy.logwarn('task_planner: no checkpoint read (%s): starting a new mission', exc)
            return None
        if not resp.found:
            rospy.loginfo('task_planner: %s', resp.message)
            return None
        snap = snapshot_from_msg(resp.checkpoint)
        asked = rospy.get_param('~mission_id', '')
        why = None
        if asked and asked != snap.mission_id:
            why = 'mission %s asked for' % asked
        elif self.starts == 1 and not self.config['resume_after_relaunch']:
            why = 'a new launch (resume_after_relaunch false)'
        if why is None:
            rospy.logwarn('task_planner: continuing unfinished mission %s (picking point %d, '
                          'phase %r)', snap.mission_id, snap.picking_point, snap.phase)
            return snap
        rospy.logwarn('task_planner: unfinished mission %s abandoned: %s', snap.mission_id, why)
        self._checkpoint_listener.event.wait(wait)
        closed = checkpoint_lib.CheckpointKeeper(snap.mission_id, snap.robot)
        closed.restore(snap)
        self._checkpoint_pub.publish(snapshot_to_msg(closed.finish('abandoned'), rospy.Time.now()))
        return None

    def _recorded(self, mission_id):
        """The pick records of `mission_id` already in the store (get_mission_records)."""
        try:
            rospy.wait_for_service(names.GET_MISSION_RECORDS, timeout=float(self.config['checkpoint_wait']))
            resp = rospy.ServiceProxy(names.GET_MISSION_RECORDS, GetMissionRecords)(mission_id=mission_id)
        except (rospy.ROSException, rospy.ServiceException) as exc:
            rospy.logwarn('task_planner: the records of mission %s cannot be read (%s)', mission_id, exc)
            return []
        return list(resp.records) if resp.success else []

    def _prepare_resume(self, snap):
        records = self._recorded(snap.mission_id)
        recorded = [(r.picking_point, r.target_id,
                     (r.pick_point.point.x, r.pick_point.point.y, r.pick_point.point.z))
                    for r in records]
        plan = checkpoint_lib.resume_plan(snap, recorded, float(self.config['resume_skip_tolerance']))
        self.recorder.restore([(r.picking_point, r.target_id, recorded[i][2],
                                mission_lib.OUTCOME_NAMES.get(r.outcome, mission_lib.OUTCOME_FAILED), r.reason,
                                r.cycle_time) for i, r in enumerate(records)],
                              points_visited=max(snap.point_index, 0))
        self.checkpoints.restore(snap)
        if snap.points:
            self.progress.resume_at(snap.points, plan.point_index)
        self.context.skip[snap.picking_point] = plan.skip
        self.context.resume = plan
        self.context.resume_snapshot = snap
        rospy.logwarn('task_planner: resume plan: %s (steps %s; %d record(s) of this mission '
                      'already stored)', plan.why, ', '.join(plan.steps), len(records))

    def publish_checkpoint(self, snap):
        self._checkpoint_pub.publish(snapshot_to_msg(snap, rospy.Time.now()))

    def _load_geometry(self):
        """The robot's geometry (motion_pkg's kinematics, robot.yaml): the stereo head's eye
        for the look at the held fruit, and the pipelined schedule's collision guard."""
        try:
            from motion_pkg.kinematics import RobotGeometry
            import rospkg
            path = rospy.get_param('~robot_description_yaml', '') or os.path.join(
                rospkg.RosPack().get_path('harvest_description'), 'config', 'robot.yaml')
            self.context.geometry = RobotGeometry.from_yaml(path)
        except Exception as exc:  # noqa: BLE001 - without it the mission runs, see below
            rospy.logerr('task_planner: no robot geometry (%s): a smaller held fruit keeps its '
                         'first estimate, and in the pipelined schedule every step runs in the '
                         'paper order', exc)

    def _setup_pipelined(self):
        """The pipelined schedule's guard needs the robot's geometry (_load_geometry) and
        where the arms are (joint_states)."""
        rospy.Subscriber(names.JOINT_STATES, JointState, self._joints_cb, queue_size=10)
        rospy.loginfo('task_planner: pipelined schedule (arm moves %s)',
                      'concurrent' if self.config['concurrent_arm_moves'] else 'taking turns')

    def _joints_cb(self, msg):
        if len(msg.name) == len(msg.position):
            self.context.set_joints(msg.name, msg.position)

    def _plan_cb(self, msg):
        self._plan = [int(p) for p in msg.data]
        self._plan_received.set()
        rospy.loginfo('task_planner: plan of the day received: picking points %s', self._plan)

    def _plan_published(self):
        """Whether a node publishes the day's plan: connected, or known to the master."""
        if self._plan_sub.get_num_connections() > 0:
            return True
        try:
            topic = self._plan_sub.resolved_name
            return any(name == topic for name, _ in rospy.get_published_topics())
        except Exception as exc:  # noqa: BLE001 - no master answer: go by the connections
            rospy.logwarn('task_planner: cannot ask the master for a plan publisher: %s', exc)
            return False

    def _load_points(self):
        """The picking points to visit: ~picking_points; else the day's plan from the farm server
        (latched `plan/picking_points`, network_pkg's uploader); else every point of the track.

        Read when the mission reaches its first point (after DO_START), so the track layout
        (/track/picking_points, set by the site configuration or the simulator) may come late.
        """
        points = rospy.get_param('~picking_points', None)
        if points is None and self._plan is None and self._plan_published():
            # a plan publisher is there: its latched plan is on its way (the connection to a
            # publisher that the master knows may still be in its handshake)
            self._plan_received.wait(5.0)
        if points is None and self._plan is not None:
            points = self._plan
        if points is None:
            track = rospy.get_param(names.TRACK_PICKING_POINTS, None)
            if track is None:
                raise ValueError('no picking points: neither ~picking_points nor track/picking_points is set')
            points = list(range(len(track)))
        rospy.loginfo('task_planner: %d picking points to visit: %s', len(points), points)
        return [int(p) for p in points]

    # --- records ---------------------------------------------------------------------------------
    def publish_event(self, kind, state, detail):
        self._event_listener.publish(self._event_pub, MissionEvent(
            mission_id=self.mission_id, stamp=rospy.Time.now(), kind=kind, state=state, detail=detail))
        if kind in ('state', 'estop', 'resume', 'fault'):
            self._state_pub.publish(String(data='%s: %s' % (state, detail)))

    def publish_record(self, record):
        if record is None:
            return
        msg = PickRecord(mission_id=self.mission_id, picking_point=int(record.picking_point),
                         target_id=int(record.target_id), outcome=mission_lib.OUTCOME_CODES[record.outcome],
                         reason=record.reason, state_names=list(record.state_names),
                         state_durations=list(record.state_durations), cycle_time=record.cycle_time,
                         stamp=rospy.Time.now())
        msg.pick_point.header.frame_id = self.config['base_frame']
        msg.pick_point.point.x, msg.pick_point.point.y, msg.pick_point.point.z = record.position
        self._record_listener.publish(self._record_pub, msg)

    # --- running ---------------------------------------------------------------------------------
    def start(self):
        self.publish_event('state', 'START', 'mission %s %s' % (
            self.mission_id, 'continued after a restart' if self.resuming else 'started'))
        self._thread = threading.Thread(target=self._run, name='task_planner')
        self._thread.daemon = True
        self._thread.start()

    def _run(self):
        try:
            self.outcome = self.sm.execute()
        except Exception as exc:  # noqa: BLE001 - a crashed machine must still be reported
            rospy.logerr('task_planner: state machine raised: %s', exc)
            self.context.fail('executive exception: %s' % exc)
            self.outcome = 'aborted'
        self.recorder.finish(rospy.get_time())
        # a mission cut short by the node's shutdown (SMACH may then end it 'aborted') goes on
        # at the next start: only a mission that really ended finishes its checkpoint
        if self.outcome in _FINISHED and not rospy.is_shutdown():
            # a fruit an emergency stop cut short and the mission did not reach again
            self.context.close_interrupted('the mission ended %s before it was tried again'
                                           % self.outcome)
            # after DO_ERROR the operator may clear the fault and resume (continue_after_fault)
            self._fault_snapshot = self.checkpoints.current if self.outcome == 'aborted' else None
            self.checkpoints.finish(self.outcome)
        totals = self.recorder.totals()
        totals['outcome'] = self.outcome
        totals['last_error'] = self.context.last_error
        summary = mission_lib.summary_json(totals)       # strict JSON: null, never NaN
        self._summary_pub.publish(String(data=summary))
        self.publish_event('summary', '', summary)
        rospy.loginfo('task_planner: mission %s ended %s: picked %d, unreachable %d, lost %d, failed %d, '
                      'dropped %d', self.mission_id, self.outcome, totals['picked'], totals['unreachable'],
                      totals['lost'], totals['failed'], totals['dropped'])
        if self.shutdown_when_done:
            rospy.signal_shutdown('mission ended')

    def on_shutdown(self):
        if self.sm.is_running():
            self.sm.request_preempt()
        self.resume.set()
        self._introspection.stop()
