"""The start-up self-test behind DO_START (Start.action).

Node `self_test_server`
  Action server: self_test (harvest_msgs/Start)
  Params: ~components: list of {name, type, topic, timeout[, trigger]}; type is
    - `action`: an action server is up (its <topic>/status is published by some node); the
      graph components wait up to their timeout (default 5 s) for start-up
    - `topic`: messages arrive on <topic> within timeout seconds (cameras, point cloud); with
      `trigger`, a std_msgs/Empty is published there first and every second while waiting (a
      triggered camera takes a frame only when asked; a free-running one ignores it)
    ~timeout_cap (0: none): no component waits longer than this (a quick self-test)
    - `status`: a diagnostic_msgs/DiagnosticStatus on <topic> has level OK (the motion controller
      enabled and fault-free, published latched by motion_pkg's motion_server)
    - `subscriber`: some node subscribes <topic> (the database takes the mission records)
  Every timeout is in ROS time (sim time in simulation).
"""
import threading

import actionlib
import rosgraph
import rospy
from diagnostic_msgs.msg import DiagnosticStatus
from harvest_msgs.msg import StartAction, StartFeedback, StartResult
from std_msgs.msg import Empty

from control_pkg import names

COMPONENT_TYPES = ('action', 'topic', 'status', 'subscriber')
#: wall seconds between checks of a ROS-time deadline while waiting for a message (the message
#: itself wakes the wait at once)
WAIT_SLICE = 0.05
#: ROS seconds between two triggers of a `topic` component's camera (a trigger sent before the
#: camera's subscription is connected is lost; the first one waits for it)
TRIGGER_PERIOD = 0.25


def parse_components(raw):
    """Validate the ~components parameter; return a list of dicts. Raises ValueError naming the fault."""
    if not isinstance(raw, list):
        raise ValueError('~components must be a list, got %s' % type(raw).__name__)
    out = []
    for i, item in enumerate(raw):
        if not isinstance(item, dict):
            raise ValueError('~components[%d] must be a mapping' % i)
        for field in ('name', 'type', 'topic'):
            if not item.get(field):
                raise ValueError('~components[%d] (%s) lacks field %r' % (i, item.get('name', '?'), field))
        if item['type'] not in COMPONENT_TYPES:
            raise ValueError('~components[%d] (%s): unknown type %r, expected one of %s'
                             % (i, item['name'], item['type'], ', '.join(COMPONENT_TYPES)))
        timeout = float(item.get('timeout', 5.0))
        if not timeout > 0:
            raise ValueError('~components[%d] (%s): timeout must be > 0' % (i, item['name']))
        out.append({'name': str(item['name']), 'type': item['type'], 'topic': str(item['topic']),
                    'timeout': timeout, 'trigger': str(item.get('trigger') or '')})
    return out


def summarize(checks):
    """checks: list of (name, ok, reason). Return (success, failed names, reasons, message)."""
    failed = [(n, r) for n, ok, r in checks if not ok]
    if not failed:
        return True, [], [], 'all %d components ready' % len(checks)
    return (False, [n for n, _ in failed], [r for _, r in failed],
            '%d of %d components failed: %s' % (len(failed), len(checks), ', '.join(n for n, _ in failed)))


class SelfTestServer(object):
    def __init__(self):
        try:
            self.components = parse_components(rospy.get_param('~components', []))
        except ValueError as exc:
            rospy.logfatal('self_test_server: %s', exc)
            raise
        cap = float(rospy.get_param('~timeout_cap', 0.0))
        if cap > 0.0:
            for comp in self.components:
                comp['timeout'] = min(comp['timeout'], cap)
        self._master = rosgraph.Master(rospy.get_name())
        self._server = actionlib.SimpleActionServer(names.SELF_TEST, StartAction, execute_cb=self.execute,
                                                    auto_start=False)
        self._server.start()
        rospy.loginfo('self_test_server: %d components configured', len(self.components))

    def _graph(self):
        pubs, subs, _ = self._master.getSystemState()
        return dict(pubs), dict(subs)

    GRAPH_TYPES = ('action', 'subscriber')

    def _graph_missing(self, comps):
        """One look at the master: {name: reason} for graph components (action/subscriber) not yet up."""
        pubs, subs, _ = self._master.getSystemState()
        pubs, subs = dict(pubs), dict(subs)
        missing = {}
        for comp in comps:
            topic = rospy.resolve_name(comp['topic'])
            if comp['type'] == 'action' and not pubs.get(topic + '/status'):
                missing[comp['name']] = 'action server %s is not running' % topic
            elif comp['type'] == 'subscriber' and not subs.get(topic):
                missing[comp['name']] = 'nothing subscribes %s' % topic
        return missing

    def check_graph(self, comps):
        """Wait (each up to its timeout) for the action servers and subscribers to appear.

        The master has no notifications, so its state is read twice a second until every
        component is up or its timeout has passed. Returns {name: (ok, reason)}.
        """
        results = {}
        pending = list(comps)
        start = rospy.get_time()
        rate = rospy.Rate(2.0)
        while pending and not rospy.is_shutdown() and not self._server.is_preempt_requested():
            try:
                missing = self._graph_missing(pending)
            except Exception as exc:  # noqa: BLE001 - master unreachable
                missing = {c['name']: 'master unreachable: %s' % exc for c in pending}
            elapsed = rospy.get_time() - start
            still = []
            for comp in pending:
                if comp['name'] not in missing:
                    results[comp['name']] = (True, '')
                elif elapsed >= comp['timeout']:
                    results[comp['name']] = (False, missing[comp['name']])
                else:
                    still.append(comp)
            pending = still
            if pending:
                try:
                    rate.sleep()
                except rospy.ROSInterruptException:
                    break
        for comp in pending:
            results[comp['name']] = (False, 'not checked: shutting down')
        return results

    @staticmethod
    def _wait_ros(event, timeout, tick=None, tick_ready=None):
        """Wait for a threading.Event up to `timeout` seconds of ROS time; call tick() as soon
        as tick_ready() (if given) and then every TRIGGER_PERIOD ROS seconds while waiting.
        True when the event was set."""
        end = rospy.get_rostime() + rospy.Duration.from_sec(timeout)
        next_tick = rospy.get_rostime()
        while not rospy.is_shutdown():
            now = rospy.get_rostime()
            if tick is not None and now >= next_tick and (tick_ready is None or tick_ready() or
                                                          now >= next_tick + rospy.Duration(1)):
                tick()
                next_tick = now + rospy.Duration.from_sec(TRIGGER_PERIOD)
            if event.wait(WAIT_SLICE):
                return True
            if rospy.get_rostime() >= end:
                return event.is_set()
        return False

    def check_topic(self, comp):
        """A topic or status component: wait for one message within its timeout (ROS time)."""
        topic = rospy.resolve_name(comp['topic'])
        if comp['type'] == 'topic':
            got = threading.Event()
            sub = rospy.Subscriber(topic, rospy.AnyMsg, lambda _m: got.set(), queue_size=1)
            trigger = None
            if comp['trigger']:
                trigger = rospy.Publisher(comp['trigger'], Empty, queue_size=1)
            try:
                if self._wait_ros(got, comp['timeout'],
                                  (lambda: trigger.publish(Empty())) if trigger else None,
                                  (lambda: trigger.get_num_connections() > 0) if trigger else None):
                    return True, ''
            finally:
                sub.unregister()
                if trigger is not None:
                    trigger.unregister()
            return False, 'no message on %s within %.1f s' % (topic, comp['timeout'])
        # a status: wait until it reports OK (a controller may still be connecting at start-up)
        ok_event = threading.Event()
        last = []

        def on_status(msg):
            last[:] = [msg]
            if msg.level == DiagnosticStatus.OK:
                ok_event.set()

        sub = rospy.Subscriber(topic, DiagnosticStatus, on_status, queue_size=10)
        try:
            if self._wait_ros(ok_event, comp['timeout']):
                return True, ''
        finally:
            sub.unregister()
        if not last:
            return False, 'no message on %s within %.1f s' % (topic, comp['timeout'])
        return False, '%s reports: %s' % (topic, last[0].message or 'level %d' % last[0].level)

    def execute(self, goal):
        wanted = set(goal.components)
        unknown = wanted - set(c['name'] for c in self.components)
        if unknown:
            self._server.set_aborted(StartResult(success=False, failed=sorted(unknown),
                                                 reasons=['not a configured component'] * len(unknown),
                                                 message='unknown components: %s' % ', '.join(sorted(unknown))),
                                     'unknown components requested')
            return
        comps = [c for c in self.components if not wanted or c['name'] in wanted]
        outcome = {}
        lock = threading.Lock()

        def run(comp):
            ok, reason = self.check_topic(comp)
            with lock:
                outcome[comp['name']] = (ok, reason)

        topic_comps = [c for c in comps if c['type'] not in self.GRAPH_TYPES]
        threads = [threading.Thread(target=run, args=(c,)) for c in topic_comps]
        for t in threads:
            t.start()
        graph = self.check_graph([c for c in comps if c['type'] in self.GRAPH_TYPES])
        for t in threads:
            t.join()
        outcome.update(graph)
        results = []
        for comp in comps:
            ok, reason = outcome[comp['name']]
            results.append((comp['name'], ok, reason))
            self._server.publish_feedback(StartFeedback(component=comp['name'], ok=ok))
        success, failed, reasons, message = summarize(results)
        if self._server.is_preempt_requested():
            self._server.set_preempted(StartResult(success=False, message='cancelled'), 'self-test cancelled')
            return
        result = StartResult(success=success, failed=failed, reasons=reasons, message=message)
        if success:
            rospy.loginfo('self_test_server: %s', message)
            self._server.set_succeeded(result, message)
        else:
            for name, reason in zip(failed, reasons):
                rospy.logerr('self_test_server: %s: %s', name, reason)
            self._server.set_succeeded(result, message)
