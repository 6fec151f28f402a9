"""A virtual X display (Xvfb) for tests and tools that start GUI programs (rviz, screenshots).

- `-noreset`: an X server resets itself whenever its last client leaves, and a client that
  connects during the reset is refused. visualization_pkg's rviz test polls the window list
  with `xwininfo` while rviz starts: an `xwininfo` leaving as rviz connected made Qt abort
  ("could not connect to display", SIGABRT; a CI failure). Two clients, one connecting as the
  other leaves: 8 of 300 refused without it, 0 of 300 with it (this machine, two CPU hogs).
- `-displayfd`: Xvfb takes the first display number it can listen on and reports it on a pipe
  once it accepts clients: no race between choosing a number and another X server taking it,
  and no wait for a socket file.
"""

import os
import select
import shutil
import subprocess
import time


class XvfbError(RuntimeError):
    """Xvfb is missing, exited, or did not report a display in time."""


def start_xvfb(screen='1600x1000x24', timeout=30.0, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
               **popen_kw):
    """Start Xvfb; return (process, display) once it accepts clients, display as ':N'.

    `screen` is Xvfb's WIDTHxHEIGHTxDEPTH of screen 0. Raises XvfbError (the process is stopped)
    when Xvfb is not installed, exits, or reports nothing within `timeout` seconds (wall time:
    a helper outside ROS). The caller terminates the process."""
    if shutil.which('Xvfb') is None:
        raise XvfbError('Xvfb is not installed (Debian package xvfb)')
    read_fd, write_fd = os.pipe()
    try:
        proc = subprocess.Popen(['Xvfb', '-displayfd', str(write_fd), '-screen', '0', screen, '-nolisten', 'tcp',
                                 '-noreset'],
                                pass_fds=(write_fd,), stdout=stdout, stderr=stderr, **popen_kw)
    except OSError:
        os.close(read_fd)
        raise
    finally:
        os.close(write_fd)
    try:
        text = _read_line(read_fd, timeout)
    except XvfbError as e:
        stop_process(proc)
        raise XvfbError('%s (exit code %s)' % (e, proc.poll()))
    finally:
        os.close(read_fd)
    if not text.strip().isdigit():
        stop_process(proc)
        raise XvfbError('Xvfb reported %r, not a display number' % text)
    return proc, ':' + text.strip()


def _read_line(fd, timeout):
    """The first newline-terminated line written to fd, within timeout seconds."""
    deadline = time.monotonic() + timeout
    data = b''
    while not data.endswith(b'\n'):
        left = deadline - time.monotonic()
        if left <= 0:
            raise XvfbError('Xvfb reported no display within %.0f s' % timeout)
        ready, _, _ = select.select([fd], [], [], left)
        if not ready:
            continue
        chunk = os.read(fd, 64)
        if not chunk:
            raise XvfbError('Xvfb exited before it reported a display')
        data += chunk
    return data.decode('ascii', 'replace')


def stop_process(proc, timeout=10.0):
    """Terminate a process, kill it if it is still there after `timeout` seconds."""
    if proc.poll() is not None:
        return
    proc.terminate()
    try:
        proc.wait(timeout)
    except subprocess.TimeoutExpired:
        proc.kill()
        proc.wait(5)
