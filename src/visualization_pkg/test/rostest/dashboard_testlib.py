"""Shared by the dashboard rostests: a QApplication in the test process and event-pumping waits."""
import faulthandler
import os
import sys
import threading
import traceback

import rospy


def make_app(platform='offscreen'):
    """The QApplication of the test process (offscreen unless told otherwise, e.g. xcb under Xvfb)."""
    if platform:
        os.environ['QT_QPA_PLATFORM'] = platform
    try:                                   # a crash in Qt prints the Python stacks
        faulthandler.enable(file=sys.__stderr__)
    except (AttributeError, ValueError, OSError):   # rosunit may replace the std streams
        pass
    sys.excepthook = _record_exception     # PyQt5 aborts on an exception in a slot without a hook
    from python_qt_binding.QtWidgets import QApplication
    return QApplication.instance() or QApplication(['dashboard_test'])


SLOT_ERRORS = []


def _record_exception(kind, value, tb):
    """Exceptions raised in Qt slots: kept for the tests to assert on, and printed."""
    text = ''.join(traceback.format_exception(kind, value, tb))
    SLOT_ERRORS.append(text)
    sys.stderr.write(text)


def pump(app, seconds):
    """Process Qt events for `seconds` (wall time)."""
    from python_qt_binding.QtTest import QTest
    deadline = rospy.get_time() + seconds
    while rospy.get_time() < deadline and not rospy.is_shutdown():
        app.processEvents()
        QTest.qWait(20)


def wait_for(app, predicate, timeout=30.0):
    """Process Qt events until predicate() is true; False on timeout. ROS callbacks run meanwhile."""
    from python_qt_binding.QtTest import QTest
    deadline = rospy.get_time() + timeout
    while not rospy.is_shutdown():
        app.processEvents()
        if predicate():
            return True
        if rospy.get_time() > deadline:
            return False
        QTest.qWait(20)
    return False


class TopicWatch(object):
    """Latest messages of a few topics, read from the test's own subscribers (not the dashboard's)."""

    def __init__(self):
        self.lock = threading.Lock()
        self.latest = {}
        self.history = {}

    def watch(self, topic, msg_type, key=None):
        def cb(msg):
            with self.lock:
                k = key(msg) if key else topic
                self.latest[k] = msg
                self.history.setdefault(topic, []).append(msg)
        return rospy.Subscriber(topic, msg_type, cb, queue_size=100)

    def get(self, key):
        with self.lock:
            return self.latest.get(key)

    def all(self, topic):
        with self.lock:
            return list(self.history.get(topic, []))
