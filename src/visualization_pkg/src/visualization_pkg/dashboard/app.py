"""Standalone dashboard: node `harvest_dashboard`, one QApplication, one DashboardWindow.

Private params: everything of config/dashboard.yaml (see main_window.DEFAULT_CONFIG), plus
  ~settings_file  ini file for window layout and panel settings ('' = the user's QSettings)
  ~restore        restore the saved layout (default true)
  ~geometry       'WxH' initial size when nothing is restored (default 1600x1000)
"""
import signal
import sys
import traceback

import rospy
from python_qt_binding.QtCore import QSettings, QTimer
from python_qt_binding.QtWidgets import QApplication

from visualization_pkg.dashboard.main_window import DEFAULT_CONFIG, DashboardWindow


def log_exception(kind, value, tb):
    """An exception in a Qt slot: log it and keep the window (PyQt5 would abort without a hook)."""
    rospy.logerr('dashboard: %s', ''.join(traceback.format_exception(kind, value, tb)))


def read_config():
    return dict((key, rospy.get_param('~' + key)) for key in DEFAULT_CONFIG if rospy.has_param('~' + key))


def make_settings(path):
    return QSettings(path, QSettings.IniFormat) if path else QSettings('harvest', 'harvest_dashboard')


class DashboardApp(object):
    """The node: builds the window, wires Ctrl-C and rospy shutdown to a clean close."""

    def __init__(self, argv):
        sys.excepthook = log_exception
        self.app = QApplication.instance() or QApplication(argv)
        self.app.setApplicationName('harvest_dashboard')
        self.window = DashboardWindow(read_config(), make_settings(rospy.get_param('~settings_file', '')))
        width, _, height = str(rospy.get_param('~geometry', '1600x1000')).partition('x')
        self.window.resize(int(width), int(height))
        if rospy.get_param('~restore', True):
            self.window.restore_settings()
        # rospy shutdown -> close the window in the GUI thread; Ctrl-C -> the same
        rospy.on_shutdown(self.window.quit_requested.emit)
        signal.signal(signal.SIGINT, lambda *_: self.window.quit_requested.emit())
        self._wake = QTimer()
        self._wake.timeout.connect(lambda: None)    # lets Python run signal handlers
        self._wake.start(200)
        self.app.lastWindowClosed.connect(self.app.quit)

    def run(self):
        self.window.start()
        self.window.show()
        code = self.app.exec_()
        self.window.shutdown()
        rospy.signal_shutdown('dashboard closed')
        return code


def main(argv=None):
    argv = rospy.myargv(argv if argv is not None else sys.argv)
    rospy.init_node('harvest_dashboard', disable_signals=True)
    return DashboardApp(argv).run()
