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
"""
import math
import os
import threading

import actionlib
import rospy
from python_qt_binding import loadUi
from python_qt_binding.QtCore import Qt, QTimer, Signal
from python_qt_binding.QtGui import QFont
from python_qt_binding.QtWidgets import QDoubleSpinBox, QLabel, QMessageBox, QPushButton, QSizePolicy
from sensor_msgs.msg import JointState
from smach_msgs.msg import SmachContainerStatus, SmachContainerStructure
from std_msgs.msg import Bool, String
from std_srvs.srv import Trigger
from trajectory_msgs.msg import JointTrajectoryPoint

from harvest_msgs.msg import (EndEffectorAction, EndEffectorGoal, MoveBaseAction, MoveBaseGoal, MoveRobotAction,
                              MoveRobotGoal)
from harvest_description import robot_config
from visualization_pkg import names
from visualization_pkg.dashboard import executive_state as es
from visualization_pkg.dashboard import manual_ops
from visualization_pkg.dashboard.operator_events import OperatorEventPublisher
from visualization_pkg.dashboard.qt_common import Panel, resource_path, robot_yaml_path, ros_now

EE_NAMES = {EndEffectorGoal.SUCTION_ON: 'suction on', EndEffectorGoal.SUCTION_OFF: 'suction off',
            EndEffectorGoal.SHEAR_CUT: 'shear cut'}
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


class OperationPanel(Panel):
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

    @staticmethod
    def _load_limits(path):
        path = path or robot_yaml_path()
        try:
            return manual_ops.limits_from_robot_yaml(robot_config.load(path))
        except (IOError, OSError, KeyError, TypeError, ValueError) as exc:  # RobotConfigError too
            rospy.logwarn('dashboard: no joint limits from %s (%s); jogging is not clamped', path, exc)
            return {}

    def _build_jog_rows(self):
        self.jog_value_labels = {}
        self.jog_steps = {}
        for col, text in enumerate(['Joint', 'Position', 'Step', '', '']):
            if text:
                label = QLabel('<b>%s</b>' % text)
                self.jog_grid.addWidget(label, 0, col)
        for row, joint in enumerate(manual_ops.jog_joint_names() + [manual_ops.WAIST_JOINT], start=1):
            linear = '_lift_' in joint
            self.jog_grid.addWidget(QLabel(joint.replace('_joint', '')), row, 0)
            value = QLabel('-')
            value.setMinimumWidth(70)
            value.setAlignment(Qt.AlignRight | Qt.AlignVCenter)
            self.jog_grid.addWidget(value, row, 1)
            step = QDoubleSpinBox()
            step.setDecimals(0 if not linear else 3)
            if linear:
                step.setRange(0.001, 0.05)
            else:
                step.setRange(1.0, 30.0)
            step.setSingleStep(0.005 if linear else 1.0)
            step.setValue(0.01 if linear else 5.0)
            step.setSuffix(' m' if linear else ' deg')
            self.jog_grid.addWidget(step, row, 2)
            for col, sign in ((3, -1.0), (4, 1.0)):
                button = QPushButton('-' if sign < 0 else '+')
                button.setFixedWidth(34)
                button.setObjectName('jog_%s_%s' % (joint, 'minus' if sign < 0 else 'plus'))
                button.clicked.connect(lambda _c=False, j=joint, s=sign: self.jog_step(j, s))
                self.jog_grid.addWidget(button, row, col)
            self.jog_value_labels[joint] = value
            self.jog_steps[joint] = step

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

    # --- manual motion ------------------------------------------------------------------------------
    def manual_event(self, action, outcome, text):
        """Record a manual command (accepted / refused / ok / failed) as an operator mission event."""
        self.events.publish(action, outcome, text)

    def _refuse(self, action, text):
        self.report(text, ok=False)
        self.manual_event(action, 'refused', text)
        return False

    def _gate(self, what, action='manual'):
        allowed, reason = self.state.manual_allowed(ros_now())
        if not allowed:
            return self._refuse(action, '%s %s' % (what, reason))
        if self.busy:
            return self._refuse(action, '%s refused: %s still running' % (what, self.busy))
        return True

    def jog_step(self, joint, sign):
        step = self.jog_steps[joint].value()
        delta = sign * (step if '_lift_' in joint else math.radians(step))
        return self.jog(joint, delta)

    def jog(self, joint, delta):
        """Move one arm joint by `delta` (m or rad) from its current position. False when refused."""
        what = 'Jog %s %+.3f' % (joint, delta)
        if not self._gate(what, 'jog'):
            return False
        if joint == manual_ops.WAIST_JOINT:
            return self._jog_waist(what, delta)
        try:
            arm_left, goal, note = manual_ops.jog_goal(joint, delta, self.positions, self.limits)
        except ValueError as exc:
            return self._refuse('jog', '%s refused: %s' % (what, exc))
        msg = MoveRobotGoal(target_joint=JointTrajectoryPoint(positions=goal), arm=arm_left)
        self._send('move_robot', msg, '%s -> [%s]%s' % (what, ', '.join('%.3f' % g for g in goal),
                                                         (' (%s)' % note) if note else ''), 'jog')
        return True

    def _jog_waist(self, what, delta):
        try:
            target, note = manual_ops.waist_jog_target(delta, self.positions, self.limits)
        except ValueError as exc:
            return self._refuse('jog', '%s refused: %s' % (what, exc))
        self._send('move_robot', MoveRobotGoal(move_waist=True, waist=target),
                   '%s -> %.3f rad%s' % (what, target, (' (%s)' % note) if note else ''), 'jog')
        return True

    def move_cart(self, point):
        what = 'Move cart to picking point %d' % point
        if not self._gate(what, 'move_cart'):
            return False
        self._send('move_base', MoveBaseGoal(picking_point=int(point)), what, 'move_cart')
        return True

    def end_effector(self, command):
        what = EE_NAMES.get(command, 'end effector %d' % command).capitalize()
        if not self._gate(what, 'end_effector'):
            return False
        if not self.confirm('%s now? The %s hand acts at once.' % (
                what, 'left (cutting)' if command == EndEffectorGoal.SHEAR_CUT else 'right (suction)')):
            return self._refuse('end_effector', '%s cancelled' % what)
        self._send('end_effector', EndEffectorGoal(command=command), what, 'end_effector')
        return True

    def _send(self, client_name, goal, what, action):
        client = self.clients.get(client_name)
        if client is None:
            self._refuse(action, '%s refused: not connected to ROS' % what)
            return
        self.busy = what
        self.report('%s: sent' % what)
        self.manual_event(action, 'accepted', what)
        self.run_in_background('action', self._run_goal, client, goal, what, action)

    def _run_goal(self, client, goal, what, action):
        """Worker thread: send the goal and wait for its end (ROS time), cancelling it on timeout.

        Uses actionlib's ActionClient with a transition callback on the goal handle itself, so a
        fast server's DONE cannot be lost before the handle is stored (SimpleActionClient's race).
        """
        if not client.wait_for_server(rospy.Duration(2.0)):
            return what, False, 'action server not available', action
        done = threading.Event()

        def transition(gh):
            if gh.get_comm_state() == actionlib.CommState.DONE:
                done.set()
        gh = client.send_goal(goal, transition_cb=transition)
        self._goal = gh
        deadline = rospy.get_time() + self.action_timeout
        while not done.wait(0.05):
            if rospy.is_shutdown() or self._closing:
                gh.cancel()
                return what, False, 'cancelled (shutting down)', action
            if rospy.get_time() > deadline:
                gh.cancel()
                return what, False, 'no result within %.0f s (cancelled)' % self.action_timeout, action
        status = gh.get_goal_status()
        text = gh.get_goal_status_text()
        return what, status == actionlib.GoalStatus.SUCCEEDED, '%s%s' % (
            actionlib.GoalStatus.to_string(status).lower(), (': ' + text) if text else ''), action

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
