"""Console panel (the paper's console module): rosout_agg with level, node and text filters."""
import time

from python_qt_binding.QtCore import QAbstractTableModel, QModelIndex, QSortFilterProxyModel, Qt, Signal
from python_qt_binding.QtGui import QBrush, QColor
from python_qt_binding.QtWidgets import (QAbstractItemView, QCheckBox, QComboBox, QHBoxLayout, QHeaderView, QLabel,
                                         QLineEdit, QPushButton, QTableView, QVBoxLayout)
from rosgraph_msgs.msg import Log

from visualization_pkg.dashboard import log_buffer
from visualization_pkg.dashboard.qt_common import Panel

ALL_NODES = '(all nodes)'
_LEVEL_COLOURS = {log_buffer.DEBUG: QColor('#78909c'), log_buffer.INFO: QColor('#263238'),
                  log_buffer.WARN: QColor('#e65100'), log_buffer.ERROR: QColor('#c62828'),
                  log_buffer.FATAL: QColor('#880e4f')}
_LEVEL_BG = {log_buffer.WARN: QColor('#fff8e1'), log_buffer.ERROR: QColor('#ffebee'),
             log_buffer.FATAL: QColor('#fce4ec')}
COLUMNS = ('Time', 'Level', 'Node', 'Message')


class LogModel(QAbstractTableModel):
    def __init__(self, size, parent=None):
        QAbstractTableModel.__init__(self, parent)
        self.buffer = log_buffer.LogBuffer(size)

    def rowCount(self, parent=QModelIndex()):
        return 0 if parent.isValid() else len(self.buffer.entries)

    def columnCount(self, parent=QModelIndex()):
        return len(COLUMNS)

    def headerData(self, section, orientation, role=Qt.DisplayRole):
        if orientation == Qt.Horizontal and role == Qt.DisplayRole:
            return COLUMNS[section]
        return None

    def data(self, index, role=Qt.DisplayRole):
        e = self.buffer.entries[index.row()]
        col = index.column()
        if role == Qt.DisplayRole:
            if col == 0:
                return '%s.%03d' % (time.strftime('%H:%M:%S', time.localtime(e.stamp)), int(e.stamp * 1000) % 1000)
            return (None, log_buffer.level_name(e.level), e.node, e.msg)[col]
        if role == Qt.ForegroundRole:
            return QBrush(_LEVEL_COLOURS.get(e.level, QColor('#000000')))
        if role == Qt.BackgroundRole and e.level in _LEVEL_BG:
            return QBrush(_LEVEL_BG[e.level])
        if role == Qt.ToolTipRole:
            return '%s\n%s' % (e.msg, e.location)
        return None

    def add(self, entry):
        if len(self.buffer.entries) == self.buffer.entries.maxlen:
            self.beginRemoveRows(QModelIndex(), 0, 0)
            self.buffer.entries.popleft()
            self.endRemoveRows()
        n = len(self.buffer.entries)
        self.beginInsertRows(QModelIndex(), n, n)
        self.buffer.add(entry)
        self.endInsertRows()

    def clear(self):
        self.beginResetModel()
        self.buffer.clear()
        self.endResetModel()


class LogFilterProxy(QSortFilterProxyModel):
    def __init__(self, parent=None):
        QSortFilterProxyModel.__init__(self, parent)
        self.filter = log_buffer.LogFilter()

    def set_filter(self, log_filter):
        self.filter = log_filter
        self.invalidateFilter()

    def filterAcceptsRow(self, row, parent):
        entries = self.sourceModel().buffer.entries
        return row < len(entries) and self.filter.accepts(entries[row])


class ConsolePanel(Panel):
    title = 'Console'
    log_received = Signal(object)

    def __init__(self, topic='rosout_agg', size=5000, parent=None):
        Panel.__init__(self, parent)
        self.topic = topic
        self.model = LogModel(size, self)
        self.proxy = LogFilterProxy(self)
        self.proxy.setSourceModel(self.model)
        self.level_combo = QComboBox()
        for level, name in log_buffer.LEVEL_NAMES.items():
            self.level_combo.addItem(name + ' and above', level)
        self.level_combo.setCurrentIndex(1)
        self.node_combo = QComboBox()
        self.node_combo.addItem(ALL_NODES)
        self.node_combo.setSizeAdjustPolicy(QComboBox.AdjustToMinimumContentsLengthWithIcon)
        self.node_combo.setMinimumContentsLength(16)
        self.text_edit = QLineEdit()
        self.text_edit.setPlaceholderText('filter text')
        self.pause_check = QCheckBox('pause')
        self.scroll_check = QCheckBox('follow')
        self.scroll_check.setChecked(True)
        clear = QPushButton('Clear')
        clear.clicked.connect(self.model.clear)
        self.count_label = QLabel('')
        self.table = QTableView()
        self.table.setModel(self.proxy)
        self.table.setEditTriggers(QAbstractItemView.NoEditTriggers)
        self.table.setSelectionBehavior(QAbstractItemView.SelectRows)
        self.table.verticalHeader().setVisible(False)
        self.table.verticalHeader().setDefaultSectionSize(20)
        self.table.setWordWrap(False)
        header = self.table.horizontalHeader()
        header.setSectionResizeMode(QHeaderView.Interactive)   # ResizeToContents is slow on 5000 rows
        header.resizeSection(0, 95)
        header.resizeSection(1, 55)
        header.resizeSection(2, 170)
        header.setStretchLastSection(True)
        top = QHBoxLayout()
        top.addWidget(self.level_combo)
        top.addWidget(self.node_combo)
        top.addWidget(self.text_edit, 1)
        top.addWidget(self.pause_check)
        top.addWidget(self.scroll_check)
        top.addWidget(clear)
        top.addWidget(self.count_label)
        layout = QVBoxLayout(self)
        layout.setContentsMargins(4, 4, 4, 4)
        layout.addLayout(top)
        layout.addWidget(self.table, 1)
        self.level_combo.currentIndexChanged.connect(self._apply_filter)
        self.node_combo.currentIndexChanged.connect(self._apply_filter)
        self.text_edit.textChanged.connect(self._apply_filter)
        self.log_received.connect(self.on_log, Qt.QueuedConnection)

    def start(self):
        Panel.start(self)
        self.subscribe(self.topic, Log, self.log_received, queue_size=200)

    def on_log(self, msg):
        if self.pause_check.isChecked():
            return
        self.add_entry(log_buffer.Entry(msg.header.stamp.to_sec(), msg.level, msg.name, msg.msg,
                                        '%s:%s (%s)' % (msg.file, msg.line, msg.function)))

    def add_entry(self, entry):
        new_node = entry.node not in self.model.buffer.nodes
        self.model.add(entry)
        if new_node:
            self.node_combo.addItem(entry.node)
        self.count_label.setText('%d / %d' % (self.proxy.rowCount(), self.model.rowCount()))
        if self.scroll_check.isChecked():
            self.table.scrollToBottom()

    def _apply_filter(self, *_args):
        node = self.node_combo.currentText()
        self.proxy.set_filter(log_buffer.LogFilter(self.level_combo.currentData() or log_buffer.DEBUG,
                                                   [] if node == ALL_NODES else [node], self.text_edit.text()))
        self.count_label.setText('%d / %d' % (self.proxy.rowCount(), self.model.rowCount()))

    def visible_messages(self):
        """(level, node, message) of the rows the filters let through (tests)."""
        out = []
        for r in range(self.proxy.rowCount()):
            src = self.proxy.mapToSource(self.proxy.index(r, 0)).row()
            e = self.model.buffer.entries[src]
            out.append((e.level, e.node, e.msg))
        return out

    def save_settings(self, s):
        s.set('level', self.level_combo.currentIndex())
        s.set('text', self.text_edit.text())
        s.set('node', self.node_combo.currentText())
        s.set('header', self.table.horizontalHeader().saveState())

    def restore_settings(self, s):
        self.level_combo.setCurrentIndex(s.get_int('level', 1))
        self.text_edit.setText(s.get_str('text', ''))
        node = s.get_str('node', ALL_NODES)
        if node and self.node_combo.findText(node) < 0:
            self.node_combo.addItem(node)
        self.node_combo.setCurrentIndex(max(0, self.node_combo.findText(node)))
        state = s.get_bytes('header')
        if state is not None:
            self.table.horizontalHeader().restoreState(state)
