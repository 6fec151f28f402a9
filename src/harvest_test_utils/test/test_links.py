"""links: which topics a node's bus info (getBusInfo) shows connected, each way."""

from harvest_test_utils import links

# rows as roscpp gave them (tf_echo beside a static_transform_publisher, a rosout connection)
ROWS = [
    [0, '/rosout', 'o', 'TCPROS', '/rosout', True, 'TCPROS connection on port 44581'],
    [1, 'http://vm:40219/', 'i', 'TCPROS', '/tf_static', True, 'TCPROS connection on port 53886'],
]


def test_connected_inbound_rows_only():
    assert links.inbound_topics(ROWS) == {'/tf_static'}


def test_a_connection_not_yet_made_does_not_count():
    rows = ROWS + [[2, 'http://vm:40219/', 'i', 'TCPROS', '/tf', False, '']]
    assert links.inbound_topics(rows) == {'/tf_static'}


def test_both_directions_count_and_short_rows_are_skipped():
    rows = [[3, 'http://vm:1/', 'b', 'UDPROS', '/clock', True], [4, 'x', 'i', 'TCPROS', '/odd']]
    assert links.inbound_topics(rows) == {'/clock'}
    assert links.outbound_topics(rows) == {'/clock'}


def test_outbound_rows():
    assert links.outbound_topics(ROWS) == {'/rosout'}


def test_an_action_clients_links():
    inbound, outbound = links.action_client_links(['/move_robot'])
    assert inbound == ['/move_robot/status', '/move_robot/result', '/move_robot/feedback']
    assert outbound == ['/move_robot/goal', '/move_robot/cancel']


def test_an_unknown_node_has_no_connections():
    # no master at this URI: the lookup fails, and that reads as "not connected yet"
    import os
    old = os.environ.get('ROS_MASTER_URI')
    os.environ['ROS_MASTER_URI'] = 'http://127.0.0.1:9/'
    try:
        assert links.node_bus_info('/nobody') == []
    finally:
        if old is None:
            del os.environ['ROS_MASTER_URI']
        else:
            os.environ['ROS_MASTER_URI'] = old
