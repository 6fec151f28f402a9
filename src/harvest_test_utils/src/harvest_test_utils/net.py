"""Free loopback ports and waiting for a condition, for tests that start servers."""

import socket
import time

LOOPBACK = '127.0.0.1'


def free_port(host=LOOPBACK):
    """A TCP port nobody listens on right now (the kernel's choice; free when returned)."""
    with socket.socket() as s:
        s.bind((host, 0))
        return s.getsockname()[1]


def wait_for(predicate, timeout, what, interval=0.05):
    """Poll ``predicate`` until it returns something true and return that value; after
    ``timeout`` wall seconds raise AssertionError naming ``what``.

    For test harnesses outside ROS (a child process such as the farm server, before or without
    a master): wall time on purpose, never used by a node."""
    deadline = time.monotonic() + timeout
    while True:
        value = predicate()
        if value:
            return value
        if time.monotonic() > deadline:
            raise AssertionError('timed out after %.0f s waiting for %s' % (timeout, what))
        time.sleep(interval)
