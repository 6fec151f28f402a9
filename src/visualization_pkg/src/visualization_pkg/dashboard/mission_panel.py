"""Mission panel: per-fruit progress and stage times of the current run, and a cycle-time plot.

Sources (control_pkg task_planner): mission/pick_records (harvest_msgs/PickRecord),
mission/events (harvest_msgs/MissionEvent), mission/summary (std_msgs/String JSON, latched).
"""
import math

from python_qt_binding.QtCore import QPointF, QRectF, Qt, Signal
from python_qt_binding.QtGui import QBrush, QColor, QFont, QPainter, QPen
from python_qt_binding.QtWidgets import (QAbstractItemView, QHeaderView, QLabel, QSplitter, QTableWidget,
                                         QTableWidgetItem, QVBoxLayout, QWidget)
from std_msgs.msg import String

from harvest_msgs.msg import MissionEvent, PickRecord
from visualization_pkg import names
from visualization_pkg.dashboard import mission_stats, operator_events
from visualization_pkg.dashboard.qt_common import Panel

#: colour of each outcome, by its name (mission_stats.OUTCOMES)
OUTCOME_COLOURS = dict((mission_stats.outcome_name(code), QColor(colour)) for code, colour in (
    (PickRecord.OUTCOME_PICKED, '#2e7d32'), (PickRecord.OUTCOME_UNREACHABLE, '#ef6c00'),
    (PickRecord.OUTCOME_LOST, '#8e24aa'), (PickRecord.OUTCOME_FAILED, '#c62828'),
    (PickRecord.OUTCOME_DROPPED, '#6d4c41')))
STAGE_PALETTE = ['#42a5f5', '#66bb6a', '#ffa726', '#ab47bc', '#26c6da', '#ef5350', '#8d6e63', '#d4e157',
                 '#5c6bc0', '#ec407a', '#78909c', '#26a69a']


def nice_step(span, ticks=5):
    """A 1-2-5 tick step so that `span` has about `ticks` ticks."""
    if span <= 0:
        return 1.0
    raw = span / float(ticks)
    mag = 10 ** math.floor(math.log10(raw))
    for m in (1, 2, 5, 10):
        if m * mag >= raw:
            return m * mag
    return 10 * mag


class CycleTimePlot(QWidget):
    """Stacked bars of stage times per fruit, outlined and marked by outcome, with the mean pick cycle."""

    def __init__(self, stats, parent=None):
        QWidget.__init__(self, parent)
        self.stats = stats
        self.setMinimumHeight(160)

    def stage_colour(self, name):
        stages = self.stats.stage_names
        index = stages.index(name) if name in stages else len(stages)
        return QColor(STAGE_PALETTE[index % len(STAGE_PALETTE)])

    def _legend_rows(self, p):
        rows, x = (1 if self.stats.stage_names else 0), 6.0
        for name in self.stats.stage_names:
            w = p.fontMetrics().boundingRect(name.replace('DO_', '').lower()).width() + 20
            if x + w > self.width() - 4:
                rows, x = rows + 1, 6.0
            x += w
        return rows

    def paintEvent(self, _event):
        p = QPainter(self)
        p.setRenderHint(QPainter.Antialiasing)
        p.fillRect(self.rect(), QColor('#ffffff'))
        font = QFont()
        font.setPointSizeF(7.5)
        p.setFont(font)
        fruits = self.stats.fruits
        left, right, bottom = 38.0, 10.0, 30.0
        top = 22.0 + 13.0 * self._legend_rows(p) + 6.0
        area = QRectF(left, top, max(10.0, self.width() - left - right), max(10.0, self.height() - top - bottom))
        p.setPen(QColor('#37474f'))
        bold = QFont(font)
        bold.setBold(True)
        p.setFont(bold)
        p.drawText(QRectF(4, 2, self.width(), 16), Qt.AlignLeft | Qt.AlignVCenter, 'Cycle time per fruit [s]')
        p.setFont(font)
        if not fruits:
            p.setPen(QColor('#90a4ae'))
            p.drawText(area, Qt.AlignCenter, 'no fruit yet')
            p.end()
            return
        top_value = max(f.cycle_time for f in fruits) * 1.1 or 1.0
        step = nice_step(top_value)
        top_value = math.ceil(top_value / step) * step

        def y_of(v):
            return area.bottom() - area.height() * v / top_value
        # grid and axis labels
        v = 0.0
        while v <= top_value + 1e-9:
            y = y_of(v)
            p.setPen(QPen(QColor('#eceff1'), 1))
            p.drawLine(QPointF(area.left(), y), QPointF(area.right(), y))
            p.setPen(QColor('#607d8b'))
            p.drawText(QRectF(0, y - 7, left - 4, 14), Qt.AlignRight | Qt.AlignVCenter, '%g' % v)
            v += step
        n = len(fruits)
        slot = area.width() / n
        bar_w = max(3.0, min(34.0, slot * 0.7))
        for i, fruit in enumerate(fruits):
            x = area.left() + slot * (i + 0.5) - bar_w / 2.0
            acc = 0.0
            for name, secs in fruit.stage_totals():
                y0, y1 = y_of(acc), y_of(acc + secs)
                p.fillRect(QRectF(x, y1, bar_w, y0 - y1), self.stage_colour(name))
                acc += secs
            rest = fruit.cycle_time - acc
            if rest > 1e-6:     # time not spent in a recorded state
                y0, y1 = y_of(acc), y_of(fruit.cycle_time)
                p.fillRect(QRectF(x, y1, bar_w, y0 - y1), QColor('#cfd8dc'))
            colour = OUTCOME_COLOURS.get(fruit.outcome, QColor('#000000'))
            p.setPen(QPen(colour, 1.6))
            p.setBrush(Qt.NoBrush)
            p.drawRect(QRectF(x, y_of(fruit.cycle_time), bar_w, area.bottom() - y_of(fruit.cycle_time)))
            p.setPen(colour)
            if slot > 26 or i % max(1, int(26 / slot)) == 0:
                p.drawText(QRectF(x - 12, area.bottom() + 2, bar_w + 24, 12), Qt.AlignCenter,
                           '%d/%d' % (fruit.picking_point, fruit.target_id))
            p.setBrush(QBrush(colour))
            p.drawEllipse(QPointF(x + bar_w / 2.0, area.bottom() + 20), 3.0, 3.0)
        mean = self.stats.mean_cycle()
        if mean is not None:
            y = y_of(mean)
            p.setPen(QPen(QColor('#1b5e20'), 1.2, Qt.DashLine))
            p.drawLine(QPointF(area.left(), y), QPointF(area.right(), y))
            label = 'mean pick %.1f s' % mean
            lw = p.fontMetrics().boundingRect(label).width() + 6
            p.fillRect(QRectF(area.left() + 2, y - 14, lw, 12), QColor(255, 255, 255, 200))
            p.drawText(QRectF(area.left() + 4, y - 14, lw, 12), Qt.AlignLeft, label)
        # legend: stage colours, wrapped under the title
        x, y = 6.0, 20.0
        for name in self.stats.stage_names:
            label = name.replace('DO_', '').lower()
            w = p.fontMetrics().boundingRect(label).width() + 20
            if x + w > self.width() - 4:
                x, y = 6.0, y + 13.0
            p.fillRect(QRectF(x, y + 2, 9, 9), self.stage_colour(name))
            p.setPen(QColor('#455a64'))
            p.drawText(QRectF(x + 11, y - 1, w, 14), Qt.AlignLeft | Qt.AlignVCenter, label)
            x += w
        p.setPen(QPen(QColor('#90a4ae'), 1))
        p.drawLine(QPointF(area.left(), area.bottom()), QPointF(area.right(), area.bottom()))
        p.end()


class MissionPanel(Panel):
    title = 'Mission'
    record_received = Signal(object)
    event_received = Signal(object)
    summary_received = Signal(object)

    def __init__(self, parent=None):
        Panel.__init__(self, parent)
        self.stats = mission_stats.MissionStats()
        self.header = QLabel('No mission yet')
        self.header.setWordWrap(True)
        self.state_label = QLabel('')
        self.state_label.setWordWrap(True)
        self.table = QTableWidget(0, 5)
        self.table.setHorizontalHeaderLabels(['Point/id', 'Outcome', 'Cycle [s]', 'Stage times [s]', 'Reason'])
        self.table.verticalHeader().setVisible(False)
        self.table.verticalHeader().setDefaultSectionSize(20)
        self.table.setEditTriggers(QAbstractItemView.NoEditTriggers)
        self.table.setSelectionBehavior(QAbstractItemView.SelectRows)
        h = self.table.horizontalHeader()
        h.setSectionResizeMode(QHeaderView.Interactive)
        for col in range(3):
            h.setSectionResizeMode(col, QHeaderView.ResizeToContents)
        h.resizeSection(3, 330)
        h.setStretchLastSection(True)
        self.plot = CycleTimePlot(self.stats)
        self.splitter = QSplitter(Qt.Vertical)
        self.splitter.addWidget(self.table)
        self.splitter.addWidget(self.plot)
        self.splitter.setStretchFactor(0, 1)
        self.splitter.setStretchFactor(1, 1)
        layout = QVBoxLayout(self)
        layout.setContentsMargins(4, 4, 4, 4)
        layout.addWidget(self.header)
        layout.addWidget(self.state_label)
        layout.addWidget(self.splitter, 1)
        self.record_received.connect(self.on_record, Qt.QueuedConnection)
        self.event_received.connect(self.on_event, Qt.QueuedConnection)
        self.summary_received.connect(self.on_summary, Qt.QueuedConnection)

    def start(self):
        Panel.start(self)
        self.subscribe(names.PICK_RECORDS, PickRecord, self.record_received, queue_size=100)
        self.subscribe(names.EVENTS, MissionEvent, self.event_received, queue_size=100)
        self.subscribe(names.SUMMARY, String, self.summary_received)

    def on_record(self, msg):
        p = msg.pick_point.point
        before = self.stats.mission_id
        self.stats.add_record(msg.mission_id, msg.picking_point, msg.target_id, msg.outcome, msg.reason,
                              msg.state_names, msg.state_durations, msg.cycle_time, (p.x, p.y, p.z))
        if before != self.stats.mission_id:
            self.table.setRowCount(0)
        self._add_row(self.stats.fruits[-1])
        self._update_header()
        self.plot.update()

    def _add_row(self, fruit):
        r = self.table.rowCount()
        self.table.insertRow(r)
        stages = ', '.join('%s %.1f' % (name.replace('DO_', '').lower(), secs) for name, secs in fruit.stage_totals())
        cells = ['%d/%d' % (fruit.picking_point, fruit.target_id), fruit.outcome, '%.1f' % fruit.cycle_time, stages,
                 fruit.reason]
        for c, text in enumerate(cells):
            item = QTableWidgetItem(text)
            item.setToolTip(text)
            if c == 1:
                item.setForeground(QBrush(OUTCOME_COLOURS.get(fruit.outcome, QColor('#000'))))
            self.table.setItem(r, c, item)
        self.table.scrollToBottom()

    def on_event(self, msg):
        if msg.kind == operator_events.KIND:
            # the dashboard's own record of an operator action: shown, but it never switches the
            # mission (its id may be the operator-<date> fallback)
            self.state_label.setText('<span style="color:#6a1b9a">operator: <b>%s</b> %s</span>'
                                     % (msg.state, msg.detail))
            return
        before = self.stats.mission_id
        self.stats.add_event(msg.mission_id, msg.kind, msg.state, msg.detail, msg.stamp.to_sec())
        if before != self.stats.mission_id:
            self.table.setRowCount(0)
            self.plot.update()
        if msg.kind != 'summary':
            colour = {'fault': '#c62828', 'estop': '#c62828', 'resume': '#2e7d32'}.get(msg.kind, '#455a64')
            self.state_label.setText('<span style="color:%s">last event: <b>%s</b> %s</span>'
                                     % (colour, msg.state or msg.kind, msg.detail))
        self._update_header()

    def on_summary(self, msg):
        self.stats.set_summary(msg.data)
        self._update_header()

    def _update_header(self):
        text = '<b>%s</b>: %s' % (self.stats.mission_id or 'mission', self.stats.progress_text())
        s = self.stats.summary
        if s:
            text += '<br><b>finished</b> (%s): %s' % (s.get('outcome', '?'), ', '.join(
                '%s %s' % (k, s[k]) for k in mission_stats.OUTCOMES if k in s))
        self.header.setText(text)

    def save_settings(self, s):
        s.set('splitter', self.splitter.saveState())

    def restore_settings(self, s):
        state = s.get_bytes('splitter')
        if state is not None:
            self.splitter.restoreState(state)
