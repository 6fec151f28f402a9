"""rqt plugins of the dashboard panels (plugin.xml), for a Noetic PC where rqt_gui_py exists.

Debian 12 has no rqt, so this module defines the plugin classes only when `rqt_gui_py` can be
imported; elsewhere importing it is harmless and `HAVE_RQT` is False. Each plugin wraps one
panel; parameters come from the dashboard's private namespace if it is set (rosparam load
config/dashboard.yaml /harvest_dashboard), else from the defaults.
"""
import rospy

from visualization_pkg.dashboard.main_window import DEFAULT_CONFIG, merged_config
from visualization_pkg.dashboard.qt_common import Settings

try:
    from rqt_gui_py.plugin import Plugin
    HAVE_RQT = True
except ImportError:
    Plugin = object
    HAVE_RQT = False

CONFIG_NS = '/harvest_dashboard'


def _config():
    try:
        overrides = dict((k, rospy.get_param('%s/%s' % (CONFIG_NS, k))) for k in DEFAULT_CONFIG
                         if rospy.has_param('%s/%s' % (CONFIG_NS, k)))
    except Exception:  # noqa: BLE001 - no master: defaults
        overrides = {}
    return merged_config(overrides)


def _make_image(cfg):
    from visualization_pkg.dashboard.image_panel import ImagePanel
    return ImagePanel([(t['title'], t['topic']) for t in cfg['image_topics']])


def _make_smach(cfg):
    from visualization_pkg.dashboard.smach_panel import StateMachinePanel
    return StateMachinePanel(cfg['introspection_server'])


def _make_operation(cfg):
    from visualization_pkg.dashboard.operation_panel import OperationPanel
    return OperationPanel(cfg['executive'], cfg['introspection_server'], cfg['estop_topic'], cfg['halt_service'],
                          cfg['actions'], cfg['action_timeout'], cfg['robot_yaml'])


def _make_nodes(cfg):
    from visualization_pkg.dashboard.nodes_panel import NodesPanel
    return NodesPanel(cfg['expected_nodes'], cfg['node_check_period'], cfg['critical_nodes'], cfg['respawn_timeout'])


def _make_console(cfg):
    from visualization_pkg.dashboard.console_panel import ConsolePanel
    return ConsolePanel(cfg['console_topic'])


def _make_diagnostics(cfg):
    from visualization_pkg.dashboard.diagnostics_panel import DiagnosticsPanel
    return DiagnosticsPanel(cfg['diagnostics_topic'])


def _make_reconfigure(cfg):
    from visualization_pkg.dashboard.reconfigure_panel import ReconfigurePanel
    return ReconfigurePanel(cfg['reconfigure_servers'])


def _make_mission(cfg):
    from visualization_pkg.dashboard.mission_panel import MissionPanel
    return MissionPanel()


class _PanelPlugin(Plugin):
    """One dashboard panel as an rqt plugin: start on load, settings per instance, clean shutdown."""
    factory = None

    def __init__(self, context):
        Plugin.__init__(self, context)
        self.setObjectName(self.__class__.__name__)
        self.panel = type(self).factory(_config())
        title = self.panel.title
        if context.serial_number() > 1:
            title += ' (%d)' % context.serial_number()
        self.panel.setWindowTitle(title)
        context.add_widget(self.panel)
        self.panel.start()

    def shutdown_plugin(self):
        self.panel.shutdown()

    def save_settings(self, plugin_settings, instance_settings):
        self.panel.save_settings(Settings(instance_settings))

    def restore_settings(self, plugin_settings, instance_settings):
        self.panel.restore_settings(Settings(instance_settings))


class ImagePlugin(_PanelPlugin):
    factory = staticmethod(_make_image)


class StateMachinePlugin(_PanelPlugin):
    factory = staticmethod(_make_smach)


class OperationPlugin(_PanelPlugin):
    factory = staticmethod(_make_operation)


class NodesPlugin(_PanelPlugin):
    factory = staticmethod(_make_nodes)


class ConsolePlugin(_PanelPlugin):
    factory = staticmethod(_make_console)


class DiagnosticsPlugin(_PanelPlugin):
    factory = staticmethod(_make_diagnostics)


class ReconfigurePlugin(_PanelPlugin):
    factory = staticmethod(_make_reconfigure)


class MissionPlugin(_PanelPlugin):
    factory = staticmethod(_make_mission)
