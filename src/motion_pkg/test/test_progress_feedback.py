"""motion_moves.progress_feedback: a goal's progress feedback never goes back, not even when two
threads feed the goal from two polls, and none follows the goal's end (no ROS master)."""
import threading

from actionlib_msgs.msg import GoalStatus

from motion_pkg.motion_moves import progress_feedback


class FakeServer(object):
    def __init__(self):
        self.lock = threading.RLock()


class FakeHandle(object):
    """The parts of actionlib's ServerGoalHandle that progress_feedback uses."""

    def __init__(self):
        self.action_server = FakeServer()
        self.status = GoalStatus.ACTIVE
        self.published = []

    def get_goal_status(self):
        return GoalStatus(status=self.status)

    def publish_feedback(self, feedback):
        self.published.append(feedback)


class Monitor(object):
    def __init__(self, percent=0):
        self.percent = percent


def test_publishes_only_progress():
    handle, monitor = FakeHandle(), Monitor()
    for percent in (0, 0, 12, 16, 16, 20):
        monitor.percent = percent
        progress_feedback(handle, monitor, lambda p: p)
    assert handle.published == [0, 12, 16, 20]


def test_an_older_polls_feedback_after_a_newer_one_is_not_sent():
    # thread A polled (12), thread B polled (16) and fed the goal first: when A feeds it, the
    # monitor holds B's 16, already sent
    handle, monitor = FakeHandle(), Monitor(16)
    progress_feedback(handle, monitor, lambda p: p)          # B
    progress_feedback(handle, monitor, lambda p: p)          # A, late
    assert handle.published == [16]
    monitor.percent = 14                                     # a dip (an overshoot) is not news
    progress_feedback(handle, monitor, lambda p: p)
    assert handle.published == [16]


def test_no_feedback_after_the_goal_ended():
    handle, monitor = FakeHandle(), Monitor(40)
    handle.status = GoalStatus.SUCCEEDED
    progress_feedback(handle, monitor, lambda p: p)
    assert handle.published == []


def test_check_and_publication_are_one_step():
    # a thread that has checked but not yet published holds the lock: another thread's newer
    # feedback waits for it, so the wire order is the poll order
    handle, monitor = FakeHandle(), Monitor(12)
    checked, release = threading.Event(), threading.Event()

    def slow(percent):
        checked.set()
        release.wait(5.0)
        return percent

    first = threading.Thread(target=progress_feedback, args=(handle, monitor, slow))
    first.start()
    assert checked.wait(5.0)
    second_done = threading.Event()

    def newer():
        monitor.percent = 16
        progress_feedback(handle, monitor, lambda p: p)
        second_done.set()

    second = threading.Thread(target=newer)
    second.start()
    assert not second_done.wait(0.2)        # blocked behind the first (not a timing claim on
    release.set()                           # success: it must not have finished before release)
    first.join(5.0)
    second.join(5.0)
    assert handle.published == [12, 16]
