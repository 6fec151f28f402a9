"""ROS node ``motion_server``: owns the Modbus TCP connection to the multi-axis controller.

A poll thread (``~poll_rate``, ROS time) reads the controller, publishes ``joint_states``,
advances the goal monitors, keeps ``motion_status`` and the diagnostics up to date and
reconnects with back-off after a lost connection. Action goals are handled in goal callbacks
(commands are written at once; the poll thread finishes the goal), so a goal costs no
actionlib polling latency. ``move_robot`` is a plain ActionServer that runs one goal per arm at
the same time (a waist goal belongs to both arms; ``motion_goals.ArmGoals``); ``move_base`` and
``end_effector`` run one goal at a time (SimpleActionServer).

Publications:  joint_states (sensor_msgs/JointState), motion_status (diagnostic_msgs/
               DiagnosticStatus, latched, on change), /diagnostics (diagnostic_updater)
Subscriptions: emergency_stop (std_msgs/Bool): every true halts every axis and aborts the move
               goals with motion_goals.ESTOP_HALT_TEXT, so a stop halts the robot even while
               the executive is down (it also halts through halt_all, and pauses the mission)
Services:      halt_all, enable_all (std_srvs/Trigger)
Actions:       move_robot (harvest_msgs/MoveRobot), move_base (harvest_msgs/MoveBase),
               end_effector (harvest_msgs/EndEffector)
Parameters:    see config/motion_server.yaml (all private).

The cart interlock (``~cart_interlock``, ``motion_interlock``): a ``move_base`` goal is refused
while an arm goal runs or an arm is not stowed over the cart, a ``move_robot`` goal while a
``move_base`` goal runs.

The node is composed of mixins, one module each: ``motion_link`` (poll, reconnect, link grace),
``motion_active_goals`` (the running goals), ``motion_moves`` (move_robot, move_base),
``motion_end_effector`` (end_effector) and ``motion_status`` (motion_status, diagnostics);
this module holds the node's parameters, its ROS interfaces and the halt/enable services.
"""

import math
import os
import threading

import actionlib
import rospkg
import rospy
from diagnostic_msgs.msg import DiagnosticStatus
from harvest_msgs.msg import EndEffectorAction, MoveBaseAction, MoveRobotAction
from sensor_msgs.msg import JointState
from std_msgs.msg import Bool
from std_srvs.srv import Trigger, TriggerResponse

from motion_pkg import motion_goals as mg
from motion_pkg.modbus_driver import DriverError, ModbusDriver
from motion_pkg.modbus_map import RegisterMap, parse_serial_number
# _Active, _internal_error and the status constants were defined here: re-exported
from motion_pkg.motion_active_goals import ActiveGoalsMixin, _Active, _internal_error  # noqa: F401
from motion_pkg.kinematics_geometry import ForwardKinematics
from motion_pkg.motion_end_effector import EndEffectorMixin
from motion_pkg.motion_interlock import CartInterlock
from motion_pkg.motion_link import LinkMixin
from motion_pkg.motion_moves import AxesMovesMixin
from motion_pkg.motion_status import (LEVEL_NAMES, POLL_RATE_TOLERANCE,  # noqa: F401
                                      POLL_RATE_WINDOW, StatusMixin)
from harvest_description import robot_config


def _package_file(package, *parts):
    return os.path.join(rospkg.RosPack().get_path(package), *parts)


class MotionServer(LinkMixin, ActiveGoalsMixin, AxesMovesMixin, EndEffectorMixin, StatusMixin):
    """Modbus driver + action servers + status of the motion system."""

    def __init__(self):
        self.regmap = RegisterMap.from_file(
            rospy.get_param('~register_map', '') or
            _package_file('motion_pkg', 'config', 'register_map.yaml'))
        # a bad robot.yaml: one fatal line naming file and field, exit 1 (nothing connects)
        robot = robot_config.load_or_exit(
            rospy.get_param('~robot_config', '') or
            _package_file('harvest_description', 'config', 'robot.yaml'), rospy.logfatal)
        self.limits = mg.limits_from_robot_config(robot)
        # the cart moves only with both arms stowed, no arm moves while the cart does
        # (motion_interlock); false: no such check (a robot whose cart cannot reach the plants)
        self.interlock = None
        if rospy.get_param('~cart_interlock', True):
            try:
                self.interlock = CartInterlock(ForwardKinematics(robot),
                                               rospy.get_param('~stowed_max_x', 0.20))
            except (TypeError, ValueError) as exc:
                rospy.logfatal('~stowed_max_x: %s', exc)          # one fatal line, exit 1
                raise SystemExit(1)
        missing = [a for a in self.regmap.axis_names if a not in self.limits]
        if missing:
            raise ValueError('axes %s of the register map are not in robot.yaml' % missing)
        try:          # the one controller this robot drives (identity block, serial number)
            serial_number = parse_serial_number(rospy.get_param('~controller_serial', 1))
        except ValueError as exc:
            rospy.logfatal('~controller_serial: %s', exc)     # one fatal line, exit 1
            raise SystemExit(1)
        self.driver = ModbusDriver(
            self.regmap, rospy.get_param('~host', '127.0.0.1'), rospy.get_param('~port', 502),
            rospy.get_param('~unit_id', 1), rospy.get_param('~response_timeout', 0.25),
            rospy.get_param('~reconnect_backoff_min', 0.1),
            rospy.get_param('~reconnect_backoff_max', 2.0), serial_number)
        self._refusal_logged = ''
        self.endpoint = '%s:%d' % (self.driver.host, self.driver.port)
        self.poll_rate = float(rospy.get_param('~poll_rate', 60.0))
        self.stale_timeout = float(rospy.get_param('~stale_timeout', 0.5))
        self.auto_enable = bool(rospy.get_param('~auto_enable', True))
        self.tol_linear = float(rospy.get_param('~tolerance_linear', 0.001))
        self.tol_angular = float(rospy.get_param('~tolerance_angular', math.radians(0.2)))
        self.timeout_factor = float(rospy.get_param('~move_timeout_factor', 1.5))
        self.timeout_margin = float(rospy.get_param('~move_timeout_margin', 2.0))
        self.suction_timeout = float(rospy.get_param('~suction_timeout', 2.0))
        self.shear_timeout = float(rospy.get_param('~shear_timeout', 2.0))
        # a lost Modbus link: running goals wait this long (ROS time) for the driver to connect
        # again, then their commands are written again and they go on (0: aborted at once)
        self.link_grace = float(rospy.get_param('~link_grace', 5.0))
        if not math.isfinite(self.link_grace) or self.link_grace < 0.0:
            raise ValueError('~link_grace must be finite and >= 0, got %r' % self.link_grace)
        self._link_lost_at = None             # ROS time the link was lost, until it is back
        self._link_error = ''                 # why it was lost
        self.points_param = rospy.get_param('~picking_points_param', '/track/picking_points')

        self._lock = threading.Lock()          # guards _active, _arm_goals, _state, _poll_index
        self._poll_lock = threading.Lock()     # one poll at a time (poll thread, goal callbacks)
        self._active = {}                      # move_base, end_effector: server name -> _Active
        self._arm_goals = mg.ArmGoals()        # move_robot: a running goal per arm
        self._deferred = []                    # (server, call) left to the poll thread
        self._state = None
        self._poll_index = 0
        self._last_good = None
        self._joint_stamp = None        # ROS time of the last joint_states published
        self._poll_error = ''
        self._last_status = None
        self._status_lock = threading.Lock()
        self._stop = threading.Event()

        self.joint_pub = rospy.Publisher('joint_states', JointState, queue_size=10)
        self.status_pub = rospy.Publisher('motion_status', DiagnosticStatus, queue_size=1,
                                          latch=True)
        self._setup_diagnostics()
        self._publish_status()
        rospy.Service('halt_all', Trigger, self._on_halt_all)
        rospy.Subscriber('emergency_stop', Bool, self._on_emergency_stop, queue_size=10)
        rospy.Service('enable_all', Trigger, self._on_enable_all)
        self.move_robot = actionlib.ActionServer('move_robot', MoveRobotAction,
                                                 self._goal_move_robot, self._cancel_move_robot,
                                                 auto_start=False)
        self.move_robot.start()
        self.move_base = self._action('move_base', MoveBaseAction, self._goal_move_base)
        self.end_effector = self._action('end_effector', EndEffectorAction,
                                         self._goal_end_effector)
        self._thread = threading.Thread(target=self._poll_loop, name='motion_poll')
        self._thread.daemon = True
        self._thread.start()
        rospy.on_shutdown(self.shutdown)

    # --- set-up --------------------------------------------------------------------------
    def _action(self, name, spec, goal_cb):
        server = actionlib.SimpleActionServer(name, spec, auto_start=False)
        server.register_goal_callback(goal_cb)
        server.register_preempt_callback(lambda: self._on_preempt(name, server))
        server.start()
        return server

    def shutdown(self):
        self._stop.set()
        if self._thread.is_alive() and threading.current_thread() is not self._thread:
            self._thread.join(2.0)
        self.driver.close()

    # --- services ------------------------------------------------------------------------
    def _halt_everything(self, text):
        """Halt every axis, then abort the move goals with `text`; (ok, message)."""
        try:
            self.driver.halt_all()
        except DriverError as exc:
            return False, 'halt failed: %s' % exc
        for _, action in self._abort_actions(mg.HALTED, text, ['move_robot', 'move_base']):
            action()
        return True, 'every axis halted'

    def _on_halt_all(self, _req):
        ok, message = self._halt_everything('halted by halt_all')
        if ok:
            rospy.logwarn('halt_all: every axis halted')
        else:
            rospy.logerr('halt_all: %s', message)
        return TriggerResponse(success=ok, message=message)

    def _on_emergency_stop(self, msg):
        if not msg.data:
            return          # released: the executive's resume moves the robot again
        ok, message = self._halt_everything(mg.ESTOP_HALT_TEXT)
        (rospy.logwarn if ok else rospy.logerr)('emergency stop topic: %s', message)

    def _on_enable_all(self, _req):
        try:
            self.driver.enable_all()
        except DriverError as exc:
            return TriggerResponse(success=False, message='enable_all failed: %s' % exc)
        rospy.loginfo('enable_all: faults cleared, every axis enabled')
        return TriggerResponse(success=True, message='faults cleared, every axis enabled')
