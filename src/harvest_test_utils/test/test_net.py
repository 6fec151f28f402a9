"""harvest_test_utils.net: free loopback ports and wait_for."""

import random
import socket

import pytest

from harvest_test_utils import net
from harvest_test_utils.net import (LOOPBACK, TEST_PORTS, free_port, free_port_offset,
                                     port_is_free, wait_for)


def test_free_port_can_be_listened_on():
    port = free_port()
    with socket.socket() as s:
        s.bind((LOOPBACK, port))
        s.listen(1)


def test_free_port_is_below_the_kernels_own_ports_and_the_rostests_fixed_ones():
    # a port the kernel hands out (every ROS node listens on one) or a rostest's fixed port
    # could be taken between the choice and the test server's bind (a CI failure: "address
    # already in use" for the farm server's port 44755)
    ports = [free_port() for _ in range(50)]
    assert all(port < min(net.ephemeral_low(), min(TEST_PORTS)) for port in ports)
    assert 11311 not in ports


def test_free_port_gives_a_port_once_per_process():
    # two servers of one test (a database cluster, then the farm server) before either binds
    rng = random.Random(5)
    ports = [free_port(rng=rng) for _ in range(200)]
    assert len(set(ports)) == len(ports)


def test_free_port_skips_a_port_that_is_listened_on():
    seed = 11
    first = free_port(rng=random.Random(seed))
    net._given.discard(first)
    holder = socket.socket()
    try:
        try:
            holder.bind((LOOPBACK, first))
            holder.listen(1)
        except OSError:
            pass             # taken by somebody else since: taken all the same
        second = free_port(rng=random.Random(seed))
        assert second != first
    finally:
        holder.close()


def test_ephemeral_low_reads_the_kernels_range(tmp_path):
    path = tmp_path / 'ip_local_port_range'
    path.write_text('40000\t60999\n')
    assert net.ephemeral_low(str(path)) == 40000
    assert net.ephemeral_low(str(tmp_path / 'missing')) == 32768


def test_wait_for_returns_the_first_true_value():
    values = iter([None, 0, 'ready'])
    assert wait_for(lambda: next(values), 10.0, 'a value', interval=0.0) == 'ready'


def test_wait_for_names_what_it_waited_for():
    with pytest.raises(AssertionError, match='the farm server'):
        wait_for(lambda: False, 0.0, 'the farm server', interval=0.0)


def test_port_is_free_sees_a_listening_server():
    with socket.socket() as s:
        s.bind((LOOPBACK, 0))
        s.listen(1)
        assert not port_is_free(s.getsockname()[1])
    assert port_is_free(free_port())


def test_free_port_offset_skips_an_offset_whose_ports_are_taken():
    # the seeded order's first offset is occupied by a listening server: the next one is chosen
    rng_seed = 7
    first = free_port_offset(ports=(20000,), step=100, rng=random.Random(rng_seed))
    holder = socket.socket()
    try:
        holder.bind((LOOPBACK, 20000 + first))
        holder.listen(1)
    except OSError:
        pass             # taken by somebody else since: taken all the same
    try:
        second = free_port_offset(ports=(20000,), step=100, rng=random.Random(rng_seed))
        assert second != first and second % 100 == 0
        assert port_is_free(20000 + second)
    finally:
        holder.close()


def test_free_port_offset_stays_below_the_ephemeral_range():
    offset = free_port_offset(ports=(15000, 15099, 18431), rng=random.Random(3))
    assert offset % 100 == 0 and 18431 + offset < 32768


def test_free_port_offset_fails_clearly_when_nothing_is_free():
    with pytest.raises(RuntimeError, match='no offset'):
        free_port_offset(ports=(32700,), step=100)
