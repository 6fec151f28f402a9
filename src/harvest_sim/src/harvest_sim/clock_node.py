"""ROS glue of the simulated clock (node ``sim_clock``).

Publishes /clock (rosgraph_msgs/Clock) following harvest_sim.clock.ClockSchedule: tick k is
simulated time ~start + k ~step, paced at ~time_scale simulated seconds per wall second (0: as
fast as the holds allow). The simulator's sensors hold the clock on sim/clock_hold
(harvest_sim/ClockHold) until they have delivered what is due (harvest_sim.clock.ClockHolds):
whatever the machine's load, a camera delivers its frames at their simulated times, and its
rendering takes no simulated time. With ~rest_scale > 0 the clock runs at that pace (1: real
time) while nothing is under way in the simulated world (harvest_sim.clock.RestPace, fed by the
simulated controller on sim/activity): the robot's start-up and its computing between two
motions cost the simulated time they cost on the wall clock, whatever the time scale, so a
mission's simulated timing does not depend on ~time_scale. The clock is the time source, so it is paced by the wall clock: it
waits on a threading.Condition until a tick is due and not held.
Parameters: ~time_scale (10.0; 0: as fast as possible), ~step (0.02 s of simulated time per
tick), ~start (100.0 s: simulated time of the first tick; nonzero so that nodes never see time
zero, which ROS treats as "no time yet"), ~hold_timeout (10 wall seconds: a hold that stops the
clock longer is dropped with a warning), ~rest_scale (0: off; the pace while the world rests,
never above ~time_scale), ~busy_step (0: off; simulated seconds per tick while only motion is
under way in the world: coarser ticks, each landing no later than the motion's end or a
sensor's next frame).
Subscriptions: sim/clock_hold (harvest_sim/ClockHold), sim/activity (harvest_sim/SimActivity).
Publications: /clock.
"""

import threading
import time
import warnings

import rospy
from rosgraph_msgs.msg import Clock

from harvest_sim import names
from harvest_sim.clock import ClockHolds, ClockSchedule, RestPace, next_tick_ns
from harvest_sim.msg import ClockHold, SimActivity

#: wall seconds between achieved-speed debug lines
REPORT_PERIOD = 10.0


def _time(ns):
    return rospy.Time(ns // 1000000000, ns % 1000000000)


class SimClockNode(object):
    def __init__(self):
        try:
            self.schedule = ClockSchedule(rospy.get_param('~time_scale', 10.0),
                                          rospy.get_param('~step', 0.02),
                                          rospy.get_param('~start', 100.0))
        except ValueError as e:
            rospy.logfatal('sim_clock: %s', e)
            raise rospy.ROSInitException(str(e))
        self.holds = ClockHolds(rospy.get_param('~hold_timeout', 10.0))
        self.time_scale = self.schedule.time_scale
        busy_step = float(rospy.get_param('~busy_step', 0.0))
        self.busy_step_ns = int(round(busy_step * 1e9)) if busy_step > 0.0 else None
        self.rest = RestPace(rospy.get_param('~rest_scale', 0.0))
        self._cond = threading.Condition()
        self._stop = False
        self._rest_sim = 0.0
        # synchronous publisher (queue_size None): when publish() returns every subscriber has
        # the tick, and a subscriber that cannot keep up slows the clock instead of losing ticks
        with warnings.catch_warnings():
            warnings.simplefilter('ignore', SyntaxWarning)
            self.pub = rospy.Publisher(names.CLOCK, Clock, queue_size=None, tcp_nodelay=True)
        self._sub = rospy.Subscriber(names.CLOCK_HOLD, ClockHold, self._on_hold, queue_size=100,
                                     tcp_nodelay=True)
        self._activity_sub = rospy.Subscriber(names.CLOCK_ACTIVITY, SimActivity,
                                              self._on_activity, queue_size=100,
                                              tcp_nodelay=True)
        rospy.on_shutdown(self._shutdown)
        self._thread = threading.Thread(target=self._run, name='sim_clock')
        self._thread.daemon = True
        self._thread.start()
        rospy.loginfo('sim_clock: time scale %s, step %.3f s', self.schedule.time_scale or 'max',
                      self.schedule.step)

    def _on_hold(self, msg):
        with self._cond:
            self.holds.set(msg.holder, msg.until.to_sec())
            self._cond.notify_all()

    def _on_activity(self, msg):
        with self._cond:
            if msg.kind == SimActivity.BUSY:
                self.rest.busy(msg.source, msg.until.to_sec())
            self._cond.notify_all()

    def _shutdown(self):
        with self._cond:
            self._stop = True
            self._cond.notify_all()
        if self.rest.enabled:
            span = (self.schedule.t_ns - self.schedule.start_ns) * 1e-9
            rospy.loginfo('sim_clock: %.0f s simulated in %d ticks, %.0f s of it at rest (paced '
                          'at %.1f)', span, self.schedule.tick, self._rest_sim,
                          self.rest.rest_scale)

    def _run(self):
        s = self.schedule
        msg = Clock()
        msg.clock = _time(s.sim_time_ns())
        self.pub.publish(msg)
        wall0 = time.monotonic()
        report = wall0 + REPORT_PERIOD
        held_wall = 0.0
        while True:
            with self._cond:
                while not self._stop:
                    now = time.monotonic()
                    t = s.sim_time()
                    blocking = self.holds.blocking(t, now)
                    self._warn_expired()
                    if blocking:
                        wait_start = now
                        self._cond.wait(0.5)
                        held_wall += time.monotonic() - wait_start
                        continue
                    s.set_scale(self.rest.scale(t, self.time_scale), now - wall0)
                    busy = self.rest.busy_until()
                    hold = self.holds.next_limit(t)
                    t_next = next_tick_ns(s.sim_time_ns(), s.step_ns, self.busy_step_ns,
                                          None if busy is None else int(round(busy * 1e9)),
                                          None if hold is None else int(round(hold * 1e9)))
                    delay = wall0 + s.wall_due(t_next) - now
                    if delay <= 0:
                        break
                    self._cond.wait(delay)
                if self._stop:
                    return
            if s.time_scale != self.time_scale:
                self._rest_sim += (t_next - s.sim_time_ns()) * 1e-9
            s.advance(time.monotonic() - wall0, t_next)
            msg.clock = _time(s.sim_time_ns())
            try:
                self.pub.publish(msg)
            except rospy.ROSException:        # shutting down
                return
            if time.monotonic() > report:
                report += REPORT_PERIOD
                elapsed = time.monotonic() - wall0
                rospy.logdebug('sim_clock: achieved time scale %.2f; held by sensors %.0f %% of '
                               'the wall time; %.0f s of simulated time at rest, %d ticks',
                               s.achieved_scale(elapsed), 100.0 * held_wall / elapsed,
                               self._rest_sim, s.tick)

    def _warn_expired(self):
        while self.holds.expired:
            holder = self.holds.expired.pop()
            rospy.logwarn('sim_clock: %s held the clock for more than %.0f wall seconds; its '
                          'hold is dropped', holder, self.holds.timeout)
