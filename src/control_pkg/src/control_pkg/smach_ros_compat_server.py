"""The fallback SimpleActionState's wait for its action server (smach_ros_compat_action.py).

`ServerWait`, a base class of SimpleActionState: the wait for the server in the background from
construction, and the wait of `execute` for it (the state's one Condition, woken by the end of
that wait, a preempt and rospy shutdown; nothing sleep-polls).

While it waits for its server it hands its node the master's current publishers of the
action's topics every `RECONNECT_PERIOD` (ROS time): rospy keeps only the newest of several
pending publisher updates of a topic, so when a server registers while the client's own
registration is answered, the client may keep the empty list and never connect to it (seen
once in some 500 whole-mission runs: `self_test/feedback` never connected, and the mission
aborted at DO_START with the server up). Connected publishers are left as they are.

`server_connected`: whether the server of a running goal is still connected to its goal topic
(SimpleActionState checks it every `SERVER_CHECK_PERIOD`, ROS time: a lost server aborts it).
Re-exported by control_pkg.smach_ros_compat_action.
"""
import threading
import traceback
from xmlrpc.client import ServerProxy

import rosgraph
import rospy

#: while waiting for a server, the node is told the master's publishers this often (ROS time)
RECONNECT_PERIOD = rospy.Duration(1.0)
_ACTION_TOPICS = ('status', 'result', 'feedback')

#: while a goal runs, whether its server is still connected is checked this often (ROS time)
SERVER_CHECK_PERIOD = rospy.Duration(0.5)


def server_connected(client):
    """True/False: the action server that last sent `client` a status is connected to its goal
    topic; None when that cannot be told (no status yet)."""
    status = getattr(client, 'last_status_msg', None)
    header = getattr(status, '_connection_header', None) or {}
    server_id = header.get('callerid')
    if not server_id:
        return None
    return bool(client.pub_goal.impl.has_connection(server_id))


def server_links(client):
    """The goal topic's connections (rospy transports) to the action server that last sent
    `client` a status: a frozenset, empty when there is none or no status yet. A respawned
    server (same node name) comes back on a new connection: a goal sent on links of which none
    is left went to a server that is gone."""
    status = getattr(client, 'last_status_msg', None)
    header = getattr(status, '_connection_header', None) or {}
    server_id = header.get('callerid')
    if not server_id:
        return frozenset()
    return frozenset(c for c in list(client.pub_goal.impl.connections)
                     if getattr(c, 'endpoint_id', None) == server_id)


def resend_publishers(namespace, names):
    """Tell this node the master's current publishers of `namespace`/name for each name, as
    the master's publisherUpdate does; rospy connects the ones it is not connected to yet.
    Errors (a master or node going away) are left to the next attempt."""
    try:
        caller_id = rospy.get_caller_id()
        master = rosgraph.Master(caller_id)
        publishers, _, _ = master.getSystemState()
        node = ServerProxy(rospy.get_node_uri())
        for name in names:
            topic = rospy.resolve_name('%s/%s' % (namespace, name))
            nodes = next((n for t, n in publishers if t == topic), [])
            uris = [master.lookupNode(n) for n in nodes]
            if uris:
                node.publisherUpdate('/master', topic, uris)
    except Exception as exc:  # noqa: BLE001 - socket, XML-RPC and master errors alike
        rospy.logdebug('resend_publishers(%s): %s', namespace, exc)


class ServerWait(object):
    """SimpleActionState's wait for its server. Uses the state's `_cond`, `_server_ready`,
    `_server_wait_running`, `_server_wait_timeout`, `_client` and `_action_name` (set by its
    constructor) and its `preempt_requested`."""

    def _wake(self):
        with self._cond:
            self._cond.notify_all()

    def _start_server_wait(self):
        with self._cond:
            if self._server_ready or self._server_wait_running:
                return
            self._server_wait_running = True
        thread = threading.Thread(name=self._action_name + '/wait_for_server',
                                  target=self._wait_for_server)
        thread.daemon = True
        thread.start()

    def _wait_for_server(self):
        timeout = self._server_wait_timeout
        ready = False
        try:
            deadline = None
            while not ready and not rospy.is_shutdown():
                now = rospy.get_rostime()
                if deadline is None and not now.is_zero() and timeout:
                    deadline = now + timeout        # ROS time runs (sim time may start late)
                if deadline is not None and now >= deadline:
                    break
                step = RECONNECT_PERIOD if deadline is None else min(RECONNECT_PERIOD,
                                                                     deadline - now)
                ready = self._client.wait_for_server(step)
                if not ready and not rospy.is_shutdown():
                    resend_publishers(self._client.ns, _ACTION_TOPICS)
        except Exception:  # rospy raises here when shutting down
            if not rospy.is_shutdown():
                rospy.logerr("Waiting for action server '%s' failed: %s"
                             % (self._action_name, traceback.format_exc()))
        with self._cond:
            self._server_ready = self._server_ready or bool(ready)
            self._server_wait_running = False
            self._cond.notify_all()

    def _connect(self):
        """Block until the server is up (True), or it timed out / preempt / shutdown."""
        with self._cond:
            ready = self._server_ready
        if ready:
            return True
        rospy.logwarn("Action state '%s' still waiting for its action server"
                      % self._action_name)
        self._start_server_wait()
        with self._cond:
            while not (self._server_ready or not self._server_wait_running
                       or self.preempt_requested() or rospy.is_shutdown()):
                self._cond.wait()
            ready = self._server_ready
        if ready:
            rospy.loginfo("Action state '%s' connected to its server" % self._action_name)
        return ready and not self.preempt_requested()
