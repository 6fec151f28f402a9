"""harvest_test_utils.net: free loopback ports and wait_for."""

import socket

import pytest

from harvest_test_utils.net import LOOPBACK, free_port, wait_for


def test_free_port_can_be_listened_on():
    port = free_port()
    with socket.socket() as s:
        s.bind((LOOPBACK, port))
        s.listen(1)


def test_wait_for_returns_the_first_true_value():
    values = iter([None, 0, 'ready'])
    assert wait_for(lambda: next(values), 10.0, 'a value', interval=0.0) == 'ready'


def test_wait_for_names_what_it_waited_for():
    with pytest.raises(AssertionError, match='the farm server'):
        wait_for(lambda: False, 0.0, 'the farm server', interval=0.0)
