"""The executive's emergency_stop topic as the stop button's level (executive_estop): a stop is
its rise to true, a resume its fall; a true that the motion server's halt already made known is
no new stop (no ROS master)."""
import threading

from std_msgs.msg import Bool

from control_pkg.executive_estop import EmergencyStopAndResume


class Planner(EmergencyStopAndResume):
    def __init__(self):
        self._estop_level = False
        self._estop_level_lock = threading.Lock()
        self.calls = []

    def request_stop(self, source):
        self.calls.append(('stop', source))

    def request_resume(self, source):
        self.calls.append(('resume', source))


def kinds(planner):
    return [kind for kind, _ in planner.calls]


def test_rise_stops_and_fall_resumes():
    p = Planner()
    p._estop_topic_cb(Bool(data=True))
    p._estop_topic_cb(Bool(data=True))        # latched again (a new subscriber connection)
    p._estop_topic_cb(Bool(data=False))
    p._estop_topic_cb(Bool(data=True))        # pressed again
    assert kinds(p) == ['stop', 'resume', 'stop']


def test_the_topics_own_true_after_a_stop_heard_by_motion_is_no_new_stop():
    # motion_server heard the stop first (its goal came back halted); the operator resumed by
    # the service; then the topic's latched true reached this node
    p = Planner()
    p.stop_heard_by_motion('DO_MOVE_ROBOT (move_robot: halted by the emergency stop)')
    p._estop_topic_cb(Bool(data=True))
    assert kinds(p) == ['stop']
    p._estop_topic_cb(Bool(data=False))       # released
    p._estop_topic_cb(Bool(data=True))        # and pressed again: a stop
    assert kinds(p) == ['stop', 'resume', 'stop']
