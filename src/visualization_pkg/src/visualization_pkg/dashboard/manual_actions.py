"""The manual actions of the manual-operation panel (the paper's DashBoard module): the jog grid
(each arm joint and the waist, clamped to robot.yaml's limits), cart moves to a picking point, and
suction and shear with a confirmation. Each passes the manual gate (executive_state.manual_allowed,
one manual goal at a time) and is recorded as an operator mission event: accepted, refused, ok or
failed. The goals' contents come from manual_ops; the goal runs in a worker thread (ROS time,
cancelled on timeout).

ManualActions is a mixin of operation_panel.OperationPanel: it uses the panel's state, positions,
limits, clients, busy, events, confirm, report, run_in_background and the jog_grid of
resource/operation.ui.
"""
import math
import threading

import actionlib
import rospy
from python_qt_binding.QtCore import Qt
from python_qt_binding.QtWidgets import QDoubleSpinBox, QLabel, QPushButton
from trajectory_msgs.msg import JointTrajectoryPoint

from harvest_msgs.msg import EndEffectorGoal, MoveBaseGoal, MoveRobotGoal
from harvest_description import robot_config
from visualization_pkg.dashboard import manual_ops
from visualization_pkg.dashboard.qt_common import robot_yaml_path, ros_now

EE_NAMES = {EndEffectorGoal.SUCTION_ON: 'suction on', EndEffectorGoal.SUCTION_OFF: 'suction off',
            EndEffectorGoal.SHEAR_CUT: 'shear cut'}


class ManualActions(object):
    """Jog grid, cart, end effector: the manual half of OperationPanel (see the module docstring)."""

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
