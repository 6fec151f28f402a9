"""Operator actions (node start/stop/restart, manual commands) as mission events.

The dashboard publishes harvest_msgs/MissionEvent on `mission/events` itself, kind 'operator', so
database_pkg's database_node stores them beside the executive's events. The mission id is the
last one seen on `mission/events` or `mission/pick_records`; before any mission has been seen it
is `operator-<UTC date>` (the database refuses an empty id).

MissionEvent fields used: kind 'operator'; state = the action ('node_stop', 'node_start',
'node_restart', 'jog', 'move_cart', 'end_effector', ...); detail = '<outcome>: <text>' with
outcome accepted / refused / failed / ok.
"""
import time

from visualization_pkg import names

KIND = 'operator'


def fallback_mission_id(now=None):
    return 'operator-' + time.strftime('%Y%m%d', time.gmtime(time.time() if now is None else now))


class MissionIdTracker(object):
    """Which mission an operator action belongs to (no rospy)."""

    def __init__(self, fallback=None):
        self.fallback = fallback or fallback_mission_id()
        self.current = ''

    def seen(self, mission_id):
        if mission_id and not mission_id.startswith('operator-'):
            self.current = mission_id

    def mission_id(self):
        return self.current or self.fallback


def event_fields(tracker, action, outcome, text):
    """(mission_id, kind, state, detail) of one operator action."""
    return tracker.mission_id(), KIND, action, '%s: %s' % (outcome, text)


class OperatorEventPublisher(object):
    """ROS glue: follows the mission id and publishes operator events (thread-safe publish)."""

    def __init__(self, topic=names.EVENTS, records_topic=names.PICK_RECORDS):
        self.topic = topic
        self.records_topic = records_topic
        self.tracker = MissionIdTracker()
        self._pub = None
        self._subs = []
        self.sent = []                  # (action, outcome, text) of this session, for the UI and tests

    def start(self):
        import rospy
        from harvest_msgs.msg import MissionEvent, PickRecord
        self._pub = rospy.Publisher(self.topic, MissionEvent, queue_size=20)
        self._subs = [rospy.Subscriber(self.topic, MissionEvent, lambda m: self.tracker.seen(m.mission_id),
                                       queue_size=20),
                      rospy.Subscriber(self.records_topic, PickRecord, lambda m: self.tracker.seen(m.mission_id),
                                       queue_size=20)]

    def publish(self, action, outcome, text):
        self.sent.append((action, outcome, text))
        if self._pub is None:
            return False
        import rospy
        from harvest_msgs.msg import MissionEvent
        mission_id, kind, state, detail = event_fields(self.tracker, action, outcome, text)
        self._pub.publish(MissionEvent(mission_id=mission_id, stamp=rospy.Time.now(), kind=kind, state=state,
                                       detail=detail))
        return True

    def shutdown(self):
        for sub in self._subs:
            sub.unregister()
        self._subs = []
        if self._pub is not None:
            self._pub.unregister()
            self._pub = None
