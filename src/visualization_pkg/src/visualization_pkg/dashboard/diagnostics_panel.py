"""Diagnostics panel (the paper's diagnostic module): diagnostic_aggregator's diagnostics_agg as a tree."""
from diagnostic_msgs.msg import DiagnosticArray
from python_qt_binding.QtCore import Qt, QTimer, Signal
from python_qt_binding.QtGui import QBrush, QColor
from python_qt_binding.QtWidgets import QHBoxLayout, QLabel, QPushButton, QTreeWidget, QTreeWidgetItem, QVBoxLayout

from visualization_pkg.dashboard import diagnostics_tree as dt
from visualization_pkg.dashboard.qt_common import Panel, ros_now

_COLOURS = {dt.OK: QColor('#2e7d32'), dt.WARN: QColor('#ef6c00'), dt.ERROR: QColor('#c62828'),
            dt.STALE: QColor('#6d4c41')}
_BG = {dt.WARN: QColor('#fff3e0'), dt.ERROR: QColor('#ffebee'), dt.STALE: QColor('#efebe9')}


class DiagnosticsPanel(Panel):
    title = 'Diagnostics'
    array_received = Signal(object)

    def __init__(self, topic='diagnostics_agg', stale_after=5.0, parent=None):
        Panel.__init__(self, parent)
        self.topic = topic
        self.stale_after = float(stale_after)
        self.root = None
        self.received = None
        self._items = {}
        self.status_label = QLabel('Waiting for %s (diagnostic_aggregator)' % topic)
        expand = QPushButton('Expand all')
        collapse = QPushButton('Collapse')
        self.tree = QTreeWidget()
        self.tree.setHeaderLabels(['Name', 'Level', 'Message'])
        self.tree.setColumnWidth(0, 260)
        self.tree.setColumnWidth(1, 60)
        expand.clicked.connect(self.tree.expandAll)
        collapse.clicked.connect(lambda: self.tree.collapseAll())
        top = QHBoxLayout()
        top.addWidget(self.status_label, 1)
        top.addWidget(expand)
        top.addWidget(collapse)
        layout = QVBoxLayout(self)
        layout.setContentsMargins(4, 4, 4, 4)
        layout.addLayout(top)
        layout.addWidget(self.tree, 1)
        self.array_received.connect(self.on_array, Qt.QueuedConnection)
        self._timer = QTimer(self)
        self._timer.setInterval(1000)
        self._timer.timeout.connect(self._check_stale)

    def start(self):
        Panel.start(self)
        self.subscribe(self.topic, DiagnosticArray, self.array_received, queue_size=5)
        self._timer.start()

    def shutdown(self):
        self._timer.stop()
        Panel.shutdown(self)

    def on_array(self, msg):
        self.received = ros_now()
        self.show_statuses([(s.name, s.level, s.message, s.hardware_id, [(kv.key, kv.value) for kv in s.values])
                            for s in msg.status])

    def show_statuses(self, statuses):
        self.root = dt.build_tree(statuses)
        seen = set()
        for node in dt.flatten(self.root):
            seen.add(node.path)
            item = self._items.get(node.path)
            if item is None:
                parent_path = node.path.rpartition('/')[0]
                parent = self._items.get(parent_path, self.tree.invisibleRootItem())
                item = QTreeWidgetItem(parent, [node.name, '', ''])
                self._items[node.path] = item
                if parent_path == '':
                    item.setExpanded(True)
            level = node.effective_level()
            item.setText(1, dt.level_name(level))
            item.setText(2, node.message)
            item.setForeground(1, QBrush(_COLOURS.get(level, QColor('#000000'))))
            for c in range(3):
                item.setBackground(c, QBrush(_BG[level]) if level in _BG else QBrush())
            tip = '\n'.join(['%s: %s' % kv for kv in node.values])
            if node.hardware_id:
                tip = 'hardware id: %s\n%s' % (node.hardware_id, tip)
            item.setToolTip(0, tip or node.path)
            item.setToolTip(2, tip or node.message)
        for path in sorted(set(self._items) - seen, key=len, reverse=True):
            item = self._items.pop(path)
            (item.parent() or self.tree.invisibleRootItem()).removeChild(item)
        levels = [n.effective_level() for n in self.root.children.values()]
        worst = dt.OK
        for level in levels:
            worst = dt.worse(worst, level)
        self.status_label.setText('<b>%s</b>: %d groups, overall <span style="color:%s"><b>%s</b></span>' % (
            self.topic, len(levels), _COLOURS.get(worst, QColor('#000')).name(), dt.level_name(worst)))

    def _check_stale(self):
        if self.received is not None and ros_now() - self.received > self.stale_after:
            self.status_label.setText('<span style="color:#6d4c41"><b>%s stale</b>: nothing for %.0f s</span>'
                                      % (self.topic, ros_now() - self.received))

    def level_of(self, path):
        """Effective level of a tree path like '/Sense/Motion' (tests)."""
        node = self.root
        for part in dt.split_name(path):
            if node is None:
                return None
            node = node.children.get(part)
        return node.effective_level() if node is not None else None
