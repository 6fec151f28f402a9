"""State-machine panel: the executive's live SMACH graph (replaces smach_viewer on Debian).

Reads the smach_viewer topics <server>/smach/container_structure and container_status, draws
a layered layout (smach_model.layout) with QGraphicsScene, highlights the active states and
shows the userdata of the container that owns the selected state.

The graph's drawing (view, shapes, edges, styles) is in smach_graph.py.
"""
from python_qt_binding.QtCore import Qt, QTimer, Signal
from python_qt_binding.QtGui import QFont, QFontMetricsF
from python_qt_binding.QtWidgets import (QCheckBox, QComboBox, QGraphicsScene, QHBoxLayout, QLabel, QPushButton,
                                         QSpinBox, QSplitter, QTreeWidget, QTreeWidgetItem, QVBoxLayout, QWidget)
from smach_msgs.msg import SmachContainerStatus, SmachContainerStructure

from visualization_pkg import names
from visualization_pkg.dashboard import smach_model, userdata
from visualization_pkg.dashboard.qt_common import Panel
from visualization_pkg.dashboard.smach_graph import ALARM_STATES, GraphDrawing, GraphView  # noqa: F401

FOLLOW = '(follow active state)'


class StateMachinePanel(GraphDrawing, Panel):
    title = 'State machine'
    structure_received = Signal(object)
    status_received = Signal(object)

    def __init__(self, server=names.INTROSPECTION_SERVER, parent=None):
        Panel.__init__(self, parent)
        self.server = server.rstrip('/')
        self.model = smach_model.SmachModel()
        self._items = {}            # key -> (shape item, text item, node)
        self._active = set()
        self._selected = ''
        self._root = None
        self._shown_userdata = None
        self._font = QFont()
        self._font.setPointSizeF(9.0)
        self._bold = QFont(self._font)
        self._bold.setBold(True)
        self._small = QFont(self._font)
        self._small.setPointSizeF(7.5)
        self._metrics = QFontMetricsF(self._bold)

        self.root_combo = QComboBox()
        self.root_combo.addItem(FOLLOW)
        self.root_combo.setToolTip('Container drawn at the top of the view')
        self.root_combo.setSizeAdjustPolicy(QComboBox.AdjustToMinimumContentsLengthWithIcon)
        self.root_combo.setMinimumContentsLength(14)
        self.depth_spin = QSpinBox()
        self.depth_spin.setRange(1, 8)
        self.depth_spin.setValue(2)
        self.depth_spin.setPrefix('depth ')
        self.depth_spin.setToolTip('Levels of nested containers drawn expanded')
        self.fit_check = QCheckBox('fit')
        self.fit_check.setChecked(True)
        self.fit_check.setToolTip('Keep the whole graph in view')
        fit_button = QPushButton('Fit')
        fit_button.clicked.connect(self.fit)
        self.active_label = QLabel('Active: (no introspection yet)')
        self.active_label.setTextInteractionFlags(Qt.TextSelectableByMouse)
        self.active_label.setWordWrap(True)

        self.scene = QGraphicsScene(self)
        self.view = GraphView(self.scene)
        self.view.clicked.connect(self.select)
        self.ud_label = QLabel('Userdata: click a state')
        self.ud_label.setWordWrap(True)
        self.ud_tree = QTreeWidget()
        self.ud_tree.setHeaderLabels(['Key', 'Value'])
        self.ud_tree.setColumnWidth(0, 130)
        ud_box = QWidget()
        ud_layout = QVBoxLayout(ud_box)
        ud_layout.setContentsMargins(0, 0, 0, 0)
        ud_layout.addWidget(self.ud_label)
        ud_layout.addWidget(self.ud_tree)
        self.splitter = QSplitter(Qt.Horizontal)
        self.splitter.addWidget(self.view)
        self.splitter.addWidget(ud_box)
        self.splitter.setStretchFactor(0, 4)
        self.splitter.setStretchFactor(1, 1)
        self.splitter.setSizes([700, 220])

        top = QHBoxLayout()
        top.addWidget(QLabel('View'))
        top.addWidget(self.root_combo, 1)
        top.addWidget(self.depth_spin)
        top.addWidget(self.fit_check)
        top.addWidget(fit_button)
        layout = QVBoxLayout(self)
        layout.setContentsMargins(4, 4, 4, 4)
        layout.addLayout(top)
        layout.addWidget(self.active_label)
        layout.addWidget(self.splitter, 1)

        self._relayout_pending = False
        self._timer = QTimer(self)
        self._timer.setSingleShot(True)
        self._timer.setInterval(40)
        self._timer.timeout.connect(self._refresh)
        self.root_combo.currentIndexChanged.connect(lambda _i: self._schedule(True))
        self.depth_spin.valueChanged.connect(lambda _v: self._schedule(True))
        self.structure_received.connect(self.on_structure, Qt.QueuedConnection)
        self.status_received.connect(self.on_status, Qt.QueuedConnection)

    # --- ROS --------------------------------------------------------------------------------------
    def start(self):
        Panel.start(self)
        self.subscribe(self.server + '/' + names.SMACH_STRUCTURE, SmachContainerStructure,
                       self.structure_received, queue_size=50)
        self.subscribe(self.server + '/' + names.SMACH_STATUS, SmachContainerStatus,
                       self.status_received, queue_size=50)

    def on_structure(self, msg):
        changed = self.model.update_structure(msg.path, msg.children, msg.internal_outcomes, msg.outcomes_from,
                                              msg.outcomes_to, msg.container_outcomes)
        if changed:
            self._update_combo()
            self._schedule(True)

    def on_status(self, msg):
        before = self.model.containers.get(msg.path)
        old_initial = list(before.initial_states) if before is not None else None
        changed = self.model.update_status(msg.path, msg.initial_states, msg.active_states, msg.local_data,
                                           msg.info)
        if changed:
            relayout = old_initial != list(msg.initial_states) or self._follow()
            self._schedule(relayout)
        if self.model.owner_of(self._selected) == msg.path if self._selected else changed:
            self._show_userdata()

    # --- drawing ------------------------------------------------------------------------------------
    def _follow(self):
        return self.root_combo.currentText() == FOLLOW

    def _update_combo(self):
        current = self.root_combo.currentText()
        paths = self.model.container_paths()
        existing = [self.root_combo.itemText(i) for i in range(1, self.root_combo.count())]
        if existing == paths:
            return
        self.root_combo.blockSignals(True)
        self.root_combo.clear()
        self.root_combo.addItem(FOLLOW)
        self.root_combo.addItems(paths)
        index = self.root_combo.findText(current)
        self.root_combo.setCurrentIndex(max(0, index))
        self.root_combo.blockSignals(False)

    def _schedule(self, relayout):
        self._relayout_pending = self._relayout_pending or relayout
        if not self._timer.isActive():
            self._timer.start()

    def _refresh(self):
        self._active = self.model.active_paths()
        if self._follow():
            root = self.model.follow_root(self.depth_spin.value())
        else:
            root = self.root_combo.currentText()
        if self._relayout_pending or root != self._root:
            self._relayout_pending = False
            self._root = root
            self._draw()
        self._restyle()
        leaves = self.model.active_leaves()
        if leaves:
            text = ', '.join('<b>%s</b> <span style="color:#757575">(%s)</span>'
                             % (p.rpartition('/')[2], p) for p in leaves)
        elif self.model.containers:
            text = 'no active state (executive idle)'
        else:
            text = '(no introspection yet)'
        self.active_label.setText('Active: ' + text)
        if not self._selected:
            self._show_userdata()

    def fit(self):
        rect = self.scene.itemsBoundingRect()
        if rect.isValid():
            self.view.fitInView(rect.adjusted(-10, -10, 10, 10), Qt.KeepAspectRatio)

    def resizeEvent(self, event):
        Panel.resizeEvent(self, event)
        if self.fit_check.isChecked():
            self.fit()

    # --- selection and userdata --------------------------------------------------------------------
    def select(self, key):
        self._selected = key
        self._shown_userdata = None
        self._restyle()
        self._show_userdata()

    def _show_userdata(self):
        """Userdata of the selected state's container; with nothing selected, of the deepest active one."""
        key = self._selected
        if '/:' in key:
            key = key.rpartition('/:')[0]
        auto = not key
        owner = self.model.owner_of(key) if key else self.model.deepest_active_container()
        if owner is None or owner not in self.model.containers:
            self.ud_label.setText('Userdata: click a state')
            self.ud_tree.clear()
            self._shown_userdata = None
            return
        c = self.model.containers[owner]
        if self._shown_userdata == (owner, c.local_data, auto):
            return
        self._shown_userdata = (owner, c.local_data, auto)
        data, error = userdata.decode(c.local_data)
        if auto:
            note = ' <span style="color:#757575">(active; click a state)</span>'
        elif owner != key:
            note = ' (selected %s)' % key.rpartition('/')[2]
        else:
            note = ''
        self.ud_label.setText('Userdata of <b>%s</b>%s%s' % (
            owner.rpartition('/')[2], note, ('<br><span style="color:#c62828">%s</span>' % error) if error else ''))
        self.ud_label.setToolTip(owner)
        self.ud_tree.clear()
        _summary, kids = userdata.describe(data)
        self._fill(self.ud_tree.invisibleRootItem(), kids)
        self.ud_tree.expandToDepth(0)

    def _fill(self, parent, kids):
        for key, (summary, sub) in kids:
            item = QTreeWidgetItem(parent, [key, summary])
            item.setToolTip(1, summary)
            self._fill(item, sub)

    # --- for tests and the window ----------------------------------------------------------------
    def highlighted_paths(self):
        """Keys of the drawn states shown as active (outcome nodes excluded)."""
        return set(k for k, (shape, _t, node) in self._items.items()
                   if shape.data(1) and node.kind != 'outcome')

    def drawn_paths(self):
        return set(self._items)

    def view_root(self):
        return self._root

    def flush(self):
        """Apply pending updates now (tests)."""
        if self._timer.isActive():
            self._timer.stop()
            self._refresh()

    # --- settings ----------------------------------------------------------------------------------
    def save_settings(self, s):
        s.set('root', self.root_combo.currentText())
        s.set('depth', self.depth_spin.value())
        s.set('fit', self.fit_check.isChecked())
        s.set('splitter', self.splitter.saveState())

    def restore_settings(self, s):
        self.depth_spin.setValue(s.get_int('depth', self.depth_spin.value()))
        self.fit_check.setChecked(s.get_bool('fit', True))
        root = s.get_str('root', FOLLOW)
        if self.root_combo.findText(root) < 0:
            self.root_combo.addItem(root)
        self.root_combo.setCurrentIndex(self.root_combo.findText(root))
        state = s.get_bytes('splitter')
        if state is not None:
            self.splitter.restoreState(state)
