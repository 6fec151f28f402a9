"""Nodes panel (the paper's node module): every running node, and whether each expected one is alive.

A QTimer starts one background check at a time: the master's system state, then getPid over
XML-RPC to every registered node (a short socket timeout), the way `rosnode ping` does.
Red rows: dead (registered but not answering, or gone) and missing expected nodes.
"""
import socket

try:
    import xmlrpc.client as xmlrpclib
except ImportError:  # pragma: no cover - Python 2
    import xmlrpclib

import rosgraph
import rospy
from python_qt_binding.QtCore import Qt, QTimer
from python_qt_binding.QtGui import QBrush
from python_qt_binding.QtWidgets import (QAbstractItemView, QHBoxLayout, QHeaderView, QLabel, QPushButton,
                                         QTableWidget, QTableWidgetItem, QVBoxLayout)

from visualization_pkg.dashboard import node_health
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

    def __init__(self, expected=(), period=2.0, parent=None):
        Panel.__init__(self, parent)
        self.health = node_health.NodeHealth(expected)
        self.period = float(period)
        self._checking = False
        self.checks = 0
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
        layout = QVBoxLayout(self)
        layout.setContentsMargins(4, 4, 4, 4)
        layout.addLayout(top)
        layout.addWidget(self.table, 1)
        self._timer = QTimer(self)
        self._timer.setInterval(int(self.period * 1000))
        self._timer.timeout.connect(self.check)

    def start(self):
        Panel.start(self)
        self._timer.start()
        self.check()

    def shutdown(self):
        self._timer.stop()
        Panel.shutdown(self)

    def check(self):
        if self._checking:
            return
        self._checking = True
        self.run_in_background('check', check_graph, rospy.get_name() or '/harvest_dashboard')

    def on_task_done(self, tag, result):
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
