"""Drawing of the state-machine panel's SMACH graph on a QGraphicsScene: the view (zoom, pan,
click to select), a shape per state, collapsed container, container and outcome of the layered
layout (smach_model.layout), edges with their outcome labels (back edges around the right side)
and arrow heads, and their style: active states green, DO_STOP/DO_ERROR red, the selection blue.

GraphDrawing is a mixin of smach_panel.StateMachinePanel: it uses the panel's model, scene,
depth_spin, fit_check, fonts and metrics, _root, _items, _active, _selected and fit().
"""
import math

from python_qt_binding.QtCore import QPointF, QRectF, Signal
from python_qt_binding.QtGui import QBrush, QColor, QPainter, QPainterPath, QPen, QPolygonF
from python_qt_binding.QtWidgets import (QGraphicsPathItem, QGraphicsPolygonItem, QGraphicsSimpleTextItem,
                                         QGraphicsView)

from visualization_pkg.dashboard import smach_model

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


class GraphDrawing(object):
    """Scene items of the SMACH graph and their style (see the module docstring)."""

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
