"""Whether a node under test has its subscriptions connected, from the node's own bus info.

A node that is up (its action server answers) may still lack a subscription's connection: the
master tells it of a publisher, and the node then asks that publisher for a connection over
XML-RPC. On a loaded machine this took long enough for `visual_servo_rostest`'s first four
tests to fail in the Docker image ("no transform hand_camera_optical <- left_shear_tcp ...
frames do not exist"): the servo node's tf listener had no connection yet, and its 0.5 s tf
wait was all it gave a transform. A test that needs the node to hear a topic waits for the
connection (`wait_for_inbound`) before its first goal.

Bus info (the ROS slave API's getBusInfo): one row per connection,
[connection id, destination, direction ('i' in, 'o' out, 'b' both), transport, topic,
connected, ...]; rospy and roscpp both give the connected flag.
"""

from xmlrpc.client import ServerProxy

import rosgraph

from harvest_test_utils.net import wait_for


def inbound_topics(bus_info):
    """Topics on which a node's bus info lists a connected inbound connection."""
    topics = set()
    for row in bus_info:
        if len(row) > 5 and row[2] in ('i', 'b') and row[5] is True:
            topics.add(row[4])
    return topics


def node_inbound_topics(node, caller_id='/harvest_test_utils_links'):
    """inbound_topics of a running node, asked through the master; empty while the node is
    unknown or does not answer."""
    try:
        uri = rosgraph.Master(caller_id).lookupNode(node)
        code, _msg, info = ServerProxy(uri).getBusInfo(caller_id)
    except (rosgraph.MasterError, OSError):
        return set()
    return inbound_topics(info) if code == 1 else set()


def wait_for_inbound(node, topics, timeout=60.0):
    """Wait (wall time, like net.wait_for) until `node` has a connected inbound connection on
    every one of `topics` (resolved names); AssertionError naming the missing ones after
    `timeout` s."""
    wanted = set(topics)
    missing = [sorted(wanted)]

    def connected():
        missing[0] = sorted(wanted - node_inbound_topics(node))
        return not missing[0]

    try:
        wait_for(connected, timeout, 'the connections of %s' % node, interval=0.1)
    except AssertionError:
        raise AssertionError('%s has no connection on %s after %.0f s'
                             % (node, ', '.join(missing[0]), timeout))
