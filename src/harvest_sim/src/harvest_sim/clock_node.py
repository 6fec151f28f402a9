"""ROS glue of the simulated clock (node ``sim_clock``).

Publishes /clock (rosgraph_msgs/Clock) following harvest_sim.clock.ClockSchedule. Paced by the
wall clock (this node is the time source, so it cannot wait on ROS time): it waits on a
threading.Event until each tick is due.
Parameters: ~time_scale (5.0 simulated seconds per wall second), ~step (0.01 s of simulated
time per tick), ~start (100.0 s: simulated time of the first tick; nonzero so that nodes never
see time zero, which ROS treats as "no time yet").
"""

import threading
import time

import rospy
from rosgraph_msgs.msg import Clock

from harvest_sim import names
from harvest_sim.clock import ClockSchedule


class SimClockNode(object):
    def __init__(self):
        try:
            self.schedule = ClockSchedule(rospy.get_param('~time_scale', 5.0),
                                          rospy.get_param('~step', 0.01),
                                          rospy.get_param('~start', 100.0))
        except ValueError as e:
            rospy.logfatal('sim_clock: %s', e)
            raise rospy.ROSInitException(str(e))
        self.pub = rospy.Publisher(names.CLOCK, Clock, queue_size=10)
        self._stop = threading.Event()
        rospy.on_shutdown(self._stop.set)
        self._thread = threading.Thread(target=self._run, name='sim_clock')
        self._thread.daemon = True
        self._thread.start()
        rospy.loginfo('sim_clock: time scale %.2f, step %.3f s', self.schedule.time_scale,
                      self.schedule.step)

    def _run(self):
        s = self.schedule
        msg = Clock()
        msg.clock = rospy.Time.from_sec(s.sim_time())
        self.pub.publish(msg)
        wall0 = time.monotonic()
        while not self._stop.is_set():
            s.advance()
            delay = wall0 + s.wall_offset() - time.monotonic()
            if delay > 0 and self._stop.wait(delay):
                break
            msg.clock = rospy.Time.from_sec(s.sim_time())
            self.pub.publish(msg)
            if s.tick % int(max(1, round(60.0 / s.step))) == 0:
                rospy.logdebug('sim_clock: achieved time scale %.2f',
                               s.achieved_scale(time.monotonic() - wall0))
