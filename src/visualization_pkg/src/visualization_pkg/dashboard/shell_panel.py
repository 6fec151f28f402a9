"""Shell panel (the paper's shell module): a local interactive bash in the workspace's environment.

OFF unless the dashboard's `enable_shell` parameter is true (the window creates this panel only
then). The shell is a QProcess child of the dashboard: `bash --rcfile <rc> -i`, the rc sourcing
the user's ~/.bashrc and the workspace's devel/setup.bash. Commands come from the line edit
(history on Up/Down); stdout is shown in black, stderr in red; Ctrl-C (button or key in the line
edit) sends SIGINT to the shell's descendants, i.e. the running command. It opens no socket and
listens on nothing: it is reachable only through this window's keyboard.
"""
import os
import tempfile

import rospy
from python_qt_binding.QtCore import QEvent, QProcess, Qt
from python_qt_binding.QtGui import QColor, QFont, QTextCursor
from python_qt_binding.QtWidgets import QHBoxLayout, QLineEdit, QPlainTextEdit, QPushButton, QVBoxLayout

from visualization_pkg.dashboard import shell_session
from visualization_pkg.dashboard.qt_common import Panel, package_path

STDOUT_COLOUR = '#000000'
STDERR_COLOUR = '#c62828'
ECHO_COLOUR = '#1565c0'
MAX_BLOCKS = 5000


def workspace_setup_files():
    """devel/setup.bash of the workspace this package runs from (ROS_PACKAGE_PATH's catkin devel)."""
    found = []
    for prefix in os.environ.get('CMAKE_PREFIX_PATH', '').split(os.pathsep):
        setup = os.path.join(prefix, 'setup.bash')
        if prefix and os.path.isfile(setup) and not prefix.startswith('/opt/ros'):
            found.append(setup)
            break
    if not found:
        guess = os.path.abspath(os.path.join(package_path(), '..', '..', 'devel', 'setup.bash'))
        if os.path.isfile(guess):
            found.append(guess)
    return found


class ShellPanel(Panel):
    title = 'Shell'

    def __init__(self, setup_files=None, working_dir='', parent=None):
        Panel.__init__(self, parent)
        self.setup_files = workspace_setup_files() if setup_files is None else list(setup_files)
        self.working_dir = working_dir or os.path.expanduser('~')
        self.history = shell_session.CommandHistory()
        self.process = None
        self._rc = None
        font = QFont('Monospace')
        font.setStyleHint(QFont.TypeWriter)
        self.output = QPlainTextEdit()
        self.output.setReadOnly(True)
        self.output.setFont(font)
        self.output.setMaximumBlockCount(MAX_BLOCKS)
        self.line = QLineEdit()
        self.line.setFont(font)
        self.line.setPlaceholderText('command (Enter runs it, Up/Down history, Ctrl-C interrupts)')
        self.line.returnPressed.connect(self.run_line)
        self.line.installEventFilter(self)
        self.interrupt_button = QPushButton('Ctrl-C')
        self.interrupt_button.setToolTip('Send SIGINT to the running command')
        self.interrupt_button.clicked.connect(self.interrupt)
        self.restart_button = QPushButton('Restart shell')
        self.restart_button.clicked.connect(self.restart_shell)
        row = QHBoxLayout()
        row.addWidget(self.line, 1)
        row.addWidget(self.interrupt_button)
        row.addWidget(self.restart_button)
        layout = QVBoxLayout(self)
        layout.setContentsMargins(4, 4, 4, 4)
        layout.addWidget(self.output, 1)
        layout.addLayout(row)

    # --- life cycle -------------------------------------------------------------------------------
    def start(self):
        Panel.start(self)
        self.start_shell()

    def start_shell(self):
        if self.process is not None and self.process.state() != QProcess.NotRunning:
            return
        fd, self._rc = tempfile.mkstemp(prefix='harvest_dashboard_', suffix='.bashrc')
        with os.fdopen(fd, 'w') as f:
            f.write(shell_session.rc_text(self.setup_files))
        self.process = QProcess(self)
        self.process.setProcessChannelMode(QProcess.SeparateChannels)
        self.process.setWorkingDirectory(self.working_dir)
        self.process.readyReadStandardOutput.connect(self._read_stdout)
        self.process.readyReadStandardError.connect(self._read_stderr)
        self.process.finished.connect(self._finished)
        with shell_session.DefaultSigintForChildren():         # so that Ctrl-C reaches commands
            self.process.start('bash', ['--rcfile', self._rc, '-i'])
            started = self.process.waitForStarted(5000)
        if not started:
            self.append('bash did not start: %s' % self.process.errorString(), STDERR_COLOUR)
            return
        self.append('shell started: bash -i (%s)' % (', '.join(self.setup_files) or 'no workspace setup found'),
                    ECHO_COLOUR)

    def restart_shell(self):
        self.stop_shell()
        self.start_shell()

    def stop_shell(self):
        proc, self.process = self.process, None
        if proc is not None and proc.state() != QProcess.NotRunning:
            shell_session.interrupt(int(proc.processId()))
            proc.finished.disconnect(self._finished)
            proc.terminate()
            if not proc.waitForFinished(2000):
                proc.kill()
                proc.waitForFinished(2000)
        if self._rc:
            try:
                os.unlink(self._rc)
            except OSError:
                pass
            self._rc = None

    def shutdown(self):
        self.stop_shell()
        Panel.shutdown(self)

    # --- input ------------------------------------------------------------------------------------
    def eventFilter(self, obj, event):
        if obj is self.line and event.type() == QEvent.KeyPress:
            key = event.key()
            if key == Qt.Key_Up:
                self.line.setText(self.history.up(self.line.text()))
                return True
            if key == Qt.Key_Down:
                self.line.setText(self.history.down(self.line.text()))
                return True
            if key == Qt.Key_C and event.modifiers() & Qt.ControlModifier and not self.line.hasSelectedText():
                self.interrupt()
                return True
        return Panel.eventFilter(self, obj, event)

    def run_line(self):
        line = self.line.text()
        self.line.clear()
        self.run(line)

    def run(self, command):
        """Send one command line to the shell."""
        self.history.add(command)
        if self.process is None or self.process.state() != QProcess.Running:
            self.append('shell not running (Restart shell)', STDERR_COLOUR)
            return False
        self.append('$ ' + command, ECHO_COLOUR)
        self.process.write((command + '\n').encode('utf-8'))
        return True

    def interrupt(self):
        """Ctrl-C: SIGINT to what the shell runs. Returns the pids signalled."""
        if self.process is None or self.process.state() != QProcess.Running:
            return []
        sent = shell_session.interrupt(int(self.process.processId()))
        self.append('^C' if sent else '^C (nothing running)', ECHO_COLOUR)
        return sent

    # --- output -----------------------------------------------------------------------------------
    def _read_stdout(self):
        if self.process is not None:
            self.append(bytes(self.process.readAllStandardOutput()).decode('utf-8', 'replace'), STDOUT_COLOUR)

    def _read_stderr(self):
        if self.process is not None:
            self.append(bytes(self.process.readAllStandardError()).decode('utf-8', 'replace'), STDERR_COLOUR)

    def _finished(self, code, _status=None):
        self.append('shell exited (%s); Restart shell to start another' % code, STDERR_COLOUR)
        rospy.loginfo('dashboard: shell exited (%s)', code)

    def append(self, text, colour):
        text = text.rstrip('\n')
        if not text:
            return
        cursor = self.output.textCursor()
        cursor.movePosition(QTextCursor.End)
        fmt = cursor.charFormat()
        fmt.setForeground(QColor(colour))
        cursor.setCharFormat(fmt)
        if not self.output.document().isEmpty():
            cursor.insertText('\n')
        cursor.insertText(text)
        self.output.setTextCursor(cursor)
        self.output.ensureCursorVisible()

    # --- for tests --------------------------------------------------------------------------------
    def text_in(self, colour):
        """Every piece of output shown in `colour` (a '#rrggbb' name), joined by newlines."""
        out = []
        block = self.output.document().begin()
        while block.isValid():
            it = block.begin()
            while not it.atEnd():
                frag = it.fragment()
                if frag.isValid() and frag.charFormat().foreground().color().name() == colour:
                    out.append(frag.text())
                it += 1
            block = block.next()
        return '\n'.join(out)

    def save_settings(self, s):
        s.set('history', self.history.items[-100:])

    def restore_settings(self, s):
        for line in s.get_list('history', []):
            self.history.add(line)
