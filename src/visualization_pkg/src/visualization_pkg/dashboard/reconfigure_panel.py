"""Reconfigure panel (the paper's reconfigure module): edit the dynamic_reconfigure parameters of our nodes.

Servers are found through their `<server>/parameter_descriptions` topics (type
dynamic_reconfigure/ConfigDescription). Selecting one connects a dynamic_reconfigure client in the
background and builds an editor from its parameter descriptions (min/max, enums, descriptions).
"""
import ast
import threading

import rosgraph
import rospy
from dynamic_reconfigure.client import Client
from python_qt_binding.QtCore import Qt, QTimer, Signal
from python_qt_binding.QtWidgets import (QCheckBox, QComboBox, QDoubleSpinBox, QFormLayout, QHBoxLayout, QLabel,
                                         QLineEdit, QListWidget, QPushButton, QScrollArea, QSpinBox, QSplitter,
                                         QStackedWidget, QVBoxLayout, QWidget)

from visualization_pkg.dashboard.qt_common import Panel

DESCRIPTION_TYPE = 'dynamic_reconfigure/ConfigDescription'
SUFFIX = '/parameter_descriptions'
_INT_LIMIT = 2 ** 31 - 1
_FLOAT_LIMIT = 1e9


def find_servers(caller_id, allowed=()):
    """Names of the dynamic_reconfigure servers on the graph (optionally only those in `allowed`)."""
    topics = rosgraph.Master(caller_id).getTopicTypes()
    names = sorted(t[:-len(SUFFIX)] for t, typ in topics if typ == DESCRIPTION_TYPE and t.endswith(SUFFIX))
    if allowed:
        wanted = set(rospy.resolve_name(a) for a in allowed)
        names = [n for n in names if n in wanted]
    return names


class ServerEditor(QWidget):
    """The editor of one server's parameters."""
    connected = Signal(object)          # (client, descriptions) or Exception
    config_received = Signal(object)    # config dict from the server
    update_done = Signal(object)        # config dict or Exception after our update

    def __init__(self, name, parent=None):
        QWidget.__init__(self, parent)
        self.name = name
        self.client = None
        self.config = {}
        self.widgets = {}
        self.types = {}
        self.closed = False
        self.status = QLabel('connecting to %s ...' % name)
        self.status.setWordWrap(True)
        self.form = QFormLayout()
        body = QWidget()
        body.setLayout(self.form)
        scroll = QScrollArea()
        scroll.setWidgetResizable(True)
        scroll.setWidget(body)
        layout = QVBoxLayout(self)
        layout.setContentsMargins(0, 0, 0, 0)
        title = QLabel('<b>%s</b>' % name)
        layout.addWidget(title)
        layout.addWidget(scroll, 1)
        layout.addWidget(self.status)
        self.connected.connect(self._on_connected, Qt.QueuedConnection)
        self.config_received.connect(self._on_config, Qt.QueuedConnection)
        self.update_done.connect(self._on_update_done, Qt.QueuedConnection)
        t = threading.Thread(target=self._connect, name='reconfigure-' + name)
        t.daemon = True
        t.start()

    def _connect(self):
        try:
            client = Client(self.name, timeout=5.0, config_callback=self._config_cb)
            descriptions = client.get_parameter_descriptions(timeout=5.0)
            if descriptions is None:
                raise RuntimeError('no parameter descriptions from %s' % self.name)
            result = (client, descriptions)
        except Exception as exc:  # noqa: BLE001 - shown in the editor
            result = exc
        if not self.closed:
            self.connected.emit(result)
        elif not isinstance(result, Exception):
            result[0].close()

    def _config_cb(self, config):
        if config is not None and not self.closed:
            self.config_received.emit(dict(config))

    def _on_connected(self, result):
        if isinstance(result, Exception):
            self.status.setText('<span style="color:#c62828">cannot connect: %s</span>' % result)
            return
        self.client, descriptions = result
        for d in descriptions:
            self._add_row(d)
        self.status.setText('%d parameters; edits apply at once' % len(descriptions))
        config = self.client.config
        if config:
            self._on_config(dict(config))

    def _add_row(self, d):
        name, typ = d['name'], d['type']
        self.types[name] = typ
        edit_method = d.get('edit_method') or ''
        if edit_method:
            w = QComboBox()
            enum = ast.literal_eval(edit_method)
            for const in enum.get('enum', []):
                w.addItem('%s (%s)' % (const['name'], const['value']), const['value'])
            w.currentIndexChanged.connect(lambda _i, n=name: self._send(n))
        elif typ == 'bool':
            w = QCheckBox()
            w.toggled.connect(lambda _v, n=name: self._send(n))
        elif typ == 'int':
            w = QSpinBox()
            w.setRange(int(max(d['min'], -_INT_LIMIT)), int(min(d['max'], _INT_LIMIT)))
            w.setKeyboardTracking(False)
            w.valueChanged.connect(lambda _v, n=name: self._send(n))
        elif typ == 'double':
            w = QDoubleSpinBox()
            w.setDecimals(4)
            lo, hi = max(float(d['min']), -_FLOAT_LIMIT), min(float(d['max']), _FLOAT_LIMIT)
            w.setRange(lo, hi)
            w.setSingleStep(max((hi - lo) / 100.0, 1e-4) if hi - lo < 1e6 else 0.1)
            w.setKeyboardTracking(False)
            w.valueChanged.connect(lambda _v, n=name: self._send(n))
        else:
            w = QLineEdit()
            w.editingFinished.connect(lambda n=name: self._send(n))
        tip = d.get('description', '')
        if typ in ('int', 'double'):
            tip += '\n[%s .. %s], default %s' % (d['min'], d['max'], d['default'])
        w.setToolTip(tip)
        label = QLabel(name)
        label.setToolTip(tip)
        self.form.addRow(label, w)
        self.widgets[name] = w

    def _value(self, name):
        w = self.widgets[name]
        if isinstance(w, QComboBox):
            return w.currentData()
        if isinstance(w, QCheckBox):
            return w.isChecked()
        if isinstance(w, (QSpinBox, QDoubleSpinBox)):
            return w.value()
        return w.text()

    def _show_value(self, name, value):
        w = self.widgets.get(name)
        if w is None:
            return
        w.blockSignals(True)
        if isinstance(w, QComboBox):
            index = w.findData(value)
            w.setCurrentIndex(max(0, index))
        elif isinstance(w, QCheckBox):
            w.setChecked(bool(value))
        elif isinstance(w, QSpinBox):
            w.setValue(int(value))
        elif isinstance(w, QDoubleSpinBox):
            w.setValue(float(value))
        else:
            w.setText(str(value))
        w.blockSignals(False)

    def _on_config(self, config):
        self.config.update(config)
        for name, value in config.items():
            self._show_value(name, value)

    def _send(self, name):
        if self.client is None:
            return
        value = self._value(name)
        self.status.setText('setting %s = %s ...' % (name, value))
        client = self.client

        def work():
            try:
                out = client.update_configuration({name: value})
            except Exception as exc:  # noqa: BLE001 - shown in the editor
                out = exc
            if not self.closed:
                self.update_done.emit(out)
        t = threading.Thread(target=work, name='reconfigure-set')
        t.daemon = True
        t.start()

    def _on_update_done(self, result):
        if isinstance(result, Exception):
            self.status.setText('<span style="color:#c62828">update failed: %s</span>' % result)
            return
        self._on_config(dict(result))
        self.status.setText('updated')

    def set_param(self, name, value):
        """Edit a parameter as the operator would (tests)."""
        w = self.widgets[name]
        if isinstance(w, QComboBox):
            w.setCurrentIndex(w.findData(value))
        elif isinstance(w, QCheckBox):
            w.setChecked(bool(value))
        elif isinstance(w, (QSpinBox, QDoubleSpinBox)):
            w.setValue(value)
        else:
            w.setText(str(value))
            self._send(name)

    def close_client(self):
        self.closed = True
        if self.client is not None:
            self.client.close()


class ReconfigurePanel(Panel):
    title = 'Reconfigure'

    def __init__(self, servers=(), period=5.0, parent=None):
        Panel.__init__(self, parent)
        self.allowed = list(servers)
        self.editors = {}
        self._searching = False
        self.server_list = QListWidget()
        self.server_list.currentTextChanged.connect(self._select)
        refresh = QPushButton('Refresh')
        refresh.clicked.connect(self.discover)
        self.stack = QStackedWidget()
        self.placeholder = QLabel('Select a node with dynamic_reconfigure parameters')
        self.placeholder.setAlignment(Qt.AlignCenter)
        self.stack.addWidget(self.placeholder)
        left = QWidget()
        lv = QVBoxLayout(left)
        lv.setContentsMargins(0, 0, 0, 0)
        lv.addWidget(self.server_list, 1)
        lv.addWidget(refresh)
        self.splitter = QSplitter(Qt.Horizontal)
        self.splitter.addWidget(left)
        self.splitter.addWidget(self.stack)
        self.splitter.setStretchFactor(1, 3)
        layout = QHBoxLayout(self)
        layout.setContentsMargins(4, 4, 4, 4)
        layout.addWidget(self.splitter)
        self._timer = QTimer(self)
        self._timer.setInterval(int(period * 1000))
        self._timer.timeout.connect(self.discover)

    def start(self):
        Panel.start(self)
        self._timer.start()
        self.discover()

    def shutdown(self):
        self._timer.stop()
        for editor in self.editors.values():
            editor.close_client()
        Panel.shutdown(self)

    def discover(self):
        if self._searching:
            return
        self._searching = True
        self.run_in_background('discover', find_servers, rospy.get_name() or '/harvest_dashboard', self.allowed)

    def on_task_done(self, tag, result):
        self._searching = False
        if isinstance(result, Exception):
            return
        current = [self.server_list.item(i).text() for i in range(self.server_list.count())]
        if current != result:
            selected = self.server_list.currentItem().text() if self.server_list.currentItem() else ''
            self.server_list.blockSignals(True)
            self.server_list.clear()
            self.server_list.addItems(result)
            matches = self.server_list.findItems(selected, Qt.MatchExactly) if selected else []
            if matches:
                self.server_list.setCurrentItem(matches[0])
            self.server_list.blockSignals(False)

    def _select(self, name):
        if not name:
            self.stack.setCurrentWidget(self.placeholder)
            return
        editor = self.editors.get(name)
        if editor is None:
            editor = self.editors[name] = ServerEditor(name)
            self.stack.addWidget(editor)
        self.stack.setCurrentWidget(editor)

    def servers(self):
        return [self.server_list.item(i).text() for i in range(self.server_list.count())]

    def open_editor(self, name):
        matches = self.server_list.findItems(name, Qt.MatchExactly)
        if matches:
            self.server_list.setCurrentItem(matches[0])
        return self.editors.get(name)

    def save_settings(self, s):
        s.set('splitter', self.splitter.saveState())

    def restore_settings(self, s):
        state = s.get_bytes('splitter')
        if state is not None:
            self.splitter.restoreState(state)
