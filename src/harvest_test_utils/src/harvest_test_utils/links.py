"""Whether a node under test has its subscriptions connected, from the node's own bus info.

A node that is up (its action server answers) may still lack a subscription's connection: the
master tells it of a publisher, and the node then asks that publisher for a connection over
XML-RPC. On a loaded machine this took long enough for `visual_servo_rostest`'s first four
tests to fail in the Docker image ("no transform hand_camera_optical <- left_shear_tcp ...
frames do not exist"): the servo node's tf listener had no connection yet, and its 0.5 s tf
wait was all it gave a transform. A test that needs the node to hear a topic waits for the
connection (`wait_for_links`) before its first goal. The same test once failed its first goal
under two CPU hogs with "action server 'move_robot' is not available": the node's actionlib
clients wait 5 s of its 5x sim time, one wall second, for their servers' connections; it also
waits for those (`action_client_links`).

Bus info (the ROS slave API's getBusInfo): one row per connection,
[connection id, destination, direction ('i' in, 'o' out, 'b' both), transport, topic,
connected, ...]; rospy and roscpp both give the connected flag.
"""

from xmlrpc.client import ServerProxy

import rosgraph

from harvest_test_utils.net import wait_for


def connected_topics(bus_info, direction):
    """Topics on which a node's bus info lists a connected connection in `direction`: 'i'
    (the node subscribes) or 'o' (it publishes); a row marked 'b' counts for both."""
    topics = set()
    for row in bus_info:
        if len(row) > 5 and row[2] in (direction, 'b') and row[5] is True:
            topics.add(row[4])
    return topics


def inbound_topics(bus_info):
    """Topics on which a node's bus info lists a connected inbound connection."""
    return connected_topics(bus_info, 'i')


def outbound_topics(bus_info):
    """Topics on which a node's bus info lists a connected outbound connection (a subscriber
    of the node's publisher)."""
    return connected_topics(bus_info, 'o')


def node_bus_info(node, caller_id='/harvest_test_utils_links'):
    """A running node's bus info rows, asked through the master; empty while the node is
    unknown or does not answer."""
    try:
        uri = rosgraph.Master(caller_id).lookupNode(node)
        code, _msg, info = ServerProxy(uri).getBusInfo(caller_id)
    except (rosgraph.MasterError, OSError):
        return []
    return info if code == 1 else []


def action_client_links(actions):
    """(inbound, outbound) topics of an actionlib client of each action (resolved names): it
    subscribes to status, result and feedback, and its goal and cancel need the server's
    subscription."""
    inbound = ['%s/%s' % (a, t) for a in actions for t in ('status', 'result', 'feedback')]
    outbound = ['%s/%s' % (a, t) for a in actions for t in ('goal', 'cancel')]
    return inbound, outbound


def wait_for_links(node, inbound=(), outbound=(), timeout=60.0):
    """Wait (wall time, like net.wait_for) until `node` has a connected connection on every
    topic of `inbound` (it subscribes) and `outbound` (it publishes; someone subscribes);
    resolved names. AssertionError naming the missing ones after `timeout` s."""
    wanted_in, wanted_out = set(inbound), set(outbound)
    missing = [sorted(wanted_in | wanted_out)]

    def connected():
        info = node_bus_info(node)
        missing[0] = sorted((wanted_in - inbound_topics(info)) |
                            (wanted_out - outbound_topics(info)))
        return not missing[0]

    try:
        wait_for(connected, timeout, 'the connections of %s' % node, interval=0.1)
    except AssertionError:
        raise AssertionError('%s has no connection on %s after %.0f s'
                             % (node, ', '.join(missing[0]), timeout))

