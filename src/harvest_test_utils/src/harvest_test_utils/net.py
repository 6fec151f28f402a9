"""Free loopback ports and waiting for a condition, for tests that start servers."""

import random
import socket
import time

LOOPBACK = '127.0.0.1'

#: the fixed ports of the rostest files (simulated controllers, the farm server), to which
#: HARVEST_TEST_PORT_OFFSET is added (`$(eval N + int(optenv('HARVEST_TEST_PORT_OFFSET', '0')))`)
TEST_PORTS = tuple(range(15000, 15100)) + (18431,)

#: where free_port looks: below the rostests' fixed ports (TEST_PORTS and their offsets fill
#: 15000-32767) and so below the kernel's ephemeral range, skipping a default ROS master
FREE_PORT_RANGE = (10000, min(TEST_PORTS))
_SKIPPED = frozenset([11311])
_given = set()


def ephemeral_low(path='/proc/sys/net/ipv4/ip_local_port_range'):
    """The lowest port the kernel hands out by itself (bind to port 0, outgoing connections)."""
    try:
        with open(path) as f:
            return int(f.read().split()[0])
    except (OSError, ValueError, IndexError):
        return 32768


def free_port(host=LOOPBACK, rng=None):
    """A TCP port nobody listens on right now, for a server a test starts.

    Chosen at random in FREE_PORT_RANGE, outside the kernel's ephemeral range: between this
    call and the server's bind, no ROS node of a test running beside (they all listen on port
    0, the kernel's choice) nor an outgoing connection can take it, and it is never one of
    the rostests' fixed ports. A port is given at most once per process. Falls back to the
    kernel's choice when the range is taken or overlaps the ephemeral range."""
    rng = rng or random.SystemRandom()
    low, high = FREE_PORT_RANGE
    high = min(high, ephemeral_low())
    for _ in range(200 if high > low else 0):
        port = rng.randrange(low, high)
        if port in _SKIPPED or port in _given or not port_is_free(port, host):
            continue
        _given.add(port)
        return port
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



def port_is_free(port, host=LOOPBACK):
    """True when a TCP server could listen on ``port`` now."""
    with socket.socket() as s:
        try:
            s.bind((host, port))
        except OSError:
            return False
        return True


def free_port_offset(ports=TEST_PORTS, step=100, limit=400, rng=None):
    """A multiple of ``step`` that, added to each of ``ports``, gives only free ports and stays
    below the ephemeral range (32768): one per test suite, so two suites run side by side.
    Raises RuntimeError when none of ``limit`` tries is free."""
    rng = rng or random.Random()
    highest = max(ports)
    choices = [k * step for k in range(0, (32768 - highest) // step)]
    rng.shuffle(choices)
    for offset in choices[:limit]:
        if all(port_is_free(p + offset) for p in ports):
            return offset
    raise RuntimeError('no offset of %d-%d with every test port free' % (min(ports), highest))
