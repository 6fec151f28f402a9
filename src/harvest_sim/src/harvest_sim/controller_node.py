"""ROS glue of the simulated motion controller (node ``sim_controller``, run in namespace ``sim``).

Serves the controller model over Modbus TCP and publishes its ground truth for the rest of the
simulator. All timing is ROS time, so the node follows /clock when /use_sim_time is true.

Publications (relative; the node runs in namespace ``sim``):
  joint_states (sensor_msgs/JointState)  URDF joint names, every ``~publish_rate`` (ROS time),
                                         plus, before each shear_cut, one stamped when the
                                         closure was first noticed (the arm where it cut)
  suction_valve (harvest_sim/SuctionValve, latched) valve state on every change,
                                         stamped when it changed
  shear_cut (std_msgs/Header)            one per shear closure, stamp = closing time
  activity (harvest_sim/SimActivity)     for sim_clock: ACTION on every Modbus write, BUSY with
                                         the time until which something is under way (axes,
                                         vacuum build-up, shear) whenever that changes
  ~halt_received (sensor_msgs/TimeReference) one per Modbus write that halts axes: header.stamp
                                         = ROS time of the write, time_ref = its wall time
                                         (time.time()), source = "all" or the halted axes
Subscriptions:
  suction_sealed (std_msgs/Bool)         true while the suction cup sits on a fruit
Services:
  ~inject_fault (std_srvs/Trigger)       apply the fault string in param ``~fault``
  ~set_server_enabled (std_srvs/SetBool) open/close the Modbus TCP listener
  ~drop_connections (harvest_sim/FaultWindow) close every client connection and refuse new
                                         ones for `duration` s of ROS time, then listen again
Parameters:
  ~host (127.0.0.1, loopback only), ~port (5020), ~unit_id (1),
  ~serial_number (1; the identity block's serial number, registers 7-8: the robot's driver
  refuses a controller whose serial number is not its ~controller_serial),
  ~robot_config (path of robot.yaml; default harvest_description/config/robot.yaml),
  ~initial_positions ({axis: value}, SI units), ~publish_rate (60 Hz), ~shear_hold (0.2 s),
  ~fault ("" = normal; see controller_server.FAULT_SYNTAX), applied at start-up too.
An address that cannot be bound (or is not loopback) or a bad ~serial_number raises
StartupError: scripts/sim_controller logs it fatal and exits 1.
"""

import os
import threading

import rospkg
import rospy
import yaml
from sensor_msgs.msg import JointState, TimeReference
from std_msgs.msg import Bool, Header
from std_srvs.srv import SetBool, SetBoolResponse, Trigger, TriggerResponse

from harvest_sim import controller_map as cm
from harvest_sim import names
from harvest_sim.controller_model import ControllerModel, axes_from_robot_config
from harvest_sim.controller_server import ControllerServer, apply_faults, parse_fault_spec
from harvest_sim.msg import SimActivity, SuctionValve
from harvest_sim.srv import FaultWindow, FaultWindowResponse


def default_robot_config():
    return os.path.join(rospkg.RosPack().get_path('harvest_description'), 'config', 'robot.yaml')


class StartupError(Exception):
    """The node cannot do its job (its address cannot be bound, a bad parameter): the script
    logs it as fatal and exits non-zero, and the launch (required="true") ends."""


class SimControllerNode(object):
    """Owns the model, the Modbus server, the publishers and the fault services."""

    def __init__(self):
        path = rospy.get_param('~robot_config', '') or default_robot_config()
        with open(path) as stream:
            robot = yaml.safe_load(stream)
        motion = robot['motion']
        configs = axes_from_robot_config(robot, rospy.get_param('~initial_positions', {}))
        try:
            serial_number = cm.parse_serial_number(
                rospy.get_param('~serial_number', cm.DEFAULT_SERIAL_NUMBER))
        except ValueError as exc:
            raise StartupError('~serial_number: %s' % exc)
        self.model = ControllerModel(configs, motion['suction_build_up'], motion['shear_stroke'],
                                     rospy.get_param('~shear_hold', 0.2), rospy.get_time(),
                                     serial_number)
        self.joint_names = [c.name + '_joint' for c in configs]
        self._lock = threading.Lock()
        self.activity_pub = rospy.Publisher(names.ACTIVITY, SimActivity, queue_size=50,
                                            tcp_nodelay=True)
        self._busy_until = None
        self._activity_lock = threading.Lock()
        try:
            self.server = ControllerServer(self.model, rospy.get_time,
                                           rospy.get_param('~host', '127.0.0.1'),
                                           rospy.get_param('~port', 5020),
                                           rospy.get_param('~unit_id', 1),
                                           on_write=self._on_write, on_halt=self._on_halt)
        except ValueError as exc:                  # not a loopback address
            raise StartupError(str(exc))
        self.joint_pub = rospy.Publisher('joint_states', JointState, queue_size=10)
        self.halt_pub = rospy.Publisher('~halt_received', TimeReference, queue_size=20,
                                        tcp_nodelay=True)
        self.valve_pub = rospy.Publisher('suction_valve', SuctionValve, queue_size=10, latch=True)
        self.cut_pub = rospy.Publisher('shear_cut', Header, queue_size=10)
        self.valve_pub.publish(SuctionValve(header=Header(stamp=rospy.Time.now()), open=False))
        rospy.Subscriber('suction_sealed', Bool, self._on_sealed, queue_size=10)
        try:
            self.server.start()
        except OSError as exc:
            raise StartupError(str(exc))
        rospy.loginfo('simulated motion controller on %s:%d unit %d, serial number %d (%d axes)',
                      self.server.host, self.server.port, self.server.unit, serial_number,
                      len(configs))
        startup_fault = rospy.get_param('~fault', '')
        if startup_fault:
            rospy.logwarn('start-up fault: %s', self._apply(startup_fault))
        rospy.Service('~inject_fault', Trigger, self._on_inject)
        rospy.Service('~set_server_enabled', SetBool, self._on_server_enabled)
        rospy.Service('~drop_connections', FaultWindow, self._on_drop_connections)
        rate = float(rospy.get_param('~publish_rate', 60.0))
        self._timer = rospy.Timer(rospy.Duration(1.0 / rate), self._on_timer)
        rospy.on_shutdown(self.shutdown)

    def _apply(self, text):
        with self._lock:
            summary = apply_faults(parse_fault_spec(text), self.model, self.server,
                                   rospy.get_time())
        self._publish_busy(rospy.get_time())
        return summary

    # --- activity, for sim_clock ---------------------------------------------------------
    def _on_write(self, t):
        """A Modbus write (server thread): the robot acted; what is now under way?"""
        self._publish_activity(SimActivity.ACTION, 0.0)
        self._publish_busy(t)

    def _publish_busy(self, t):
        until = self.model.busy_until(t)
        with self._activity_lock:
            if until == self._busy_until:
                return
            self._busy_until = until
        self._publish_activity(SimActivity.BUSY, until)

    def _publish_activity(self, kind, until):
        msg = SimActivity(source=rospy.get_name(), kind=kind)
        if until > 0.0:
            msg.until = rospy.Time.from_sec(until)
        try:
            self.activity_pub.publish(msg)
        except rospy.ROSException:        # shutting down
            pass

    def _on_inject(self, _req):
        text = rospy.get_param('~fault', '')
        try:
            summary = self._apply(text)
        except (ValueError, RuntimeError, OSError) as exc:
            return TriggerResponse(success=False, message='fault %r not applied: %s' % (text, exc))
        rospy.logwarn('injected fault %r: %s', text, summary)
        return TriggerResponse(success=True, message=summary)

    def _on_server_enabled(self, req):
        with self._lock:
            ok = self.server.set_listening(req.data)
        state = 'listening' if req.data else 'closed'
        rospy.logwarn('Modbus server %s', state if ok else 'failed to listen')
        return SetBoolResponse(success=ok, message=state if ok else 'cannot listen')

    def _on_halt(self, t, wall, halted):
        """A Modbus write halted axes (server thread): when, in ROS and wall time."""
        msg = TimeReference(time_ref=rospy.Time.from_sec(wall), source=' '.join(halted))
        msg.header.stamp = rospy.Time.from_sec(t)
        try:
            self.halt_pub.publish(msg)
        except rospy.ROSException:        # shutting down
            pass

    def _on_drop_connections(self, req):
        now = rospy.get_time()
        try:
            with self._lock:
                closed = self.server.drop_connections_for(req.duration, now)
        except (ValueError, OSError) as exc:
            return FaultWindowResponse(success=False, message='not applied: %s' % exc)
        if req.duration == 0.0:
            text = 'listening again'
        else:
            text = ('closed %d connection(s); refusing connections for %.3f s, until %.3f'
                    % (closed, req.duration, now + req.duration))
        rospy.logwarn('drop_connections: %s', text)
        return FaultWindowResponse(success=True, message=text)

    def _end_outage(self, t):
        with self._lock:
            until = self.server.outage_until
            if until is None or t < until:
                return
            reopened = self.server.end_outage(t)
        if reopened:
            rospy.logwarn('drop_connections: window over, listening again')
        else:
            rospy.logerr_throttle(5.0, 'drop_connections: cannot listen again on %s:%d'
                                  % (self.server.host, self.server.port))

    def _on_sealed(self, msg):
        t = rospy.get_time()
        self.model.set_sealed(msg.data, t)
        self._publish_busy(t)          # a sealed cup starts the vacuum build-up

    def _on_timer(self, _event):
        now = rospy.get_rostime()
        t = now.to_sec()
        self._end_outage(t)
        for event in self.model.pop_events(t):
            if event[0] == 'valve':
                self.valve_pub.publish(SuctionValve(
                    header=Header(stamp=rospy.Time.from_sec(event[1])), open=event[2]))
            elif event[0] == 'shear_cut':
                pose = self.model.pop_closure_pose()
                if pose is not None and pose[0] < t:
                    # the arm where the shear closed, before the joint state of this tick
                    closed = JointState(name=self.joint_names, position=pose[1],
                                        velocity=pose[2])
                    closed.header.stamp = rospy.Time.from_sec(pose[0])
                    self.joint_pub.publish(closed)
                self.cut_pub.publish(Header(stamp=rospy.Time.from_sec(event[1]),
                                            frame_id='left_shear_tcp'))
        positions, velocities = self.model.joint_states(t)
        msg = JointState(name=self.joint_names, position=positions, velocity=velocities)
        msg.header.stamp = now
        self.joint_pub.publish(msg)

    def shutdown(self):
        self._timer.shutdown()
        self.server.stop()
