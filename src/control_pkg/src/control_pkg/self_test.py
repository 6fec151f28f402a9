"""The start-up self-test behind DO_START (Start.action).

Node `self_test_server`
  Action server: self_test (harvest_msgs/Start)
  Params: ~components: list of {name, type, topic, timeout}; type is
    - `action`: an action server is up (its <topic>/status is published by some node)
    - `topic`: messages arrive on <topic> within timeout seconds (cameras, point cloud)
    - `status`: a diagnostic_msgs/DiagnosticStatus on <topic> has level OK (the motion controller
      enabled and fault-free, published latched by motion_pkg's motion_server)
    - `subscriber`: some node subscribes <topic> (the database takes the mission records)
"""
import threading

import actionlib
import rosgraph
import rospy
from diagnostic_msgs.msg import DiagnosticStatus
from harvest_msgs.msg import StartAction, StartFeedback, StartResult

COMPONENT_TYPES = ('action', 'topic', 'status', 'subscriber')


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
                    'timeout': timeout})
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
        self._master = rosgraph.Master(rospy.get_name())
        self._server = actionlib.SimpleActionServer('self_test', StartAction, execute_cb=self.execute,
                                                    auto_start=False)
        self._server.start()
        rospy.loginfo('self_test_server: %d components configured', len(self.components))

    def _graph(self):
        pubs, subs, _ = self._master.getSystemState()
        return dict(pubs), dict(subs)

    def check(self, comp):
        topic = rospy.resolve_name(comp['topic'])
        kind = comp['type']
        try:
            if kind == 'action':
                pubs, _ = self._graph()
                if pubs.get(topic + '/status'):
                    return True, ''
                return False, 'action server %s is not running' % topic
            if kind == 'subscriber':
                _, subs = self._graph()
                if subs.get(topic):
                    return True, ''
                return False, 'nothing subscribes %s' % topic
            if kind == 'topic':
                rospy.wait_for_message(topic, rospy.AnyMsg, timeout=comp['timeout'])
                return True, ''
            if kind == 'status':
                msg = rospy.wait_for_message(topic, DiagnosticStatus, timeout=comp['timeout'])
                if msg.level == DiagnosticStatus.OK:
                    return True, ''
                return False, '%s reports: %s' % (topic, msg.message or 'level %d' % msg.level)
        except rospy.ROSException:
            return False, 'no message on %s within %.1f s' % (topic, comp['timeout'])
        except Exception as exc:  # noqa: BLE001 - the master may be unreachable
            return False, 'check of %s failed: %s' % (topic, exc)
        return False, 'unknown component type %s' % kind

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
        results = [None] * len(comps)
        lock = threading.Lock()

        def run(i, comp):
            ok, reason = self.check(comp)
            with lock:
                results[i] = (comp['name'], ok, reason)
                self._server.publish_feedback(StartFeedback(component=comp['name'], ok=ok))

        threads = [threading.Thread(target=run, args=(i, c)) for i, c in enumerate(comps)]
        for t in threads:
            t.start()
        for t in threads:
            t.join()
        success, failed, reasons, message = summarize(results)
        result = StartResult(success=success, failed=failed, reasons=reasons, message=message)
        if success:
            rospy.loginfo('self_test_server: %s', message)
            self._server.set_succeeded(result, message)
        else:
            for name, reason in zip(failed, reasons):
                rospy.logerr('self_test_server: %s: %s', name, reason)
            self._server.set_succeeded(result, message)
