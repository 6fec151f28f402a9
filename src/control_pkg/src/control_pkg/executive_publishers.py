"""What the task planner publishes on its mission topics besides the messages it fills itself:
harvest_msgs/Checkpoint to and from a checkpoint.Snapshot, and the publishers' subscriber
listeners (`_Subscribed`: a subscriber connected; `_Replayed`: the run's records and events sent
again to a subscriber that connects later).

Re-exported by control_pkg.executive_node.
"""
import threading

import rospy

from geometry_msgs.msg import Point
from harvest_msgs.msg import Checkpoint
from control_pkg import checkpoint as checkpoint_lib


def snapshot_to_msg(snap, stamp):
    """A checkpoint.Snapshot as harvest_msgs/Checkpoint."""
    msg = Checkpoint(mission_id=snap.mission_id, robot=snap.robot, stamp=stamp,
                     points=list(snap.points), point_index=snap.point_index,
                     picking_point=snap.picking_point, target_id=snap.target_id,
                     phase=snap.phase, holding=snap.holding, finished=snap.finished,
                     outcome=snap.outcome)
    msg.targets_done = [t for t, _ in snap.targets_done]
    msg.done_positions = [Point(*xyz) for _, xyz in snap.targets_done]
    if snap.target_position is not None:
        msg.target_position = Point(*snap.target_position)
    return msg


def snapshot_from_msg(msg):
    return checkpoint_lib.Snapshot(
        msg.mission_id, msg.robot, msg.points, msg.point_index, msg.picking_point,
        [(t, (p.x, p.y, p.z)) for t, p in zip(msg.targets_done, msg.done_positions)],
        msg.target_id, (msg.target_position.x, msg.target_position.y, msg.target_position.z)
        if msg.target_id >= 0 else None, msg.phase, msg.holding, msg.finished, msg.outcome)


class _Subscribed(rospy.SubscribeListener):
    """Sets an event when a subscriber connects to the publisher it listens to."""

    def __init__(self):
        rospy.SubscribeListener.__init__(self)
        self.event = threading.Event()

    def peer_subscribe(self, topic_name, topic_publish, peer_publish):
        self.event.set()


class _Replayed(_Subscribed):
    """A publisher's history of this run, sent again to every subscriber that connects: a
    database_node that (re)starts mid-mission (respawned after a crash) gets every record and
    event it missed, and a dashboard started late the whole mission (the store keeps each once:
    database_pkg schema 5)."""

    def __init__(self):
        _Subscribed.__init__(self)
        self._lock = threading.Lock()
        self._sent = []

    def publish(self, publisher, msg):
        with self._lock:
            self._sent.append(msg)
        publisher.publish(msg)

    def peer_subscribe(self, topic_name, topic_publish, peer_publish):
        with self._lock:
            history = list(self._sent)
        for msg in history:
            peer_publish(msg)
        _Subscribed.peer_subscribe(self, topic_name, topic_publish, peer_publish)
