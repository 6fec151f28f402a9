"""Nodes panel (the paper's node module): every running node, whether each expected one is alive,
and Start / Stop / Restart of the selected node (node_control.py; rosnode and roslaunch in node_layer.py).

A QTimer starts one background check at a time: the master's system state, then getPid over
XML-RPC to every registered node (a short socket timeout), the way `rosnode ping` does.
Red rows: dead (registered but not answering, or gone) and missing expected nodes.
Stopping or restarting a node the mission needs (`critical_nodes`) while a mission runs (or while
the mission state is unknown) asks for a confirmation. Every action is published as an operator
mission event (operator_events.py).
"""
import socket
import threading
import time

try:
    import xmlrpc.client as xmlrpclib
except ImportError:  # pragma: no cover - Python 2
    import xmlrpclib

import rosgraph
import rospy
from python_qt_binding.QtCore import Qt, QTimer
from python_qt_binding.QtGui import QBrush
from python_qt_binding.QtWidgets import (QAbstractItemView, QHBoxLayout, QHeaderView, QLabel, QMessageBox,
                                         QPushButton, QTableWidget, QTableWidgetItem, QVBoxLayout)

from visualization_pkg.dashboard import node_control, node_health
from visualization_pkg.dashboard.operator_events import OperatorEventPublisher
from visualization_pkg.dashboard.qt_common import GREEN, LIGHT_AMBER, LIGHT_GREEN, LIGHT_RED, RED, Panel

_COLOURS = {node_health.ALIVE: LIGHT_GREEN, node_health.DEAD: LIGHT_RED, node_health.MISSING: LIGHT_RED}


class _TimeoutTransport(xmlrpclib.Transport):
    def __init__(self, timeout):
        xmlrpclib.Transport.__init__(self)
        self.timeout = timeout

    def make_connection(self, host):
        conn = xmlrpclib.Transport.make_connection(self, host)
        conn.timeout = self.timeout
        return conn


def ping_node(uri, caller_id, timeout=0.5):
    """(ok, detail): getPid of the node's XML-RPC server."""
    try:
        proxy = xmlrpclib.ServerProxy(uri, transport=_TimeoutTransport(timeout))
        code, _msg, pid = proxy.getPid(caller_id)
        return code == 1, 'pid %s' % pid
    except (socket.error, socket.timeout, xmlrpclib.Error, OSError, ValueError) as exc:
        return False, 'no answer: %s' % exc


def check_graph(caller_id, ping_timeout=0.5):
    """(registered node names, {name: (ok, detail)}). Raises when the master is unreachable."""
    master = rosgraph.Master(caller_id)
    pubs, subs, srvs = master.getSystemState()
    names = set()
    for group in (pubs, subs, srvs):
        for _topic, nodes in group:
            names.update(nodes)
    answers = {}
    for name in sorted(names):
        try:
            uri = master.lookupNode(name)
        except rosgraph.MasterError as exc:
            answers[name] = (False, 'unknown to the master: %s' % exc)
            continue
        answers[name] = ping_node(uri, caller_id, ping_timeout)
    return names, answers


class NodesPanel(Panel):
    title = 'Nodes'

    def __init__(self, expected=(), period=2.0, critical=(), respawn_timeout=10.0, mission_running=None,
                 events=None, layer=None, parent=None):
        Panel.__init__(self, parent)
        self.health = node_health.NodeHealth(expected)
        self.period = float(period)
        self._checking = False
        self.checks = 0
        self.critical = set(node_control.norm(n) for n in critical)
        self.respawn_timeout = float(respawn_timeout)
        # () -> True / False / None (unknown); the window passes the operation panel's view
        self.mission_running = mission_running or (lambda: None)
        self._own_events = events is None
        self.events = OperatorEventPublisher() if events is None else events
        self._layer = layer
        self.control = None
        self.acting = ''
        self.last_message = ''
        self.confirm = self.confirm_dialog
        self.summary = QLabel('Nodes: not checked yet')
        refresh = QPushButton('Check now')
        refresh.clicked.connect(self.check)
        cleanup = QPushButton('Forget dead')
        cleanup.setToolTip('Forget dead nodes that are not expected (like rosnode cleanup, in this view only)')
        cleanup.clicked.connect(self.forget_dead)
        self.table = QTableWidget(0, 3)
        self.table.setHorizontalHeaderLabels(['Node', 'State', 'Detail'])
        self.table.verticalHeader().setVisible(False)
        self.table.setEditTriggers(QAbstractItemView.NoEditTriggers)
        self.table.setSelectionBehavior(QAbstractItemView.SelectRows)
        self.table.horizontalHeader().setSectionResizeMode(0, QHeaderView.ResizeToContents)
        self.table.horizontalHeader().setSectionResizeMode(1, QHeaderView.ResizeToContents)
        self.table.horizontalHeader().setStretchLastSection(True)
        top = QHBoxLayout()
        top.addWidget(self.summary, 1)
        top.addWidget(refresh)
        top.addWidget(cleanup)
        actions = QHBoxLayout()
        self.action_buttons = {}
        for action, tip in (('start', 'Start the selected node again (roslaunch)'),
                            ('stop', 'Stop the selected node (rosnode kill)'),
                            ('restart', 'Kill the selected node and start it again (or wait for its respawn)')):
            button = QPushButton(action.capitalize())
            button.setObjectName('node_%s_button' % action)
            button.setToolTip(tip)
            button.clicked.connect(lambda _c=False, a=action: self.act(a, self.selected_node()))
            actions.addWidget(button)
            self.action_buttons[action] = button
        self.action_label = QLabel('')
        self.action_label.setWordWrap(True)
        actions.addWidget(self.action_label, 1)
        layout = QVBoxLayout(self)
        layout.setContentsMargins(4, 4, 4, 4)
        layout.addLayout(top)
        layout.addWidget(self.table, 1)
        layout.addLayout(actions)
        self._timer = QTimer(self)
        self._timer.setInterval(int(self.period * 1000))
        self._timer.timeout.connect(self.check)

    def start(self):
        Panel.start(self)
        self._ensure_control()
        if self._own_events:
            self.events.start()
        self._timer.start()
        self.check()

    def _ensure_control(self):
        if self.control is None:
            if self._layer is None:
                from visualization_pkg.dashboard.node_layer import RosNodeLayer
                self._layer = RosNodeLayer(rospy.get_name() or '/harvest_dashboard')
            self.control = node_control.NodeController(self._layer)
        return self.control

    def shutdown(self):
        self._timer.stop()
        Panel.shutdown(self)
        # nodes this dashboard started stop with it (as with roslaunch); others keep running
        if self.control is not None:
            self.control.shutdown()
            if hasattr(self._layer, 'shutdown'):
                self._layer.shutdown()
        if self._own_events:
            self.events.shutdown()

    # --- start / stop / restart ------------------------------------------------------------------
    def selected_node(self):
        rows = self.table.selectionModel().selectedRows() if self.table.selectionModel() else []
        if not rows:
            return ''
        item = self.table.item(rows[0].row(), 0)
        return item.data(Qt.UserRole) if item is not None else ''

    def confirm_dialog(self, question):
        answer = QMessageBox.question(self, 'Confirm', question, QMessageBox.Yes | QMessageBox.No, QMessageBox.No)
        return answer == QMessageBox.Yes

    def report(self, action, outcome, text):
        self.last_message = text
        ok = outcome in (node_control.OK, 'accepted')
        self.action_label.setText('<span style="color:%s">%s</span>' % ('#2e7d32' if ok else '#c62828', text))
        (rospy.loginfo if ok else rospy.logwarn)('dashboard: %s', text)
        self.events.publish('node_' + action, outcome, text)

    def act(self, action, name):
        """Start, stop or restart `name`; False when refused at once (the result comes later)."""
        if not name:
            self.report(action, node_control.REFUSED, '%s: select a node first' % action.capitalize())
            return False
        name = node_control.norm(name)
        if self.acting:
            self.report(action, node_control.REFUSED, '%s %s refused: %s still running' % (
                action.capitalize(), name, self.acting))
            return False
        running = self.mission_running()
        if action != 'start' and name in self.critical and running is not False:
            question = '%s %s? The mission needs it%s.' % (action.capitalize(), name, '' if running else
                                                           ' (mission state unknown)')
            if not self.confirm(question):
                self.report(action, node_control.REFUSED, '%s %s cancelled by the operator' % (
                    action.capitalize(), name))
                return False
        control = self._ensure_control()
        self.acting = '%s %s' % (action, name)
        self.action_label.setText('%s %s...' % (action.capitalize(), name))
        if action == 'stop':
            self.run_in_background('node_stop', lambda: ('stop', name) + control.stop(name))
        elif action == 'start':
            self.run_in_background('node_start', lambda: ('start', name) + control.start_plan(name))
        else:
            self.run_in_background('node_restart', lambda: ('restart', name) + control.restart(name, self._wait_back))
        return True

    def _wait_back(self, name, old_pid):
        """Worker thread: wait (bounded, wall clock) for a respawned process with a new pid."""
        deadline = time.time() + self.respawn_timeout
        pause = threading.Event()
        while time.time() < deadline and not self._closing:
            pid = self._layer.pid(name)
            if pid is not None and pid != old_pid:
                return True
            pause.wait(0.2)
        return False

    def _node_action_done(self, tag, result):
        self.acting = ''
        if isinstance(result, Exception):
            self.report(tag[5:], node_control.FAILED, '%s failed: %s' % (tag, result))
            return
        if tag == 'node_start':
            action, name, spec, refusal = result
            if spec is None:
                self.report(action, node_control.REFUSED, refusal)
            else:
                self.report(action, *self.control.launch(spec))
        elif tag == 'node_restart':
            action, name, outcome, text, spec = result
            if spec is not None:
                outcome, text2 = self.control.launch(spec)
                text = '%s; %s' % (text, text2)
            self.report(action, outcome, text)
        else:
            action, name, outcome, text = result
            self.report(action, outcome, text)
        self.check()

    def check(self):
        if self._checking:
            return
        self._checking = True
        self.run_in_background('check', check_graph, rospy.get_name() or '/harvest_dashboard')

    def on_task_done(self, tag, result):
        if tag.startswith('node_'):
            self._node_action_done(tag, result)
            return
        self._checking = False
        self.checks += 1
        if isinstance(result, Exception):
            self.summary.setText('<span style="color:#c62828"><b>ROS master unreachable:</b> %s</span>' % result)
            return
        registered, answers = result
        self.show_rows(self.health.update(registered, answers))

    def show_rows(self, rows):
        self.table.setRowCount(len(rows))
        bad = 0
        for r, row in enumerate(rows):
            name = QTableWidgetItem(row.name + ('  (expected)' if row.expected else ''))
            name.setData(Qt.UserRole, row.name)
            state = QTableWidgetItem(row.state.upper())
            detail = QTableWidgetItem(row.detail)
            colour = _COLOURS.get(row.state, LIGHT_AMBER)
            for c, item in enumerate((name, state, detail)):
                item.setBackground(QBrush(colour))
                self.table.setItem(r, c, item)
            state.setForeground(QBrush(GREEN if row.state == node_health.ALIVE else RED))
            bad += row.state != node_health.ALIVE
        alive = len(rows) - bad
        self.summary.setText('%d alive%s' % (alive, (', <span style="color:#c62828"><b>%d dead or missing</b></span>'
                                                      % bad) if bad else ''))

    def forget_dead(self):
        for name, row in list(self.health.rows.items()):
            if row.state == node_health.DEAD and not row.expected:
                self.health.forget(name)
        self.show_rows([self.health.rows[n] for n in sorted(self.health.rows)])

    # --- for tests -------------------------------------------------------------------------------
    def node_state(self, name):
        return self.health.state(name)

    def row_colour(self, name):
        """Background colour name of the node's row in the table, or None when not shown."""
        for r in range(self.table.rowCount()):
            item = self.table.item(r, 0)
            if item is not None and item.data(Qt.UserRole) == name:
                return item.background().color().name()
        return None
