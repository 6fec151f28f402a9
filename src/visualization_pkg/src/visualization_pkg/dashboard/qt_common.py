"""What every dashboard panel shares: the Panel base class, settings access, background calls.

Threading rule of the dashboard: rospy callbacks and worker threads never touch widgets; they
emit a Qt Signal, connected with Qt.QueuedConnection, and the slot runs in the GUI thread.
"""
import os
import threading
import time

import rospy
from python_qt_binding.QtCore import QObject, Qt, Signal
from python_qt_binding.QtGui import QColor
from python_qt_binding.QtWidgets import QWidget

# one palette for every panel
GREEN = QColor('#43a047')
LIGHT_GREEN = QColor('#c8e6c9')
RED = QColor('#e53935')
LIGHT_RED = QColor('#ffcdd2')
AMBER = QColor('#fb8c00')
LIGHT_AMBER = QColor('#ffe0b2')
GREY = QColor('#9e9e9e')
LIGHT_GREY = QColor('#f5f5f5')
BLUE = QColor('#1e88e5')
PURPLE = QColor('#8e24aa')


class Settings(object):
    """Typed access to rqt-style settings (`value(key, default)` / `set_value(key, value)`).

    Both qt_gui's Settings (rqt) and QSettingsGroup below have that interface; values read
    back from an ini file may come as strings, hence the coercing getters.
    """

    def __init__(self, backend):
        self.b = backend

    def set(self, key, value):
        self.b.set_value(key, value)

    def get_str(self, key, default=''):
        v = self.b.value(key, default)
        return default if v is None else str(v)

    def get_int(self, key, default=0):
        try:
            return int(self.b.value(key, default))
        except (TypeError, ValueError):
            return default

    def get_float(self, key, default=0.0):
        try:
            return float(self.b.value(key, default))
        except (TypeError, ValueError):
            return default

    def get_bool(self, key, default=False):
        v = self.b.value(key, default)
        if isinstance(v, str):
            return v.lower() in ('1', 'true', 'yes')
        return bool(v) if v is not None else default

    def get_list(self, key, default=()):
        v = self.b.value(key, None)
        if v is None:
            return list(default)
        if isinstance(v, str):
            return [v] if v else []
        return [str(x) for x in v]

    def get_bytes(self, key):
        return self.b.value(key, None)


class QSettingsGroup(object):
    """rqt's settings interface over a QSettings group (the standalone window)."""

    def __init__(self, qsettings, group):
        self.s = qsettings
        self.group = group

    def set_value(self, key, value):
        self.s.setValue('%s/%s' % (self.group, key), value)

    def value(self, key, default=None):
        return self.s.value('%s/%s' % (self.group, key), default)


class Panel(QWidget):
    """A dashboard panel: one dock of the window, or one rqt plugin.

    Subclasses create their subscriptions in start() (not in __init__, so a panel can be built
    and inspected without a ROS graph), undo them in shutdown(), and keep their own settings.
    """
    title = 'Panel'
    task_done = Signal(str, object)         # (tag, result or Exception) of run_in_background

    def __init__(self, parent=None):
        QWidget.__init__(self, parent)
        self.setObjectName(self.__class__.__name__)
        self._subs = []
        self._started = False
        self._closing = False
        self.task_done.connect(self._on_task_done, Qt.QueuedConnection)

    # --- life cycle -----------------------------------------------------------------------------
    def start(self):
        self._started = True

    def shutdown(self):
        self._closing = True
        for sub in self._subs:
            sub.unregister()
        self._subs = []

    def save_settings(self, settings):
        pass

    def restore_settings(self, settings):
        pass

    # --- helpers --------------------------------------------------------------------------------
    def subscribe(self, topic, msg_type, signal, queue_size=10, **kwargs):
        """Subscribe so that each message is emitted through `signal` (a queued connection)."""
        def forward(msg, *args):
            # holds the panel (the bound signal alone does not keep it alive); silent once closing
            if not self._closing:
                signal.emit(msg)
        sub = rospy.Subscriber(topic, msg_type, forward, queue_size=queue_size, **kwargs)
        self._subs.append(sub)
        return sub

    def run_in_background(self, tag, fn, *args):
        """Run fn(*args) in a daemon thread; its result (or exception) comes to on_task_done."""
        def work():
            try:
                result = fn(*args)
            except Exception as exc:  # noqa: BLE001 - delivered to the GUI thread as a result
                result = exc
            if not self._closing:
                self.task_done.emit(tag, result)
        thread = threading.Thread(target=work, name='dashboard-%s' % tag)
        thread.daemon = True
        thread.start()
        return thread

    def _on_task_done(self, tag, result):
        self.on_task_done(tag, result)

    def on_task_done(self, tag, result):
        pass


def ros_now():
    """ROS time in seconds (sim time when /use_sim_time is set); wall time before init_node."""
    try:
        return rospy.get_time()
    except rospy.exceptions.ROSInitException:
        return time.time()


def package_path():
    """visualization_pkg's share directory (rospkg), else the source tree next to this module."""
    try:
        import rospkg
        return rospkg.RosPack().get_path('visualization_pkg')
    except Exception:  # noqa: BLE001 - rospkg missing or ROS_PACKAGE_PATH unset: use the source tree
        return os.path.abspath(os.path.join(os.path.dirname(__file__), '..', '..', '..'))


def robot_yaml_path():
    """harvest_description's config/robot.yaml (rospkg), else beside this source tree."""
    try:
        import rospkg
        return os.path.join(rospkg.RosPack().get_path('harvest_description'), 'config',
                            'robot.yaml')
    except Exception:  # noqa: BLE001 - rospkg missing or ROS_PACKAGE_PATH unset: the source tree
        return os.path.abspath(os.path.join(os.path.dirname(__file__), '..', '..', '..', '..',
                                            'harvest_description', 'config', 'robot.yaml'))


def resource_path(name):
    return os.path.join(package_path(), 'resource', name)
