"""The shell module's logic (no rospy, no Qt): command history, the shell's rc file, and which
processes Ctrl-C interrupts.

The shell is a local `bash -i` child of the dashboard (QProcess pipes, no terminal, no socket).
Without a terminal bash has no job control, so its commands run in its own process group; Ctrl-C
sends SIGINT to the shell's descendants (found through /proc), never to the shell itself.
"""
import os
import signal


class CommandHistory(object):
    """Up/Down history of a line edit: up() goes back, down() forward, past the end = draft."""

    def __init__(self, limit=500):
        self.limit = limit
        self.items = []
        self.pos = 0
        self.draft = ''

    def add(self, line):
        if line.strip() and (not self.items or self.items[-1] != line):
            self.items.append(line)
            del self.items[:-self.limit]
        self.pos = len(self.items)
        self.draft = ''

    def up(self, current):
        if self.pos == len(self.items):
            self.draft = current
        if self.pos > 0:
            self.pos -= 1
        return self.items[self.pos] if self.items else current

    def down(self, current):
        if self.pos < len(self.items):
            self.pos += 1
        return self.draft if self.pos == len(self.items) else self.items[self.pos]


def rc_text(setup_files):
    """bash --rcfile contents: the user's ~/.bashrc when present, then the workspace's setup files."""
    lines = ['[ -f ~/.bashrc ] && . ~/.bashrc', 'PS1=""', 'PS2=""']
    for path in setup_files:
        lines.append('[ -f %s ] && . %s' % (_quote(path), _quote(path)))
    lines.append('PS1=""')
    return '\n'.join(lines) + '\n'


def _quote(path):
    return "'" + path.replace("'", "'\\''") + "'"


def parent_map(proc='/proc'):
    """{pid: parent pid} of every process visible in /proc."""
    out = {}
    try:
        entries = os.listdir(proc)
    except OSError:
        return out
    for entry in entries:
        if not entry.isdigit():
            continue
        try:
            with open(os.path.join(proc, entry, 'stat'), 'rb') as f:
                raw = f.read()
            out[int(entry)] = int(raw[raw.rindex(b')') + 2:].split()[1])
        except (OSError, ValueError, IndexError):
            continue
    return out


def descendants(pid, parents):
    """Every process below `pid` (children first, then theirs), from a {pid: ppid} map."""
    children = {}
    for child, parent in parents.items():
        children.setdefault(parent, []).append(child)
    out, todo = [], [pid]
    while todo:
        for child in sorted(children.get(todo.pop(0), [])):
            out.append(child)
            todo.append(child)
    return out


def interrupt(shell_pid, parents=None, kill=os.kill, sig=signal.SIGINT):
    """Send SIGINT to the shell's descendants (its foreground command and what that started).
    Returns the pids signalled (empty: the shell was idle)."""
    sent = []
    for pid in descendants(shell_pid, parent_map() if parents is None else parents):
        try:
            kill(pid, sig)
            sent.append(pid)
        except OSError:
            continue
    return sent


class DefaultSigintForChildren(object):
    """Context manager: processes started inside it get SIGINT's default action even when this
    process ignores SIGINT (a background job of a non-interactive shell, as under `make`, starts
    with SIGINT ignored, and an ignored signal stays ignored across fork and exec, so a Ctrl-C
    to the shell's command or a roslaunch stop would do nothing). Meanwhile this process catches
    SIGINT with a handler that does nothing, so it is not ended either; a handled signal goes
    back to its default action in a child at exec. Only in the main thread (Python's rule for
    signal handlers); elsewhere it changes nothing."""

    def __enter__(self):
        self._old = None
        try:
            if signal.getsignal(signal.SIGINT) is signal.SIG_IGN:
                self._old = signal.signal(signal.SIGINT, _ignore_sigint)
        except ValueError:                      # not the main thread
            self._old = None
        return self

    def __exit__(self, *exc):
        if self._old is not None:
            signal.signal(signal.SIGINT, self._old)
        return False


def _ignore_sigint(signum, frame):
    """SIGINT caught and dropped while children are started (see DefaultSigintForChildren)."""
