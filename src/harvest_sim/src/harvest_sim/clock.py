"""Deterministic simulated clock schedule and its holds (pure logic, no rospy).

Tick k carries simulated time start + k * step, whatever the machine's load: a late tick is
published late (the achieved time scale drops), never skipped, so the sequence of times is
deterministic.

Pacing: with time_scale > 0 a tick is due time_scale times faster than real time, counted from
an anchor. When the clock falls behind (a hold, a loaded machine) by more than `max_lag` wall
seconds, the anchor moves to the late tick: the clock never races to catch up, so the speed
never exceeds time_scale. time_scale 0 means "as fast as the holds allow".

Holds: the simulator's sensors stop the clock until they have delivered what is due. A holder
(a camera) sets `until`: the clock stops as soon as it has published a time at or after it (so
a timer due at `until` fires whatever the rounding of the ticks). A free-running camera holds at
its next frame's time until that frame is out; a triggered one holds while it renders. A hold
that stops the clock for more than `timeout` wall seconds is dropped (a sensor that died must
not stop the world).
"""

INF = float('inf')


class ClockSchedule(object):
    def __init__(self, time_scale=5.0, step=0.02, start=100.0, max_lag=0.05):
        if not time_scale >= 0.0:
            raise ValueError('time_scale must be >= 0 (0: as fast as possible), got %r'
                             % (time_scale,))
        if not step > 0.0:
            raise ValueError('step must be > 0 s, got %r' % (step,))
        if start < 0.0:
            raise ValueError('start must be >= 0 s, got %r' % (start,))
        self.time_scale = float(time_scale)
        self.step = float(step)
        self.start = float(start)
        self.max_lag = float(max_lag)
        self.tick = 0
        self._anchor = (0, 0.0)      # (tick, wall offset) the pacing counts from
        self.reanchors = 0

    def sim_time(self, tick=None):
        """Simulated time (s) of a tick (default: the current one)."""
        return self.start + (self.tick if tick is None else tick) * self.step

    def sim_time_ns(self, tick=None):
        """Simulated time of a tick in integer nanoseconds (exact: no float truncation, so a
        timer due at a multiple of the step fires on its tick)."""
        return int(round(self.sim_time(tick) * 1e9))

    def wall_offset(self, tick=None):
        """Wall seconds after the schedule's start at which a tick is due (0 if unpaced)."""
        tick = self.tick if tick is None else tick
        if self.time_scale == 0.0:
            return 0.0
        return self._anchor[1] + (tick - self._anchor[0]) * self.step / self.time_scale

    def advance(self, wall_elapsed=None):
        """Move to the next tick; returns its simulated time. `wall_elapsed` (wall seconds since
        the start, when the tick is actually published) moves the pacing anchor to this tick
        when it is more than max_lag late."""
        self.tick += 1
        if wall_elapsed is not None and self.time_scale > 0.0 and \
                wall_elapsed - self.wall_offset() > self.max_lag:
            self._anchor = (self.tick, wall_elapsed)
            self.reanchors += 1
        return self.sim_time()

    def set_scale(self, time_scale, wall_elapsed):
        """Change the pace from the current tick on (0: unpaced)."""
        time_scale = float(time_scale)
        if time_scale != self.time_scale:
            self.time_scale = time_scale
            self._anchor = (self.tick, wall_elapsed)

    def achieved_scale(self, wall_elapsed):
        """Simulated seconds per wall second so far."""
        if wall_elapsed <= 0.0:
            return 0.0
        return self.tick * self.step / wall_elapsed


class ClockHolds(object):
    """The holds on the clock: holder -> latest simulated time the clock may publish.

    A hold that keeps the clock from its next tick for more than `timeout` wall seconds is
    dropped (its holder died or hangs) and reported once in `expired`."""

    def __init__(self, timeout=10.0):
        self.timeout = float(timeout)
        self._holds = {}             # holder -> until
        self._blocking = {}          # holder -> wall time it started to stop the clock
        self.expired = []

    def set(self, holder, until):
        """Stop the clock once it reaches `until` (simulated seconds); <= 0 or inf releases."""
        self._blocking.pop(holder, None)
        if until <= 0.0 or until == INF:
            self._holds.pop(holder, None)
        else:
            self._holds[holder] = float(until)

    def blocking(self, t_now, wall_now):
        """Holders that keep the clock, now at simulated time t_now, from its next tick (after
        dropping those that have done so for longer than the timeout)."""
        out = []
        for holder, until in list(self._holds.items()):
            if until > t_now + 1e-6:
                self._blocking.pop(holder, None)
                continue
            since = self._blocking.setdefault(holder, wall_now)
            if wall_now - since > self.timeout:
                del self._holds[holder]
                del self._blocking[holder]
                self.expired.append(holder)
                continue
            out.append(holder)
        return sorted(out)

    def __len__(self):
        return len(self._holds)


class RestPace(object):
    """Simulated time runs at real time while the simulated world rests.

    The simulated controller reports what is under way (axes moving, vacuum building up, shear
    closing) and when it ends. While something is under way the clock runs at its time scale;
    while the world rests, the robot is starting up or deciding what to do next (perception,
    planning, messaging), and the clock runs at `rest_scale` (1: real time): the robot's
    start-up and computing cost the simulated time they cost on the wall clock, as on a real
    robot, whatever the time scale, and every timeout of the robot stack that runs while
    nothing moves is a real-time timeout. Only physical processes are accelerated, so a
    mission's simulated timing is the same at 2x and at 20x.
    """

    def __init__(self, rest_scale=1.0):
        self.rest_scale = float(rest_scale)
        self._busy = {}              # source -> simulated time until which it is busy

    @property
    def enabled(self):
        return self.rest_scale > 0.0

    def busy(self, source, until):
        self._busy[source] = float(until)

    def resting(self, t_now):
        """Whether nothing is under way in the world at simulated time t_now."""
        if not self.enabled:
            return False
        return not self._busy or t_now >= max(self._busy.values()) - 1e-9

    def scale(self, t_now, time_scale):
        """The pace of the clock at simulated time t_now."""
        if self.resting(t_now):
            return min(self.rest_scale, time_scale) if time_scale > 0.0 else self.rest_scale
        return time_scale
