"""RViz panel (the paper's RViz module): rviz embedded as a dock through rviz's Python bindings.

Optional and lazy: the window builds it only when the `embedded_rviz` parameter is true, so
offscreen tests and rqt need no OpenGL context. Before embedding, `embed_blocker` rules out what
makes rviz abort the whole process (an uncatchable C++ abort when OGRE gets no display: the
offscreen/minimal Qt platforms, no DISPLAY), and `probe` initialises a VisualizationFrame in a child
process first. When embedding is not possible the window logs one line and, when a display
exists, starts rviz in its own window instead (`rosrun rviz rviz -d <config>`, stopped with the
dashboard).
"""
import os
import shutil
import subprocess
import sys

import rospy
from python_qt_binding.QtWidgets import QLabel, QVBoxLayout

from visualization_pkg.dashboard.qt_common import Panel, package_path

HEADLESS_PLATFORMS = ('offscreen', 'minimal', 'vnc')

_PROBE = '''
import sys
from python_qt_binding.QtWidgets import QApplication
app = QApplication(['rviz_probe'])
from rviz import bindings as rviz
frame = rviz.VisualizationFrame()
frame.setSplashPath('')
frame.initialize()
sys.stdout.write('rviz ok\\n')
'''


def default_config_path():
    return os.path.join(package_path(), 'rviz', 'harvest.rviz')


def embed_blocker(platform, env):
    """Why rviz cannot be embedded in this process ('' = try): the Qt platform and the display."""
    if platform in HEADLESS_PLATFORMS:
        return 'Qt platform %s has no OpenGL window' % platform
    if platform == 'xcb' and not env.get('DISPLAY'):
        return 'no DISPLAY'
    if platform.startswith('wayland') and not env.get('WAYLAND_DISPLAY'):
        return 'no WAYLAND_DISPLAY'
    return ''


def window_blocker(env, which=shutil.which):
    """Why rviz cannot run in its own window ('' = it can)."""
    if not env.get('DISPLAY') and not env.get('WAYLAND_DISPLAY'):
        return 'no display'
    if not which('rosrun'):
        return 'rosrun not found'
    return ''


def bindings_error():
    """'' when rviz's Python bindings import, else the reason."""
    try:
        from rviz import bindings  # noqa: F401
    except Exception as exc:  # noqa: BLE001 - ImportError, or a sip/shiboken mismatch
        return 'rviz Python bindings unavailable: %s' % exc
    return ''


def probe(timeout=30.0):
    """Initialise a VisualizationFrame in a child process: '' when it works, else why not."""
    try:
        out = subprocess.run([sys.executable, '-c', _PROBE], stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                             timeout=timeout, check=False)
    except (OSError, subprocess.TimeoutExpired) as exc:
        return 'rviz probe failed: %s' % exc
    if out.returncode == 0 and b'rviz ok' in out.stdout:
        return ''
    tail = out.stderr.decode('utf-8', 'replace').strip().splitlines()[-1:] or ['exit %d' % out.returncode]
    return 'rviz cannot initialise here (%s)' % tail[0]


class RvizPanel(Panel):
    """The rviz VisualizationFrame in a dock; the frame is created and loaded in start()."""
    title = 'RViz'

    def __init__(self, config_path='', parent=None):
        Panel.__init__(self, parent)
        self.config_path = config_path or default_config_path()
        self.frame = None
        self.placeholder = QLabel('rviz starts with the dashboard (%s)' % self.config_path)
        self._layout = QVBoxLayout(self)
        self._layout.setContentsMargins(0, 0, 0, 0)
        self._layout.addWidget(self.placeholder)

    def start(self):
        Panel.start(self)
        from rviz import bindings as rviz
        frame = rviz.VisualizationFrame()
        frame.setSplashPath('')
        frame.initialize()
        reader = rviz.YamlConfigReader()
        config = rviz.Config()
        reader.readFile(config, self.config_path)
        frame.load(config)
        frame.menuBar().hide()      # not setMenuBar(None): rviz's destructor uses its menu bar
        frame.setStatusBar(None)
        frame.setHideButtonVisibility(False)
        self._layout.removeWidget(self.placeholder)
        self.placeholder.hide()
        self._layout.addWidget(frame)
        self.frame = frame

    def shutdown(self):
        Panel.shutdown(self)
        if self.frame is not None:
            self.frame.close()


def make_rviz(config_path, platform, env=None, probe_fn=probe):
    """(RvizPanel or None, the log line when not embedded). Called only when embedded_rviz is on."""
    env = os.environ if env is None else env
    reason = embed_blocker(platform, env) or bindings_error() or probe_fn()
    if not reason:
        return RvizPanel(config_path), ''
    return None, reason


def fallback_line(reason, window_reason):
    if window_reason:
        return 'dashboard: rviz not embedded (%s); rviz cannot run here (%s)' % (reason, window_reason)
    return 'dashboard: rviz not embedded (%s); starting rviz in its own window' % reason


def start_rviz_window(config_path, parent):
    """rviz in its own window, as a QProcess child of `parent` (stopped with the dashboard)."""
    from python_qt_binding.QtCore import QProcess
    proc = QProcess(parent)
    proc.start('rosrun', ['rviz', 'rviz', '-d', config_path or default_config_path()])
    rospy.logdebug('dashboard: rviz window process started')
    return proc
