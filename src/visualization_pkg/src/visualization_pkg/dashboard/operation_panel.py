"""Manual-operation panel (the paper's DashBoard module): mission start, emergency stop and resume,
cart moves, joint jogging, suction and shear.

The emergency stop is always accepted; it latches `emergency_stop` true, calls the executive's
`<executive>/emergency_stop` and `halt_all`, and cancels this panel's own goal (never the
executive's: its states must see the stop through DO_STOP). It counts as
confirmed once the executive reports DO_STOP. Every manual motion is refused unless the executive
is paused (DO_STOP) or no mission is running (executive_state.manual_allowed). Every manual command,
accepted or refused, is published as an operator mission event (operator_events.py).

The waist has a jog row too (robot.yaml axis `waist`, joint `waist_joint`): a waist jog that passes
the same gate sends a `move_robot` goal that moves the waist alone (MoveRobot `move_waist`, no arm
positions), clamped to robot.yaml's waist limits.

The manual actions (jog grid, cart, end effector and their gate) are in manual_actions.py.
"""
import math
import os

import actionlib
import rospy
from python_qt_binding import loadUi
from python_qt_binding.QtCore import Qt, QTimer, Signal
from python_qt_binding.QtGui import QFont
from python_qt_binding.QtWidgets import QMessageBox, QPushButton, QSizePolicy
from sensor_msgs.msg import JointState
from smach_msgs.msg import SmachContainerStatus, SmachContainerStructure
from std_msgs.msg import Bool, String
from std_srvs.srv import Trigger

from harvest_msgs.msg import EndEffectorAction, EndEffectorGoal, MoveBaseAction, MoveRobotAction
from visualization_pkg import names
from visualization_pkg.dashboard import executive_state as es
from visualization_pkg.dashboard.manual_actions import EE_NAMES, ManualActions  # noqa: F401
from visualization_pkg.dashboard.operator_events import OperatorEventPublisher
from visualization_pkg.dashboard.qt_common import Panel, resource_path, ros_now

_MODE_TEXT = {es.UNKNOWN: ('#757575', 'executive: waiting for introspection'),
              es.OFFLINE: ('#757575', 'executive: not running'),
              es.IDLE: ('#1565c0', 'executive: idle (no mission running)'),
              es.RUNNING: ('#2e7d32', 'mission RUNNING'),
              es.PAUSED: ('#c62828', 'mission PAUSED: DO_STOP (axes halted)')}


class EStopButton(QPushButton):
    """The one-click emergency stop: red; amber while waiting for DO_STOP; dark when confirmed."""
    READY, REQUESTED, STOPPED = 'ready', 'requested', 'stopped'

    def __init__(self, parent=None):
        QPushButton.__init__(self, parent)
        self.setObjectName('estop_button')
        font = QFont()
        font.setPointSize(13)
        font.setBold(True)
        self.setFont(font)
        self.setMinimumHeight(44)
        self.setMinimumWidth(230)
        self.setSizePolicy(QSizePolicy.Expanding, QSizePolicy.Fixed)
        self.setToolTip('Emergency stop: pause the mission (DO_STOP) and halt every axis. One click.')
        self.state = None
        self.set_state(self.READY)

    def set_state(self, state):
        if state == self.state:
            return
        self.state = state
        text, bg, fg = {self.READY: ('EMERGENCY STOP', '#d32f2f', '#ffffff'),
                        self.REQUESTED: ('STOP REQUESTED...', '#ef6c00', '#ffffff'),
                        self.STOPPED: ('STOPPED (DO_STOP)', '#7f0000', '#ffeb3b')}[state]
        self.setText(text)
        self.setStyleSheet('QPushButton#estop_button { background-color: %s; color: %s; border: 3px solid #400000;'
                           ' border-radius: 6px; padding: 4px 14px; }'
                           ' QPushButton#estop_button:pressed { background-color: #400000; }' % (bg, fg))


class OperationPanel(ManualActions, Panel):
    title = 'Manual operation'
    root_status = Signal(object)
    structure_seen = Signal(object)
    state_text = Signal(object)
    joints_received = Signal(object)
    summary_received = Signal(object)

    def __init__(self, executive=names.EXECUTIVE, server=names.INTROSPECTION_SERVER,
                 estop_topic=names.EMERGENCY_STOP, halt_service=names.HALT_ALL, actions=None, action_timeout=60.0, robot_yaml='', events=None,
                 parent=None):
        Panel.__init__(self, parent)
        loadUi(resource_path('operation.ui'), self)
        self.executive = executive.rstrip('/')
        self.server = server.rstrip('/')
        self.estop_topic = estop_topic
        self.halt_service = halt_service
        self.actions = {'move_base': 'move_base', 'move_robot': 'move_robot', 'end_effector': 'end_effector'}
        self.actions.update(actions or {})
        self.action_timeout = float(action_timeout)
        self.state = es.ExecutiveState(ros_now())
        self.positions = {}
        self.clients = {}
        self.busy = ''
        self.last_message = ''
        self.confirm = self.confirm_dialog
        self._estop_pub = None
        self._estop_requested = False
        self._goal = None
        self._summary = ''
        self.limits = self._load_limits(robot_yaml)
        self._own_events = events is None
        self.events = OperatorEventPublisher() if events is None else events

        self.estop_button = EStopButton()
        self.estop_layout.addWidget(self.estop_button)
        self.estop_button.clicked.connect(self.emergency_stop)
        self.start_button.clicked.connect(self.start_mission)
        self.resume_button.clicked.connect(self.resume)
        self.move_cart_button.clicked.connect(lambda: self.move_cart(self.point_spin.value()))
        self.suction_on_button.clicked.connect(lambda: self.end_effector(EndEffectorGoal.SUCTION_ON))
        self.suction_off_button.clicked.connect(lambda: self.end_effector(EndEffectorGoal.SUCTION_OFF))
        self.shear_button.clicked.connect(lambda: self.end_effector(EndEffectorGoal.SHEAR_CUT))
        self._build_jog_rows()

        self.root_status.connect(self._on_root_status, Qt.QueuedConnection)
        self.structure_seen.connect(self._on_seen, Qt.QueuedConnection)
        self.state_text.connect(self._on_state_text, Qt.QueuedConnection)
        self.joints_received.connect(self._on_joints, Qt.QueuedConnection)
        self.summary_received.connect(self._on_summary, Qt.QueuedConnection)
        self._timer = QTimer(self)
        self._timer.setInterval(250)
        self._timer.timeout.connect(self.refresh)
        self.refresh()

    # --- ROS --------------------------------------------------------------------------------------
    def start(self):
        Panel.start(self)
        self._estop_pub = rospy.Publisher(self.estop_topic, Bool, queue_size=1, latch=True)
        self.subscribe(self.server + '/' + names.SMACH_STATUS, SmachContainerStatus, self.root_status, 50)
        self.subscribe(self.server + '/' + names.SMACH_STRUCTURE, SmachContainerStructure, self.structure_seen, 50)
        self.subscribe(self.executive + '/' + names.EXECUTIVE_STATE, String, self.state_text)
        self.subscribe(names.JOINT_STATES, JointState, self.joints_received, 5)
        self.subscribe(names.SUMMARY, String, self.summary_received)
        self.clients = {'move_base': actionlib.ActionClient(self.actions['move_base'], MoveBaseAction),
                        'move_robot': actionlib.ActionClient(self.actions['move_robot'], MoveRobotAction),
                        'end_effector': actionlib.ActionClient(self.actions['end_effector'], EndEffectorAction)}
        self.run_in_background('points', lambda: rospy.get_param(names.TRACK_PICKING_POINTS, []))
        if self._own_events:
            self.events.start()
        self._timer.start()

    def shutdown(self):
        self._timer.stop()
        Panel.shutdown(self)
        if self._estop_pub is not None:
            self._estop_pub.unregister()
        self._cancel_own_goal()
        for client in self.clients.values():
            client.stop()
        if self._own_events:
            self.events.shutdown()

    def _on_root_status(self, msg):
        now = ros_now()
        self.state.seen(now)
        if msg.path.count('/') == 1:      # the root container, e.g. /SM_ROOT
            self.state.update_root(msg.active_states, now)
            self.refresh()

    def _on_seen(self, _msg):
        self.state.seen(ros_now())

    def _on_state_text(self, msg):
        self.state.update_text(msg.data, ros_now())
        self.refresh()

    def _on_joints(self, msg):
        for name, pos in zip(msg.name, msg.position):
            self.positions[name] = pos

    def _on_summary(self, msg):
        self._summary = msg.data

    # --- display ------------------------------------------------------------------------------------
    def mode(self):
        return self.state.mode(ros_now())

    def refresh(self):
        mode = self.mode()
        colour, text = _MODE_TEXT[mode]
        detail = self.state.text
        self.mode_label.setText('<span style="color:%s"><b>%s</b></span>%s' % (
            colour, text, ('<br><span style="color:#616161">%s</span>' % detail) if detail else ''))
        if mode == es.PAUSED:
            self.estop_button.set_state(EStopButton.STOPPED)
            self._estop_requested = False
        elif self._estop_requested:
            self.estop_button.set_state(EStopButton.REQUESTED)
        else:
            self.estop_button.set_state(EStopButton.READY)
        allowed, reason = self.state.manual_allowed(ros_now())
        locked = {es.RUNNING: 'locked while the mission runs', es.UNKNOWN: 'locked until the executive is seen'}
        self.jog_box.setTitle('Jog joints (arms: move_robot)%s' % ('' if allowed else ' - ' + locked.get(mode, 'locked')))
        for joint, label in self.jog_value_labels.items():
            if joint in self.positions:
                v = self.positions[joint]
                label.setText('%.3f m' % v if '_lift_' in joint else '%.1f deg' % math.degrees(v))

    def report(self, text, ok=True):
        self.last_message = text
        colour = '#2e7d32' if ok else '#c62828'
        self.status_label.setText('<span style="color:%s">%s</span>' % (colour, text))
        self.history.appendPlainText(('' if ok else '! ') + text)
        (rospy.loginfo if ok else rospy.logwarn)('dashboard: %s', text)

    def confirm_dialog(self, question):
        answer = QMessageBox.question(self, 'Confirm', question, QMessageBox.Yes | QMessageBox.No, QMessageBox.No)
        return answer == QMessageBox.Yes

    # --- mission buttons ----------------------------------------------------------------------------
    def emergency_stop(self):
        """One click, always accepted: latch the stop, ask the executive, halt the axes."""
        self._estop_requested = True
        if self._estop_pub is not None:
            self._estop_pub.publish(Bool(data=True))
        self._cancel_own_goal()     # only this panel's goal; never the executive's
        self.run_in_background('estop', self._call_estop)
        self.report('EMERGENCY STOP requested')
        self.refresh()
        return True

    def _cancel_own_goal(self):
        gh, self._goal = self._goal, None
        if gh is not None and self.busy:
            gh.cancel()

    def _call_estop(self):
        out = []
        for name in (self.executive + '/' + names.EXECUTIVE_EMERGENCY_STOP, self.halt_service):
            out.append(self._trigger(name, 1.0))
        return out

    @staticmethod
    def _trigger(name, timeout):
        try:
            rospy.wait_for_service(name, timeout=timeout)
            resp = rospy.ServiceProxy(name, Trigger)()
            return name, resp.success, resp.message
        except (rospy.ROSException, rospy.ServiceException) as exc:
            return name, False, str(exc)

    def resume(self):
        mode = self.mode()
        if mode == es.RUNNING:
            self.report('Resume refused: the mission is not paused', ok=False)
            return False
        self._estop_requested = False
        self.run_in_background('resume', self._trigger, self.executive + '/' + names.EXECUTIVE_RESUME, 2.0)
        self.report('Resume requested')
        return True

    def start_mission(self):
        mode = self.mode()
        if mode in (es.RUNNING, es.PAUSED):
            self.report('Start refused: a mission is already %s' % mode, ok=False)
            return False
        self.run_in_background('start', self._trigger, self.executive + '/' + names.EXECUTIVE_START, 2.0)
        self.report('Start mission requested')
        return True

    def on_task_done(self, tag, result):
        if isinstance(result, Exception):
            self.report('%s failed: %s' % (tag, result), ok=False)
            if tag == 'action':
                self.busy = ''
            return
        if tag == 'action':
            self.busy = ''
            what, ok, text, action = result
            self.report('%s: %s' % (what, text), ok=ok)
            self.manual_event(action, 'ok' if ok else 'failed', '%s: %s' % (what, text))
        elif tag == 'estop':
            for name, ok, text in result:
                self.report('%s: %s' % (name, text or ('ok' if ok else 'failed')), ok=ok)
        elif tag in ('resume', 'start'):
            name, ok, text = result
            if tag == 'resume' and self._estop_pub is not None:
                # release the latched stop after the service call, so the executive resumes once
                # (through the service) and a later subscriber does not see a stale stop
                self._estop_pub.publish(Bool(data=False))
            self.report('%s: %s' % (name, text), ok=ok)
        elif tag == 'points':
            if result:
                self.point_spin.setMaximum(max(0, len(result) - 1))
        self.refresh()

    # --- settings ------------------------------------------------------------------------------------
    def save_settings(self, s):
        s.set('point', self.point_spin.value())
        for joint, step in self.jog_steps.items():
            s.set('step_' + joint, step.value())

    def restore_settings(self, s):
        self.point_spin.setValue(s.get_int('point', 0))
        for joint, step in self.jog_steps.items():
            step.setValue(s.get_float('step_' + joint, step.value()))
