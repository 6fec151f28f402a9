"""executive_node._Replayed: what the task planner published is sent again to a subscriber that
connects later (a respawned database_node), to that subscriber only."""
from harvest_msgs.msg import PickRecord

from control_pkg.executive_node import _Replayed


class _Publisher(object):
    def __init__(self):
        self.sent = []

    def publish(self, msg):
        self.sent.append(msg)


def test_a_late_subscriber_gets_every_message_published_before_it_came():
    replay, topic = _Replayed(), _Publisher()
    for target in (1, 2):
        replay.publish(topic, PickRecord(mission_id='m', target_id=target))
    assert [m.target_id for m in topic.sent] == [1, 2]
    late = []
    replay.peer_subscribe('mission/pick_records', topic.publish, late.append)
    assert [m.target_id for m in late] == [1, 2]
    assert [m.target_id for m in topic.sent] == [1, 2]        # the others get nothing twice
    assert replay.event.is_set()
    replay.publish(topic, PickRecord(mission_id='m', target_id=3))
    again = []
    replay.peer_subscribe('mission/pick_records', topic.publish, again.append)
    assert [m.target_id for m in again] == [1, 2, 3]
