"""ROS-time alarms of the executive's action states, served by one shared thread.

A rospy.Timer is a thread that sleeps in ROS time, and with /use_sim_time every /clock message
wakes every sleeping thread of the node. Its shutdown() does not end the sleep: a one-shot
timer of a goal's exec_timeout (60 s for a move, 300 s for the self test) lives on, waking at
every tick, until its full duration has passed. With one per goal, a simulated mission kept
about 40 such threads in task_planner (50 /clock messages a second each), a tenth of a core.

Here every alarm of the process is one entry of a heap, served by one daemon thread that runs
only while an alarm is pending; a cancelled alarm is gone at once. Alarms follow ROS time like
rospy.Timer: with simulated time the thread waits on rospy's clock condition (woken by each
/clock message), with wall time it sleeps until the earliest deadline or a new earlier alarm.
A callback gets no event argument (None) and must not block; an exception in it is logged.
"""
import heapq
import itertools
import threading

import rospy

__all__ = ['call_after', 'call_every', 'pending', 'Alarm']

_WAIT_CAP = 0.5      # wall s: the longest a wait goes without looking at the clock again


class Alarm(object):
    """One pending alarm; shutdown() cancels it (a callback already running finishes)."""

    def __init__(self, period, callback, oneshot):
        self.period = period
        self.callback = callback
        self.oneshot = oneshot
        self.cancelled = False

    def shutdown(self):
        self.cancelled = True


class _Server(object):
    def __init__(self):
        self._cond = threading.Condition()
        self._heap = []                    # (deadline nsec, sequence, Alarm)
        self._seq = itertools.count()
        self._thread = None

    def add(self, alarm, deadline):
        with self._cond:
            heapq.heappush(self._heap, (deadline.to_nsec(), next(self._seq), alarm))
            if self._thread is None or not self._thread.is_alive():
                self._thread = threading.Thread(target=self._run, name='ros_alarms')
                self._thread.daemon = True
                self._thread.start()
            self._cond.notify_all()

    def pending(self):
        with self._cond:
            return sum(1 for _, _, a in self._heap if not a.cancelled)

    def _due(self, now_ns):
        """Pop the alarms due at now_ns (re-arming the periodic ones); (due, next deadline)."""
        due = []
        with self._cond:
            while self._heap and (self._heap[0][2].cancelled or self._heap[0][0] <= now_ns):
                deadline, _, alarm = heapq.heappop(self._heap)
                if alarm.cancelled:
                    continue
                due.append(alarm)
                if not alarm.oneshot:
                    step = alarm.period.to_nsec()
                    later = deadline + step if deadline + step > now_ns else now_ns + step
                    heapq.heappush(self._heap, (later, next(self._seq), alarm))
            if all(a.cancelled for _, _, a in self._heap):
                self._heap = []            # only cancelled ones left: nothing to wait for
            return due, (self._heap[0][0] if self._heap else None)

    def _run(self):
        while not rospy.core.is_shutdown():
            due, next_ns = self._due(rospy.get_rostime().to_nsec())
            for alarm in due:
                if alarm.cancelled:
                    continue
                try:
                    alarm.callback(None)
                except Exception as exc:       # one broken callback must not stop the others
                    rospy.logerr('ros_alarms: callback %r raised %s: %s', alarm.callback,
                                 type(exc).__name__, exc)
            if due:
                continue
            if next_ns is None:
                with self._cond:
                    if not self._heap:
                        self._thread = None      # the next add() starts a thread again
                        return
                continue
            if rospy.rostime.is_wallclock():
                wait = (next_ns - rospy.get_rostime().to_nsec()) * 1e-9
                with self._cond:
                    if wait > 0 and self._heap and self._heap[0][0] == next_ns:
                        self._cond.wait(min(wait, _WAIT_CAP))
            else:
                clock = rospy.rostime.get_rostime_cond()
                with clock:               # notified by every /clock message
                    if rospy.get_rostime().to_nsec() < next_ns:
                        clock.wait(_WAIT_CAP)


_server = _Server()


def call_after(duration, callback):
    """Call callback(None) once, `duration` (rospy.Duration) of ROS time from now."""
    alarm = Alarm(duration, callback, oneshot=True)
    _server.add(alarm, rospy.get_rostime() + duration)
    return alarm


def call_every(period, callback):
    """Call callback(None) every `period` (rospy.Duration) of ROS time, the first after one."""
    alarm = Alarm(period, callback, oneshot=False)
    _server.add(alarm, rospy.get_rostime() + period)
    return alarm


def pending():
    """Alarms not yet due and not cancelled (for tests and diagnostics)."""
    return _server.pending()
