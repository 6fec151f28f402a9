"""Deterministic simulated clock schedule (pure logic, no rospy).

Tick k carries simulated time start + k * step and is due at wall time
wall_start + k * step / time_scale. The sequence of published times never depends on the
machine's load: a late tick is published late (the achieved time scale drops), never skipped.
"""


class ClockSchedule(object):
    def __init__(self, time_scale=5.0, step=0.01, start=100.0):
        if not time_scale > 0.0:
            raise ValueError('time_scale must be > 0, got %r' % (time_scale,))
        if not step > 0.0:
            raise ValueError('step must be > 0 s, got %r' % (step,))
        if start < 0.0:
            raise ValueError('start must be >= 0 s, got %r' % (start,))
        self.time_scale = float(time_scale)
        self.step = float(step)
        self.start = float(start)
        self.tick = 0

    def sim_time(self, tick=None):
        """Simulated time (s) of a tick (default: the current one)."""
        return self.start + (self.tick if tick is None else tick) * self.step

    def wall_offset(self, tick=None):
        """Wall seconds after the schedule's start at which a tick is due."""
        return (self.tick if tick is None else tick) * self.step / self.time_scale

    def advance(self):
        """Move to the next tick; returns its simulated time."""
        self.tick += 1
        return self.sim_time()

    def achieved_scale(self, wall_elapsed):
        """Simulated seconds per wall second so far."""
        if wall_elapsed <= 0.0:
            return 0.0
        return self.tick * self.step / wall_elapsed
