"""State-machine panel: the executive's live SMACH graph (replaces smach_viewer on Debian).

Reads the smach_viewer topics <server>/smach/container_structure and container_status, draws
a layered layout (smach_model.layout) with QGraphicsScene, highlights the active states and
shows the userdata of the container that owns the selected state.
"""
import math

from python_qt_binding.QtCore import QPointF, QRectF, Qt, QTimer, Signal
from python_qt_binding.QtGui import QBrush, QColor, QFont, QFontMetricsF, QPainter, QPainterPath, QPen, QPolygonF
from python_qt_binding.QtWidgets import (QCheckBox, QComboBox, QGraphicsPathItem, QGraphicsPolygonItem,
                                         QGraphicsScene, QGraphicsSimpleTextItem, QGraphicsView, QHBoxLayout,
                                         QLabel, QPushButton, QSpinBox, QSplitter, QTreeWidget, QTreeWidgetItem,
                                         QVBoxLayout, QWidget)
from smach_msgs.msg import SmachContainerStatus, SmachContainerStructure

from visualization_pkg import names
from visualization_pkg.dashboard import smach_model, userdata
from visualization_pkg.dashboard.qt_common import Panel

FOLLOW = '(follow active state)'
ALARM_STATES = ('DO_STOP', 'DO_ERROR')

_FILL = {'state': QColor('#f7f7f7'), 'collapsed': QColor('#eeeeee'), 'container': QColor('#fcfcfc'),
         'outcome': QColor('#eceff1')}
_ACTIVE_FILL = {'state': QColor('#43a047'), 'collapsed': QColor('#66bb6a'), 'container': QColor('#eef7ee'),
                'outcome': QColor('#43a047')}
_BORDER = QColor('#9e9e9e')
_ACTIVE_BORDER = QColor('#2e7d32')
_ALARM_FILL = QColor('#e53935')
_SELECT = QColor('#1e88e5')
_EDGE = QColor('#78909c')


class GraphView(QGraphicsView):
    """Zoom with the wheel, drag to pan, click a state to select it."""
    clicked = Signal(str)

    def __init__(self, scene, parent=None):
        QGraphicsView.__init__(self, scene, parent)
        self.setRenderHint(QPainter.Antialiasing)
        self.setRenderHint(QPainter.TextAntialiasing)
        self.setDragMode(QGraphicsView.ScrollHandDrag)
        self.setTransformationAnchor(QGraphicsView.AnchorUnderMouse)
        self.setBackgroundBrush(QBrush(QColor('#ffffff')))

    def wheelEvent(self, event):
        factor = 1.15 if event.angleDelta().y() > 0 else 1 / 1.15
        self.scale(factor, factor)

    def mousePressEvent(self, event):
        item = self.itemAt(event.pos())
        while item is not None and item.data(0) is None:
            item = item.parentItem()
        if item is not None and item.data(0):
            self.clicked.emit(str(item.data(0)))
        QGraphicsView.mousePressEvent(self, event)


class StateMachinePanel(Panel):
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

    def measure(self, text):
        width = getattr(self._metrics, 'horizontalAdvance', self._metrics.width)
        return width(text), self._metrics.height()

    def _draw(self):
        self.scene.clear()
        self._items = {}
        block = smach_model.layout(self.model, self._root, self.depth_spin.value(), self.measure) \
            if self._root else None
        if block is None:
            self.scene.setSceneRect(QRectF(0, 0, 10, 10))
            return
        frame = self.scene.addRect(QRectF(-6, -28, block.w + 12, block.h + 34), QPen(QColor('#cfd8dc')),
                                   QBrush(QColor('#fbfcfd')))
        frame.setZValue(-10)
        title = self.scene.addSimpleText(self._root, self._bold)
        title.setBrush(QBrush(QColor('#546e7a')))
        title.setPos(0, -24)
        depth = {}
        for node in block.walk():
            depth[node.key] = node.key.count('/')
            self._add_node(node, depth[node.key])
        self._add_edges(block)
        self.scene.setSceneRect(self.scene.itemsBoundingRect().adjusted(-10, -10, 10, 10))
        if self.fit_check.isChecked():
            self.fit()

    def _add_node(self, node, z):
        path = QPainterPath()
        radius = node.h / 2.0 if node.kind == 'outcome' else 6.0
        path.addRoundedRect(QRectF(node.x, node.y, node.w, node.h), radius, radius)
        if node.kind == 'collapsed':
            path.addRoundedRect(QRectF(node.x + 3, node.y + 3, node.w - 6, node.h - 6), 4, 4)
        shape = QGraphicsPathItem(path)
        shape.setData(0, node.key)
        shape.setZValue(z)
        shape.setToolTip(node.key if node.kind != 'outcome' else 'outcome %s of %s'
                         % (node.label, node.key.rpartition('/:')[0]))
        self.scene.addItem(shape)
        text = QGraphicsSimpleTextItem(node.label, shape)
        text.setFont(self._bold if node.kind != 'outcome' else self._font)
        tw, th = self.measure(node.label)
        if node.kind == 'container':
            text.setPos(node.x + 8, node.y + 4)
        else:
            text.setPos(node.x + (node.w - tw) / 2.0, node.y + (node.h - th) / 2.0)
        self._items[node.key] = (shape, text, node)

    def _add_edges(self, block):
        pen = QPen(_EDGE, 1.2)
        grouped = {}
        for a, b, outcome, back in block.all_edges():
            grouped.setdefault((a, b), [[], back])[0].append(outcome)
        outgoing, incoming = {}, {}
        for (a, b) in grouped:
            outgoing.setdefault(a, []).append(b)
            incoming.setdefault(b, []).append(a)
        node = dict((k, v[2]) for k, v in self._items.items())

        def slot(lst, key, other, n):
            keys = sorted(lst, key=lambda k: node[k].x if k in node else 0)
            i = keys.index(other)
            return n.x + n.w * (i + 1.0) / (len(keys) + 1.0)

        for (a, b), (labels, back) in sorted(grouped.items()):
            if a not in node or b not in node:
                continue
            na, nb = node[a], node[b]
            path = QPainterPath()
            if not back and nb.y > na.y + na.h - 1:
                p0 = QPointF(slot(outgoing[a], a, b, na), na.y + na.h)
                p1 = QPointF(slot(incoming[b], b, a, nb), nb.y)
                dy = max(12.0, (p1.y() - p0.y()) / 2.0)
                path.moveTo(p0)
                path.cubicTo(QPointF(p0.x(), p0.y() + dy), QPointF(p1.x(), p1.y() - dy), p1)
                mid = path.pointAtPercent(0.5)
                tip, direction = p1, QPointF(0, 1)
            else:
                # back edge: out of the right side, around, into the target's right side
                p0 = QPointF(na.x + na.w, na.y + na.h / 2.0)
                p1 = QPointF(nb.x + nb.w, nb.y + nb.h / 2.0)
                bulge = max(p0.x(), p1.x()) + 28.0
                path.moveTo(p0)
                path.cubicTo(QPointF(bulge, p0.y()), QPointF(bulge, p1.y()), p1)
                mid = path.pointAtPercent(0.5)
                tip, direction = p1, QPointF(-1, 0)
            item = self.scene.addPath(path, pen)
            item.setZValue(50)
            self._arrow(tip, direction)
            label = self.scene.addSimpleText(', '.join(labels), self._small)
            label.setBrush(QBrush(QColor('#607d8b')))
            r = label.boundingRect()
            label.setPos(mid.x() + 3, mid.y() - r.height() / 2.0)
            label.setZValue(51)

    def _arrow(self, tip, direction):
        size = 6.0
        angle = math.atan2(direction.y(), direction.x())
        left = QPointF(tip.x() - size * math.cos(angle - 0.45), tip.y() - size * math.sin(angle - 0.45))
        right = QPointF(tip.x() - size * math.cos(angle + 0.45), tip.y() - size * math.sin(angle + 0.45))
        head = QGraphicsPolygonItem(QPolygonF([tip, left, right]))
        head.setBrush(QBrush(_EDGE))
        head.setPen(QPen(_EDGE))
        head.setZValue(50)
        self.scene.addItem(head)

    def _restyle(self):
        for key, (shape, text, node) in self._items.items():
            active = self._is_active(key, node)
            alarm = active and node.label in ALARM_STATES
            if active:
                fill = _ALARM_FILL if alarm else _ACTIVE_FILL[node.kind]
                pen = QPen(_ACTIVE_BORDER if not alarm else QColor('#b71c1c'), 2.2)
            else:
                fill = _FILL[node.kind]
                pen = QPen(_BORDER, 1.0)
            if key == self._selected:
                pen = QPen(_SELECT, 3.0)
            shape.setBrush(QBrush(fill))
            shape.setPen(pen)
            light_text = active and node.kind in ('state', 'collapsed', 'outcome')
            text.setBrush(QBrush(QColor('#ffffff') if light_text else QColor('#263238')))
            shape.setData(1, bool(active))

    def _is_active(self, key, node):
        if node.kind == 'outcome':
            container = key.rpartition('/:')[0]
            c = self.model.containers.get(container)
            # a finished container reports its outcome as its only 'active' entry in some servers
            return bool(c) and node.label in c.active_states and container in (self._active | {self._root})
        return key in self._active

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
