"""ros_alarms (no ROS master): ROS-time alarms from one shared thread. Simulated time is driven
here through rospy.rostime, as /clock messages drive it in a node."""

import threading

import pytest
import rospy

from control_pkg import ros_alarms

#: rospy's clock (rostime._set_rostime, switch_to_wallclock) still calls Condition.notifyAll
pytestmark = pytest.mark.filterwarnings('ignore:notifyAll:DeprecationWarning')


@pytest.fixture
def sim_clock():
    """Simulated ROS time at 100 s; set(t) moves it as a /clock message does."""
    rospy.rostime.set_rostime_initialized(True)

    def set_time(sec):
        rospy.rostime._set_rostime(rospy.Time.from_sec(sec))
    set_time(100.0)
    yield set_time
    rospy.rostime.switch_to_wallclock()


def fired_event():
    event = threading.Event()
    return event, (lambda _e: event.set())


def test_due_alarms_in_deadline_order_and_periodic_ones_rearm():
    server = ros_alarms._Server()
    calls = []
    once = ros_alarms.Alarm(rospy.Duration(2.0), lambda e: calls.append('once'), True)
    every = ros_alarms.Alarm(rospy.Duration(1.0), lambda e: calls.append('every'), False)
    with server._cond:                # no thread: _due is called by hand
        server._heap = [(101 * 10**9, 0, every), (102 * 10**9, 1, once)]   # a heap
    assert server._due(int(100.9e9)) == ([], 101 * 10**9)
    due, nxt = server._due(101 * 10**9)
    assert due == [every] and nxt == 102 * 10**9
    due, nxt = server._due(102 * 10**9)
    assert set(due) == {every, once} and nxt == 103 * 10**9      # every: 101 + 1 + 1
    # a periodic alarm far behind is re-armed one period after now, not in a burst
    due, nxt = server._due(110 * 10**9)
    assert due == [every] and nxt == 111 * 10**9


def test_only_cancelled_alarms_left_is_nothing_to_wait_for():
    server = ros_alarms._Server()
    alarm = ros_alarms.Alarm(rospy.Duration(300.0), lambda e: None, True)
    with server._cond:
        server._heap = [(400 * 10**9, 0, alarm)]
    alarm.shutdown()
    assert server._due(100 * 10**9) == ([], None)
    assert server.pending() == 0


def test_alarm_fires_in_simulated_time_and_the_thread_ends(sim_clock):
    event, cb = fired_event()
    ros_alarms.call_after(rospy.Duration(2.0), cb)
    assert ros_alarms.pending() == 1
    sim_clock(102.0)
    assert event.wait(10.0)
    thread = ros_alarms._server._thread
    if thread is not None:
        thread.join(10.0)
        assert not thread.is_alive()
    assert ros_alarms.pending() == 0


def test_cancelled_alarm_never_fires(sim_clock):
    calls = []
    early = ros_alarms.call_after(rospy.Duration(1.0), lambda e: calls.append('early'))
    event, cb = fired_event()
    ros_alarms.call_after(rospy.Duration(2.0), cb)
    early.shutdown()
    sim_clock(103.0)
    assert event.wait(10.0)          # served in deadline order: 'early' would have come first
    assert calls == []


def test_periodic_alarm_follows_the_clock_until_shut_down(sim_clock):
    ticks = []
    seen = threading.Condition()

    def tick(_e):
        with seen:
            ticks.append(rospy.get_rostime().to_sec())
            seen.notify_all()
    alarm = ros_alarms.call_every(rospy.Duration(0.5), tick)
    for n, t in enumerate((100.5, 101.0, 101.5), start=1):
        sim_clock(t)
        with seen:
            assert seen.wait_for(lambda: len(ticks) >= n, 10.0)
    alarm.shutdown()
    assert ticks == [100.5, 101.0, 101.5]


def test_a_raising_callback_does_not_stop_the_others(sim_clock):
    def broken(_e):
        raise RuntimeError('broken on purpose')
    ros_alarms.call_after(rospy.Duration(1.0), broken)
    event, cb = fired_event()
    ros_alarms.call_after(rospy.Duration(1.5), cb)
    sim_clock(102.0)
    assert event.wait(10.0)


def test_alarm_fires_in_wall_time():
    rospy.rostime.set_rostime_initialized(True)
    rospy.rostime.switch_to_wallclock()
    event, cb = fired_event()
    start = rospy.get_rostime()
    ros_alarms.call_after(rospy.Duration(0.05), cb)
    assert event.wait(10.0)
    assert rospy.get_rostime() - start >= rospy.Duration(0.05)
