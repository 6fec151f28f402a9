"""The dashboard window: every panel in a dock, the emergency stop in a fixed toolbar."""
import os

import rospy
from python_qt_binding.QtCore import QSettings, Qt, QTimer, Signal
from python_qt_binding.QtGui import QFont
from python_qt_binding.QtWidgets import (QAction, QApplication, QDockWidget, QLabel, QMainWindow, QSizePolicy,
                                         QToolBar, QWidget)

from visualization_pkg import names
from visualization_pkg.dashboard import executive_state as es
from visualization_pkg.dashboard import rviz_panel
from visualization_pkg.dashboard.console_panel import ConsolePanel
from visualization_pkg.dashboard.diagnostics_panel import DiagnosticsPanel
from visualization_pkg.dashboard.image_panel import DEFAULT_TOPICS, ImagePanel
from visualization_pkg.dashboard.mission_panel import MissionPanel
from visualization_pkg.dashboard.nodes_panel import NodesPanel
from visualization_pkg.dashboard.operation_panel import OperationPanel
from visualization_pkg.dashboard.operator_events import OperatorEventPublisher
from visualization_pkg.dashboard.qt_common import QSettingsGroup, Settings
from visualization_pkg.dashboard.reconfigure_panel import ReconfigurePanel
from visualization_pkg.dashboard.smach_panel import StateMachinePanel

SETTINGS_VERSION = 1

DEFAULT_CONFIG = {
    'executive': names.EXECUTIVE,
    'introspection_server': names.INTROSPECTION_SERVER,
    'estop_topic': names.EMERGENCY_STOP,
    'halt_service': names.HALT_ALL,
    'actions': {'move_base': 'move_base', 'move_robot': 'move_robot', 'end_effector': 'end_effector'},
    'action_timeout': 60.0,
    'image_topics': [{'title': t, 'topic': n} for t, n in DEFAULT_TOPICS],
    'expected_nodes': [],
    'node_check_period': 2.0,
    'console_topic': 'rosout_agg',
    'diagnostics_topic': 'diagnostics_agg',
    'reconfigure_servers': [],
    'robot_yaml': '',
    'critical_nodes': ['task_planner', 'motion_server', 'kinematics_server', 'image_processing', 'visual_servo'],
    'respawn_timeout': 10.0,
    'embedded_rviz': False,
    'rviz_config': '',
    'enable_shell': False,
}


def merged_config(overrides):
    cfg = dict(DEFAULT_CONFIG)
    for key, value in (overrides or {}).items():
        if key in cfg and isinstance(cfg[key], dict) and isinstance(value, dict):
            merged = dict(cfg[key])
            merged.update(value)
            cfg[key] = merged
        elif key in cfg:
            cfg[key] = value
    return cfg


#: the operator's shell setting in the dashboard's QSettings (the launch's enable_shell is the
#: default until the operator chooses)
SHELL_SETTING = 'modules/shell'


def shell_enabled(settings, default):
    """The shell setting as a bool (QSettings' ini files give strings back)."""
    value = settings.value(SHELL_SETTING, default)
    if isinstance(value, str):
        return value.strip().lower() in ('true', '1', 'yes')
    return bool(value)


class DashboardWindow(QMainWindow):
    """One window, dockable panels; start() subscribes, close() saves settings and shuts down."""
    quit_requested = Signal()

    def __init__(self, config=None, settings=None, parent=None):
        QMainWindow.__init__(self, parent)
        self.config = merged_config(config)
        cfg = self.config
        self.setWindowTitle('Harvest robot dashboard')
        self.setObjectName('HarvestDashboard')
        self.setDockNestingEnabled(True)
        self.settings = settings if settings is not None else QSettings('harvest', 'harvest_dashboard')
        self._shut = False
        self.events = OperatorEventPublisher()

        self.images = ImagePanel([(t['title'], t['topic']) for t in cfg['image_topics']])
        self.smach = StateMachinePanel(cfg['introspection_server'])
        self.operation = OperationPanel(cfg['executive'], cfg['introspection_server'], cfg['estop_topic'],
                                        cfg['halt_service'], cfg['actions'], cfg['action_timeout'], cfg['robot_yaml'],
                                        events=self.events)
        self.nodes = NodesPanel(cfg['expected_nodes'], cfg['node_check_period'], cfg['critical_nodes'],
                                cfg['respawn_timeout'], mission_running=self._mission_running, events=self.events)
        self.console = ConsolePanel(cfg['console_topic'])
        self.diagnostics = DiagnosticsPanel(cfg['diagnostics_topic'])
        self.reconfigure = ReconfigurePanel(cfg['reconfigure_servers'])
        self.mission = MissionPanel()
        self.panels = [self.images, self.smach, self.operation, self.nodes, self.console, self.diagnostics,
                       self.reconfigure, self.mission]
        # optional modules: docks only when enabled
        self.rviz = None
        self.rviz_process = None
        self.rviz_log = ''
        if cfg['embedded_rviz']:
            self._setup_rviz(cfg['rviz_config'])
        self.shell = None
        if shell_enabled(self.settings, cfg['enable_shell']):
            self._create_shell()

        # the emergency stop lives in a fixed toolbar: always visible, whatever the docks do
        bar = QToolBar('Emergency stop')
        bar.setObjectName('estop_toolbar')
        bar.setMovable(False)
        bar.setFloatable(False)
        bar.toggleViewAction().setEnabled(False)
        bar.setContextMenuPolicy(Qt.PreventContextMenu)
        self.operation.estop_layout.removeWidget(self.operation.estop_button)
        self.operation.estop_holder.hide()
        self.estop_button = self.operation.estop_button
        self.estop_button.setSizePolicy(QSizePolicy.Fixed, QSizePolicy.Fixed)
        self.estop_button.setFixedWidth(300)
        bar.addWidget(self.estop_button)
        spacer = QWidget()
        spacer.setFixedWidth(12)
        bar.addWidget(spacer)
        self.mode_label = QLabel()
        font = QFont()
        font.setPointSize(11)
        self.mode_label.setFont(font)
        bar.addWidget(self.mode_label)
        self.addToolBar(Qt.TopToolBarArea, bar)

        self.docks = {}
        for panel in self.panels:
            dock = QDockWidget(panel.title, self)
            dock.setObjectName('dock_' + panel.__class__.__name__)
            dock.setWidget(panel)
            dock.setFeatures(QDockWidget.DockWidgetMovable | QDockWidget.DockWidgetFloatable |
                             QDockWidget.DockWidgetClosable)
            self.docks[panel] = dock
        self._default_layout()

        view = self.menuBar().addMenu('&View')
        for panel in self.panels:
            view.addAction(self.docks[panel].toggleViewAction())
        view.addSeparator()
        settings_menu = self.menuBar().addMenu('&Settings')
        self.shell_action = QAction('Shell panel (a local terminal; never reachable from the network)', self)
        self.shell_action.setCheckable(True)
        self.shell_action.setChecked(self.shell is not None)
        self.shell_action.toggled.connect(self.set_shell_enabled)
        settings_menu.addAction(self.shell_action)
        reset = QAction('Reset layout', self)
        reset.triggered.connect(self._default_layout)
        view.addAction(reset)
        file_menu = self.menuBar().addMenu('&File')
        quit_action = QAction('Quit', self)
        quit_action.setShortcut('Ctrl+Q')
        quit_action.triggered.connect(self.close)
        file_menu.addAction(quit_action)

        self._timer = QTimer(self)
        self._timer.setInterval(250)
        self._timer.timeout.connect(self._tick)
        self.quit_requested.connect(self.close, Qt.QueuedConnection)

    def _create_shell(self):
        from visualization_pkg.dashboard.shell_panel import ShellPanel
        self.shell = ShellPanel()
        self.panels.append(self.shell)

    def set_shell_enabled(self, enabled):
        """The operator's setting (Settings menu, kept in the dashboard's settings): the shell
        panel opens now and at every start, or closes (its shell ended) and stays closed."""
        enabled = bool(enabled)
        self.settings.setValue(SHELL_SETTING, enabled)
        self.settings.sync()
        if enabled and self.shell is None:
            self._create_shell()
            dock = QDockWidget(self.shell.title, self)
            dock.setObjectName('dock_' + self.shell.__class__.__name__)
            dock.setWidget(self.shell)
            dock.setFeatures(QDockWidget.DockWidgetMovable | QDockWidget.DockWidgetFloatable |
                             QDockWidget.DockWidgetClosable)
            self.docks[self.shell] = dock
            self.addDockWidget(Qt.RightDockWidgetArea, dock)
            self.tabifyDockWidget(self.docks[self.reconfigure], dock)
            dock.raise_()
            if self._timer.isActive():          # the window has started: so does the shell
                self.shell.start()
        elif not enabled and self.shell is not None:
            shell, self.shell = self.shell, None
            shell.shutdown()
            dock = self.docks.pop(shell)
            self.removeDockWidget(dock)
            self.panels.remove(shell)
            dock.deleteLater()
        if self.shell_action.isChecked() != enabled:
            self.shell_action.setChecked(enabled)

    def _setup_rviz(self, config_path):
        panel, reason = rviz_panel.make_rviz(config_path, QApplication.platformName())
        if panel is not None:
            self.rviz = panel
            self.panels.append(panel)
            return
        window_reason = rviz_panel.window_blocker(os.environ)
        self.rviz_log = rviz_panel.fallback_line(reason, window_reason)
        rospy.logwarn(self.rviz_log)
        if not window_reason:
            self.rviz_process = rviz_panel.start_rviz_window(config_path, self)

    def _mission_running(self):
        """True / False, or None while the executive's state is not known yet (for the nodes panel)."""
        mode = self.operation.mode()
        if mode == es.UNKNOWN:
            return None
        return mode in (es.RUNNING, es.PAUSED)

    def _default_layout(self):
        """Images and manual operation on the left, the state machine in the middle, the mission on
        the right; console, diagnostics, reconfigure and nodes tabbed below the state machine."""
        d = self.docks
        for dock in d.values():
            dock.setFloating(False)
            dock.show()
        self.addDockWidget(Qt.LeftDockWidgetArea, d[self.images])
        self.addDockWidget(Qt.LeftDockWidgetArea, d[self.operation])
        self.splitDockWidget(d[self.images], d[self.operation], Qt.Vertical)
        self.addDockWidget(Qt.RightDockWidgetArea, d[self.smach])
        self.addDockWidget(Qt.RightDockWidgetArea, d[self.mission])
        self.splitDockWidget(d[self.smach], d[self.mission], Qt.Horizontal)
        self.addDockWidget(Qt.RightDockWidgetArea, d[self.console])
        self.splitDockWidget(d[self.smach], d[self.console], Qt.Vertical)
        self.tabifyDockWidget(d[self.console], d[self.nodes])
        self.tabifyDockWidget(d[self.nodes], d[self.diagnostics])
        self.tabifyDockWidget(d[self.diagnostics], d[self.reconfigure])
        if self.rviz is not None:
            self.addDockWidget(Qt.RightDockWidgetArea, d[self.rviz])
            self.tabifyDockWidget(d[self.smach], d[self.rviz])
            d[self.smach].raise_()
        if self.shell is not None:
            self.addDockWidget(Qt.RightDockWidgetArea, d[self.shell])
            self.tabifyDockWidget(d[self.reconfigure], d[self.shell])
        d[self.console].raise_()
        self.resizeDocks([d[self.images], d[self.smach], d[self.mission]], [520, 760, 480], Qt.Horizontal)
        self.resizeDocks([d[self.images], d[self.operation]], [330, 620], Qt.Vertical)
        self.resizeDocks([d[self.smach], d[self.console]], [640, 300], Qt.Vertical)

    # --- life cycle -----------------------------------------------------------------------------
    def start(self):
        self.events.start()
        for panel in self.panels:
            panel.start()
        self._timer.start()
        self._tick()

    def _tick(self):
        op = self.operation
        self.mode_label.setText(op.mode_label.text().replace('<br>', '&nbsp;&nbsp;&nbsp;'))

    def closeEvent(self, event):
        self.save_settings()
        self.shutdown()
        QMainWindow.closeEvent(self, event)

    def shutdown(self):
        if self._shut:
            return
        self._shut = True
        self._timer.stop()
        for panel in self.panels:
            panel.shutdown()
        self.events.shutdown()
        if self.rviz_process is not None:
            self.rviz_process.terminate()
            if not self.rviz_process.waitForFinished(3000):
                self.rviz_process.kill()

    # --- settings ---------------------------------------------------------------------------------
    def save_settings(self):
        s = self.settings
        s.setValue('version', SETTINGS_VERSION)
        s.setValue('window/geometry', self.saveGeometry())
        s.setValue('window/state', self.saveState(SETTINGS_VERSION))
        for panel in self.panels:
            panel.save_settings(Settings(QSettingsGroup(s, panel.objectName())))
        s.sync()

    def restore_settings(self):
        s = self.settings
        try:
            version = int(s.value('version', 0))
        except (TypeError, ValueError):
            version = 0
        if version != SETTINGS_VERSION:
            return False
        geometry = s.value('window/geometry')
        if geometry is not None:
            self.restoreGeometry(geometry)
        state = s.value('window/state')
        if state is not None:
            self.restoreState(state, SETTINGS_VERSION)
        for panel in self.panels:
            panel.restore_settings(Settings(QSettingsGroup(s, panel.objectName())))
        return True
