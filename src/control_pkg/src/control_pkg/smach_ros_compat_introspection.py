"""IntrospectionServer for hosts without smach_ros (see control_pkg.smach_compat).

Speaks the smach_ros 2.5 (Noetic) introspection protocol, so smach_viewer and other smach_ros
tools work unchanged. Written anew for this workspace.

Topics (relative to server_name):
    <server_name>/smach/container_structure  smach_msgs/SmachContainerStructure  (out)
    <server_name>/smach/container_status     smach_msgs/SmachContainerStatus     (out)
    <server_name>/smach/container_init       smach_msgs/SmachContainerInitialStatusCmd (in)

Content conventions (as smach_ros):
    - one structure and one status message per container in the tree, the root at `path`
      (e.g. /SM_ROOT) and each nested container at <parent path>/<label> (a root path of
      '/' gives /<label>);
    - structure: children = child labels; internal_outcomes/outcomes_from/outcomes_to = the
      container's get_internal_edges(), one index per edge; container_outcomes = its
      registered outcomes;
    - status: initial_states and active_states as the container reports them (an idle
      StateMachine reports ['None']); local_data = base64 text of the userdata dict pickled
      with protocol 2; info = a short reason ('HEARTBEAT', 'TRANSITION', ...);
    - an init command whose path names a container and whose initial_states are children
      of it sets that container's initial state(s) and merges its (base64 pickled) userdata.
      NOTE: as in smach_ros this unpickles data received from the network; run it only on
      a trusted ROS graph.

Differences from smach_ros, all deliberate: one pair of publishers and one init subscriber
per server instead of per container; heartbeats from one rospy.Timer (ROS time) instead of
sleep-polling threads; status is also published when a container starts and terminates;
userdata entries that cannot be pickled are left out (with a throttled warning) instead of
breaking the status stream.
"""
import base64
import pickle
import threading
import traceback

import rospy
from smach_msgs.msg import (SmachContainerInitialStatusCmd, SmachContainerStatus,
                            SmachContainerStructure)
from std_msgs.msg import Header

from control_pkg.smach_compat import smach

__all__ = ['IntrospectionServer', 'STATUS_TOPIC', 'INIT_TOPIC', 'STRUCTURE_TOPIC',
           'encode_userdata', 'decode_userdata']

STATUS_TOPIC = '/smach/container_status'
INIT_TOPIC = '/smach/container_init'
STRUCTURE_TOPIC = '/smach/container_structure'

_PICKLE_PROTOCOL = 2


def encode_userdata(data):
    """Userdata dict -> the local_data text (base64 of a protocol-2 pickle).

    Entries that cannot be pickled are left out; returns (text, names of skipped keys).
    """
    try:
        blob = pickle.dumps(dict(data), _PICKLE_PROTOCOL)
        skipped = []
    except Exception:
        kept = {}
        skipped = []
        for key, value in data.items():
            try:
                pickle.dumps(value, _PICKLE_PROTOCOL)
            except Exception:
                skipped.append(key)
            else:
                kept[key] = value
        blob = pickle.dumps(kept, _PICKLE_PROTOCOL)
    return base64.b64encode(blob).decode('ascii'), skipped


def decode_userdata(text):
    """The local_data text -> userdata dict (empty text gives an empty dict)."""
    if not text:
        return {}
    return pickle.loads(base64.b64decode(text))


class _ContainerProxy(object):
    """Reports one container of the tree."""

    def __init__(self, server, container, path):
        self.server = server
        self.container = container
        self.path = path
        container.register_start_cb(self._on_start)
        container.register_transition_cb(self._on_transition)
        container.register_termination_cb(self._on_termination)

    def _on_start(self, _userdata, _initial_states, *_args):
        self.publish_status('START')

    def _on_transition(self, _userdata, _active_states, *_args):
        self.publish_status('TRANSITION')

    def _on_termination(self, _userdata, _terminal_states, outcome, *_args):
        self.publish_status('TERMINATION: %s' % (outcome,))

    def structure_msg(self):
        container = self.container
        internal_outcomes, outcomes_from, outcomes_to = [], [], []
        for outcome, from_label, to_label in container.get_internal_edges():
            internal_outcomes.append(str(outcome))
            outcomes_from.append(str(from_label))
            outcomes_to.append(str(to_label))
        return SmachContainerStructure(
            header=Header(stamp=rospy.Time.now()),
            path=self.path,
            children=[str(label) for label in container.get_children().keys()],
            internal_outcomes=internal_outcomes,
            outcomes_from=outcomes_from,
            outcomes_to=outcomes_to,
            container_outcomes=sorted(str(o) for o in container.get_registered_outcomes()))

    def status_msg(self, info):
        container = self.container
        local_data, skipped = encode_userdata(container.userdata._data)
        if skipped:
            rospy.logwarn_throttle(10.0, "SMACH introspection of '%s': userdata keys %s cannot "
                                   "be pickled and are not published" % (self.path, skipped))
        return SmachContainerStatus(
            header=Header(stamp=rospy.Time.now()),
            path=self.path,
            initial_states=[str(s) for s in container.get_initial_states()],
            active_states=[str(s) for s in container.get_active_states()],
            local_data=local_data,
            info=info)

    def publish_status(self, info):
        self.server.publish_status(self, info)


class IntrospectionServer(object):
    """Publish the structure and status of a SMACH tree for smach_viewer.

    IntrospectionServer(server_name, state, path) like smach_ros; start() builds the
    container proxies and begins publishing, stop() ends it. `update_rate` (a
    rospy.Duration, default 2 s as smach_ros) is the heartbeat period.
    """

    def __init__(self, server_name, state, path, update_rate=rospy.Duration(2.0)):
        self._server_name = server_name
        self._state = state
        self._path = path
        self._update_rate = update_rate
        self._lock = threading.Lock()
        self._proxies = []
        self._running = False
        self._timer = None
        self._structure_pub = None
        self._status_pub = None
        self._init_sub = None

    def start(self):
        with self._lock:
            if self._running:
                return
            self._structure_pub = rospy.Publisher(self._server_name + STRUCTURE_TOPIC,
                                                  SmachContainerStructure, queue_size=5)
            self._status_pub = rospy.Publisher(self._server_name + STATUS_TOPIC,
                                               SmachContainerStatus, queue_size=50)
            if not self._proxies:
                self.construct(self._server_name, self._state, self._path)
            self._running = True
        self._init_sub = rospy.Subscriber(self._server_name + INIT_TOPIC,
                                          SmachContainerInitialStatusCmd, self._on_init_cmd)
        self._heartbeat(None)
        self._timer = rospy.Timer(self._update_rate, self._heartbeat)

    def stop(self):
        with self._lock:
            if not self._running:
                return
            self._running = False
            timer, self._timer = self._timer, None
            subscriber, self._init_sub = self._init_sub, None
            publishers = (self._structure_pub, self._status_pub)
        if timer is not None:
            timer.shutdown()
        if subscriber is not None:
            subscriber.unregister()
        for publisher in publishers:
            publisher.unregister()

    def construct(self, server_name, state, path):
        """Make proxies for `state` (a container) and every container below it."""
        self._proxies.append(_ContainerProxy(self, state, path))
        prefix = '' if path == '/' else path
        for label, child in state.get_children().items():
            if isinstance(child, smach.Container):
                self.construct(server_name, child, prefix + '/' + label)

    def clear(self):
        """Forget all proxies (they stay registered on the containers but publish nothing)."""
        self.stop()
        with self._lock:
            proxies, self._proxies = self._proxies, []
        for proxy in proxies:
            proxy.server = _Detached()

    # ----------------------------------------------------------------- publishing
    def publish_status(self, proxy, info):
        with self._lock:
            if not self._running:
                return
            try:
                self._status_pub.publish(proxy.status_msg(info))
            except Exception:
                if not rospy.is_shutdown():
                    rospy.logerr_throttle(10.0, "SMACH introspection status of '%s' failed: %s"
                                          % (proxy.path, traceback.format_exc()))

    def _heartbeat(self, _event):
        for proxy in list(self._proxies):
            with self._lock:
                if not self._running:
                    return
                try:
                    self._structure_pub.publish(proxy.structure_msg())
                except Exception:
                    if not rospy.is_shutdown():
                        rospy.logerr_throttle(10.0, "SMACH introspection structure of '%s' "
                                              "failed: %s" % (proxy.path, traceback.format_exc()))
            proxy.publish_status('HEARTBEAT')

    def _on_init_cmd(self, msg):
        for proxy in list(self._proxies):
            if proxy.path != msg.path:
                continue
            children = proxy.container.get_children()
            unknown = [s for s in msg.initial_states if s not in children]
            if unknown:
                rospy.logerr("SMACH init command for '%s': %s are not children (children: %s)"
                             % (msg.path, unknown, sorted(children.keys())))
                return
            try:
                data = decode_userdata(msg.local_data)
            except Exception:
                rospy.logerr("SMACH init command for '%s': local_data does not decode: %s"
                             % (msg.path, traceback.format_exc()))
                return
            userdata = smach.UserData()
            userdata._data = dict(data)
            rospy.loginfo("SMACH '%s': initial states set to %s by remote command"
                          % (msg.path, list(msg.initial_states)))
            proxy.container.set_initial_state(list(msg.initial_states), userdata)
            proxy.publish_status('REMOTE_INIT')
            return


class _Detached(object):
    """Stand-in server for proxies of a cleared IntrospectionServer."""

    @staticmethod
    def publish_status(_proxy, _info):
        return None
