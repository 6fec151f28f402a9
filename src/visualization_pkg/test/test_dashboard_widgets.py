"""Dashboard widgets offscreen (QT_QPA_PLATFORM=offscreen), fed through their slots: no ROS master.

The state-machine graph and its userdata, the manual-operation gate, the window (fixed e-stop
toolbar, docks, settings round trip, shutdown) and the rqt plugin classes with a stand-in rqt.
"""
import base64
import os
import pickle
import sys
import types

import pytest

os.environ.setdefault('QT_QPA_PLATFORM', 'offscreen')
HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(os.path.dirname(HERE), 'src'))

QtWidgets = pytest.importorskip('python_qt_binding.QtWidgets')
smach_msgs = pytest.importorskip('smach_msgs.msg')
pytest.importorskip('harvest_msgs.msg')

from python_qt_binding.QtCore import QSettings  # noqa: E402


@pytest.fixture(scope='module')
def app():
    return QtWidgets.QApplication.instance() or QtWidgets.QApplication(['test'])


def structure(path, children, edges, outcomes):
    return smach_msgs.SmachContainerStructure(path=path, children=children,
                                              internal_outcomes=[e[0] for e in edges],
                                              outcomes_from=[e[1] for e in edges],
                                              outcomes_to=[e[2] for e in edges], container_outcomes=outcomes)


def status(path, active, data=None, initial=None):
    local = base64.b64encode(pickle.dumps(data or {}, 2)).decode('ascii')
    return smach_msgs.SmachContainerStatus(path=path, active_states=active, initial_states=initial or [],
                                           local_data=local)


def feed_executive(panel):
    panel.on_structure(structure('/SM_ROOT', ['RUN', 'DO_STOP'],
                                 [('estop', 'RUN', 'DO_STOP'), ('resume', 'DO_STOP', 'RUN'),
                                  ('succeeded', 'RUN', 'succeeded')], ['succeeded', 'aborted']))
    panel.on_structure(structure('/SM_ROOT/RUN', ['MISSION', 'ESTOP_MONITOR'],
                                 [('succeeded', 'MISSION', 'succeeded'), ('estop', 'ESTOP_MONITOR', 'estop')],
                                 ['succeeded', 'estop']))
    panel.on_structure(structure('/SM_ROOT/RUN/MISSION', ['DO_START', 'NEXT_POINT', 'DO_MOVEBASE'],
                                 [('succeeded', 'DO_START', 'NEXT_POINT'), ('point', 'NEXT_POINT', 'DO_MOVEBASE'),
                                  ('succeeded', 'DO_MOVEBASE', 'NEXT_POINT'), ('done', 'NEXT_POINT', 'succeeded')],
                                 ['succeeded', 'aborted']))
    panel.on_status(status('/SM_ROOT', ['RUN'], initial=['RUN']))
    panel.on_status(status('/SM_ROOT/RUN', ['MISSION', 'ESTOP_MONITOR']))
    panel.on_status(status('/SM_ROOT/RUN/MISSION', ['DO_MOVEBASE'], {'picking_point': 3, 'track_position': 1.8},
                           initial=['DO_START']))


def test_state_machine_panel(app):
    from visualization_pkg.dashboard.smach_panel import StateMachinePanel
    panel = StateMachinePanel()
    panel.resize(900, 600)
    feed_executive(panel)
    panel.flush()
    assert panel.view_root() == '/SM_ROOT/RUN'                # follow: deepest active container, depth 2
    assert panel.highlighted_paths() == {'/SM_ROOT/RUN/MISSION', '/SM_ROOT/RUN/MISSION/DO_MOVEBASE',
                                         '/SM_ROOT/RUN/ESTOP_MONITOR'}
    assert 'DO_MOVEBASE' in panel.active_label.text()
    panel.select('/SM_ROOT/RUN/MISSION/DO_MOVEBASE')
    items = dict((panel.ud_tree.topLevelItem(i).text(0), panel.ud_tree.topLevelItem(i).text(1))
                 for i in range(panel.ud_tree.topLevelItemCount()))
    assert items == {'picking_point': '3', 'track_position': '1.8'}
    # the emergency stop moves the root to DO_STOP
    panel.on_status(status('/SM_ROOT', ['DO_STOP']))
    panel.flush()
    assert panel.view_root() == '/SM_ROOT'
    assert panel.highlighted_paths() == {'/SM_ROOT/DO_STOP'}
    # a fixed view with every level expanded
    panel.root_combo.setCurrentIndex(panel.root_combo.findText('/SM_ROOT'))
    panel.depth_spin.setValue(3)
    panel.flush()
    assert '/SM_ROOT/RUN/MISSION/DO_START' in panel.drawn_paths()
    panel.grab()


def test_operation_gate_without_ros(app):
    from visualization_pkg.dashboard import executive_state as es
    from visualization_pkg.dashboard.operation_panel import EStopButton, OperationPanel
    op = OperationPanel()
    assert op.mode() == es.UNKNOWN
    assert not op.jog('left_lift_joint', 0.01) and 'not known yet' in op.last_message
    op._on_root_status(status('/SM_ROOT', ['RUN']))
    assert op.mode() == es.RUNNING
    assert not op.move_cart(0) and 'mission is running' in op.last_message
    assert not op.start_mission() and 'already running' in op.last_message
    op._on_root_status(status('/SM_ROOT', ['DO_STOP']))
    op.refresh()
    assert op.estop_button.state == EStopButton.STOPPED
    assert not op.jog('left_lift_joint', 0.01) and 'no joint_states' in op.last_message
    assert op.limits['right_boom_joint'] == (-2.618, 2.618)
    op._on_root_status(status('/SM_ROOT/RUN', ['MISSION']))    # a nested container: not the root
    assert op.mode() == es.PAUSED
    op.confirm = lambda question: False
    assert not op.end_effector(1) and 'cancelled' in op.last_message


def test_window_layout_settings_and_shutdown(app, tmp_path):
    from visualization_pkg.dashboard.main_window import DashboardWindow
    ini = str(tmp_path / 'dashboard.ini')
    w = DashboardWindow({'expected_nodes': ['task_planner']}, QSettings(ini, QSettings.IniFormat))
    w.resize(1600, 1000)
    w.show()
    app.processEvents()
    bar = w.estop_button.parentWidget()
    assert isinstance(bar, QtWidgets.QToolBar) and not bar.isMovable()
    assert w.estop_button.isVisible()
    for panel in w.panels:                                  # every panel sits in its own dock
        assert isinstance(panel.parentWidget(), QtWidgets.QDockWidget)
    w.docks[w.console].hide()
    assert w.estop_button.isVisible()                       # docks come and go, the stop stays
    w.smach.depth_spin.setValue(4)
    w.images.combos[0].setEditText('other/image')
    w.close()
    assert w._shut
    other = DashboardWindow(settings=QSettings(ini, QSettings.IniFormat))
    assert other.restore_settings()
    assert other.smach.depth_spin.value() == 4
    assert other.images.combos[0].currentText() == 'other/image'
    other.shutdown()


def test_rqt_plugins_with_a_stand_in_rqt(app, monkeypatch):
    """plugin.xml names classes that work with rqt's Plugin interface (rqt itself is not on Debian)."""
    from python_qt_binding.QtCore import QObject

    class Plugin(QObject):                                   # qt_gui's Plugin is a QObject taking a context
        def __init__(self, context):
            QObject.__init__(self)

    fake = types.ModuleType('rqt_gui_py.plugin')
    fake.Plugin = Plugin
    monkeypatch.setitem(sys.modules, 'rqt_gui_py', types.ModuleType('rqt_gui_py'))
    monkeypatch.setitem(sys.modules, 'rqt_gui_py.plugin', fake)
    sys.modules.pop('visualization_pkg.dashboard.rqt_plugins', None)
    from visualization_pkg.dashboard import rqt_plugins
    import visualization_pkg.dashboard.main_window  # noqa: F401 - imports every panel class
    import visualization_pkg.dashboard.qt_common as qc
    for cls in [qc.Panel] + qc.Panel.__subclasses__():       # no ROS graph here: do not subscribe
        monkeypatch.setattr(cls, 'start', lambda self: None)
    assert rqt_plugins.HAVE_RQT

    class Context(object):
        def __init__(self):
            self.widgets = []

        def serial_number(self):
            return 2

        def add_widget(self, widget):
            self.widgets.append(widget)

    class Store(object):
        def __init__(self):
            self.d = {}

        def set_value(self, k, v):
            self.d[k] = v

        def value(self, k, default=None):
            return self.d.get(k, default)

    xml = open(os.path.join(os.path.dirname(HERE), 'plugin.xml')).read()
    for name in ('ImagePlugin', 'StateMachinePlugin', 'OperationPlugin', 'NodesPlugin', 'ConsolePlugin',
                 'DiagnosticsPlugin', 'ReconfigurePlugin', 'MissionPlugin'):
        assert 'visualization_pkg.dashboard.rqt_plugins.' + name in xml
        ctx = Context()
        plugin = getattr(rqt_plugins, name)(ctx)
        assert ctx.widgets == [plugin.panel] and plugin.panel.windowTitle().endswith('(2)')
        store = Store()
        plugin.save_settings(Store(), store)
        plugin.restore_settings(Store(), store)
        plugin.shutdown_plugin()
    sys.modules.pop('visualization_pkg.dashboard.rqt_plugins', None)


def test_mission_plot_paints(app):
    from visualization_pkg.dashboard.mission_panel import MissionPanel, nice_step
    assert nice_step(9.0) == 2.0 and nice_step(0.0) == 1.0
    panel = MissionPanel()
    panel.resize(500, 400)
    for i, outcome in enumerate([0, 1, 2, 0]):
        panel.stats.add_record('m', 0, i, outcome, '', ['DO_KINEMATICS', 'DO_MOVE_ROBOT'], [0.2, 1.0 + i], 1.5 + i)
    image = panel.plot.grab().toImage()
    assert image.width() > 0
    colours = set(image.pixel(x, y) for x in range(0, image.width(), 5) for y in range(0, image.height(), 5))
    assert len(colours) > 4                                 # bars drawn, not a blank widget


def test_mission_panel_colours_every_outcome(app):
    from visualization_pkg.dashboard import mission_panel, mission_stats
    assert sorted(mission_panel.OUTCOME_COLOURS) == sorted(mission_stats.OUTCOMES)
    assert len(set(c.name() for c in mission_panel.OUTCOME_COLOURS.values())) == len(mission_stats.OUTCOMES)


def wait_until(predicate, timeout=20.0):
    """Run the Qt event loop until predicate() holds or `timeout` s pass (a bounded QEventLoop wait)."""
    from python_qt_binding.QtCore import QElapsedTimer, QEventLoop, QTimer
    loop = QEventLoop()
    clock = QElapsedTimer()
    clock.start()
    poll = QTimer()
    poll.timeout.connect(lambda: (predicate() or clock.elapsed() > timeout * 1000) and loop.quit())
    poll.start(20)
    if not predicate():
        loop.exec_()
    poll.stop()
    return predicate()


class FakeEvents(object):
    def __init__(self):
        self.sent = []

    def publish(self, action, outcome, text):
        self.sent.append((action, outcome, text))


def test_shell_is_off_until_the_operator_enables_it_in_the_settings_menu(app, tmp_path):
    from visualization_pkg.dashboard.main_window import DashboardWindow
    from visualization_pkg.dashboard.shell_panel import ShellPanel
    ini = str(tmp_path / 'shell.ini')
    w = DashboardWindow(settings=QSettings(ini, QSettings.IniFormat))
    assert w.shell is None and not w.shell_action.isChecked()
    w.shell_action.trigger()                                  # the operator ticks it
    assert isinstance(w.shell, ShellPanel) and w.shell in w.panels
    assert isinstance(w.shell.parentWidget(), QtWidgets.QDockWidget)
    w.shutdown()
    again = DashboardWindow(settings=QSettings(ini, QSettings.IniFormat))
    assert isinstance(again.shell, ShellPanel) and again.shell_action.isChecked()   # kept
    again.shell_action.trigger()                              # and unticks it
    assert again.shell is None and not any(isinstance(p, ShellPanel) for p in again.panels)
    again.shutdown()
    # the operator's choice wins over the launch's enable_shell default
    third = DashboardWindow({'enable_shell': True}, QSettings(ini, QSettings.IniFormat))
    assert third.shell is None
    third.shutdown()


@pytest.fixture
def shell(app):
    from visualization_pkg.dashboard.shell_panel import ShellPanel
    panel = ShellPanel(setup_files=[])
    panel.start()
    yield panel
    panel.shutdown()


def test_shell_runs_a_command_with_coloured_output(shell):
    from visualization_pkg.dashboard.shell_panel import STDERR_COLOUR, STDOUT_COLOUR
    assert shell.run('echo hello')
    assert wait_until(lambda: 'hello' in shell.text_in(STDOUT_COLOUR))
    shell.line.setText('echo oops >&2')
    shell.run_line()
    assert wait_until(lambda: 'oops' in shell.text_in(STDERR_COLOUR))
    assert 'oops' not in shell.text_in(STDOUT_COLOUR) and shell.history.items == ['echo hello', 'echo oops >&2']


def test_shell_ctrl_c_ends_the_running_command(shell):
    from visualization_pkg.dashboard import shell_session
    from visualization_pkg.dashboard.shell_panel import STDOUT_COLOUR
    pid = int(shell.process.processId())
    shell.run('echo ready')                                 # the rc file (~/.bashrc too) has run
    assert wait_until(lambda: 'ready' in shell.text_in(STDOUT_COLOUR))

    def cmdline(p):
        try:
            with open('/proc/%d/cmdline' % p, 'rb') as f:
                return f.read()
        except OSError:                                     # ended meanwhile
            return b''

    def sleeping():
        return [p for p in shell_session.descendants(pid, shell_session.parent_map())
                if cmdline(p).startswith(b'sleep')]
    shell.run('sleep 100; echo "status $?"')
    assert wait_until(lambda: len(sleeping()) == 1)
    assert shell.interrupt()
    # sleep died of SIGINT: bash reports 128 + 2 and the shell itself is still there
    assert wait_until(lambda: 'status 130' in shell.text_in(STDOUT_COLOUR))
    assert shell.run('echo alive') and wait_until(lambda: 'alive' in shell.text_in(STDOUT_COLOUR))


def test_embedded_rviz_dock_or_fallback_line(app, tmp_path, monkeypatch):
    from visualization_pkg.dashboard import rviz_panel
    from visualization_pkg.dashboard.main_window import DashboardWindow
    monkeypatch.delenv('DISPLAY', raising=False)        # no second rviz window out of a test
    monkeypatch.delenv('WAYLAND_DISPLAY', raising=False)
    lines = []
    monkeypatch.setattr(rviz_panel.rospy, 'logwarn', lambda text, *a: lines.append(text % a if a else text))
    w = DashboardWindow({'embedded_rviz': True}, QSettings(str(tmp_path / 'd.ini'), QSettings.IniFormat))
    if w.rviz is not None:
        assert isinstance(w.rviz.parentWidget(), QtWidgets.QDockWidget)
    else:
        assert lines == [w.rviz_log] and 'rviz not embedded' in w.rviz_log and w.rviz_process is None
    plain = DashboardWindow(settings=QSettings(str(tmp_path / 'e.ini'), QSettings.IniFormat))
    assert plain.rviz is None and plain.shell is None and len(plain.panels) == 8   # both off by default
    w.shutdown()
    plain.shutdown()


def test_nodes_panel_actions_confirm_and_publish_events(app):
    from test_dashboard_logic import FakeLayer
    from visualization_pkg.dashboard import node_control as nc
    from visualization_pkg.dashboard.nodes_panel import NodesPanel
    spec = nc.NodeSpec('/task_planner', 'control_pkg', 'task_planner')
    layer = FakeLayer({'/task_planner': 7, '/dummy': 8}, {'/task_planner': spec})
    events = FakeEvents()
    running = [True]
    panel = NodesPanel(critical=['task_planner'], mission_running=lambda: running[0], events=events, layer=layer)
    panel.check = lambda: None                          # no master here
    asked = []
    panel.confirm = lambda q: asked.append(q) or False
    assert not panel.act('restart', '/task_planner')
    assert asked and layer.calls == [] and events.sent[-1][:2] == ('node_restart', nc.REFUSED)
    panel.confirm = lambda q: True
    assert panel.act('restart', '/task_planner')
    assert wait_until(lambda: not panel.acting)
    assert layer.calls == [('kill', '/task_planner'), ('launch', '/task_planner')]
    assert events.sent[-1][:2] == ('node_restart', nc.OK)
    running[0] = False
    panel.confirm = lambda q: pytest.fail('no confirmation for a non-critical node or without a mission')
    assert panel.act('restart', '/dummy') and wait_until(lambda: not panel.acting)
    assert events.sent[-1][:2] == ('node_restart', nc.REFUSED) and layer.pid('/dummy') == 8
    assert 'another machine' in panel.action_label.text()
    assert panel.act('stop', '/dummy') and wait_until(lambda: not panel.acting)
    assert events.sent[-1][:2] == ('node_stop', nc.OK) and layer.pid('/dummy') is None
    panel.shutdown()
    assert ('stop_process', '/task_planner') in layer.calls     # what the dashboard started stops with it


def test_waist_jog_row_gate_and_events(app):
    from visualization_pkg.dashboard import executive_state as es
    from visualization_pkg.dashboard.operation_panel import OperationPanel
    events = FakeEvents()
    op = OperationPanel(events=events)
    assert op.findChild(QtWidgets.QPushButton, 'jog_waist_joint_plus') is not None
    op._on_root_status(status('/SM_ROOT', ['RUN']))
    assert op.mode() == es.RUNNING
    assert not op.jog('waist_joint', 0.1) and 'mission is running' in op.last_message
    assert events.sent[-1][:2] == ('jog', 'refused')
    assert not op.move_cart(1) and events.sent[-1][:2] == ('move_cart', 'refused')
    op._on_root_status(status('/SM_ROOT', ['DO_STOP']))
    op.positions['waist_joint'] = 0.5
    op.jog('waist_joint', 0.1)                       # no ROS here: refused by _send, as arm jogs
    assert 'not connected to ROS' in op.last_message and events.sent[-1][:2] == ('jog', 'refused')
    # paused: the waist jog goes to move_robot as a waist-only goal, clamped, and is recorded
    sent = []
    op.clients = {'move_robot': object()}
    op.run_in_background = lambda tag, fn, *args: sent.append((tag, args))
    assert op.jog('waist_joint', 0.1)
    (tag, (client, goal, what, action)), = sent
    assert tag == 'action' and client is op.clients['move_robot'] and action == 'jog'
    assert goal.move_waist and goal.waist == pytest.approx(0.6) and list(goal.target_joint.positions) == []
    assert events.sent[-1][:2] == ('jog', 'accepted') and '0.600' in events.sent[-1][2]
    op.busy = ''
    op.positions['waist_joint'] = 3.1
    assert op.jog('waist_joint', 0.2) and sent[-1][1][1].waist == pytest.approx(op.limits['waist_joint'][1])
    assert 'clamped' in events.sent[-1][2]
    op.busy = ''
    op._on_root_status(status('/SM_ROOT', ['RUN']))
    assert not op.jog('waist_joint', 0.1) and len(sent) == 2 and events.sent[-1][:2] == ('jog', 'refused')


def test_operator_events_do_not_switch_the_mission_panel(app):
    from harvest_msgs.msg import MissionEvent
    from visualization_pkg.dashboard.mission_panel import MissionPanel
    panel = MissionPanel()
    panel.on_event(MissionEvent(mission_id='m1', kind='state', state='START', detail='mission m1 started'))
    panel.stats.add_record('m1', 0, 1, 0, '', ['DO_KINEMATICS'], [0.2], 1.5)
    panel.on_event(MissionEvent(mission_id='operator-20260101', kind='operator', state='node_stop', detail='ok: /x'))
    assert panel.stats.mission_id == 'm1' and len(panel.stats.fruits) == 1
    assert 'node_stop' in panel.state_label.text()
