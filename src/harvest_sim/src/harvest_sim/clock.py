"""Deterministic simulated clock schedule and its holds (pure logic, no rospy).

The clock advances in regular steps, whatever the machine's load: a late tick is published
late (the achieved time scale drops), never skipped. While only motion is simulated (the world
is busy until a known time) it may advance in coarser steps that land where the motion ends.

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
    """The clock's simulated time (integer nanoseconds) and its pacing against the wall clock."""

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
        self.step_ns = int(round(step * 1e9))
        self.start = float(start)
        self.start_ns = int(round(start * 1e9))
        self.max_lag = float(max_lag)
        self.tick = 0
        self.t_ns = self.start_ns
        self._anchor = (self.t_ns, 0.0)      # (simulated ns, wall offset) pacing counts from
        self.reanchors = 0

    def sim_time(self):
        """Current simulated time (s)."""
        return self.t_ns * 1e-9

    def sim_time_ns(self):
        """Current simulated time in integer nanoseconds (exact: no float truncation, so a
        timer due at a multiple of the step fires on its tick)."""
        return self.t_ns

    def wall_due(self, t_ns):
        """Wall seconds after the schedule's start at which simulated time t_ns is due (0 when
        unpaced)."""
        if self.time_scale == 0.0:
            return 0.0
        return self._anchor[1] + (t_ns - self._anchor[0]) * 1e-9 / self.time_scale

    def wall_offset(self):
        """Wall seconds after the start at which the next regular tick is due."""
        return self.wall_due(self.t_ns + self.step_ns)

    def advance(self, wall_elapsed=None, to_ns=None):
        """Move to the next tick (the regular step, or simulated time to_ns); returns its
        simulated time. `wall_elapsed` (wall seconds since the start, when the tick is actually
        published) moves the pacing anchor to this tick when it is more than max_lag late."""
        self.t_ns = self.t_ns + self.step_ns if to_ns is None else int(to_ns)
        self.tick += 1
        if wall_elapsed is not None and self.time_scale > 0.0 and \
                wall_elapsed - self.wall_due(self.t_ns) > self.max_lag:
            self._anchor = (self.t_ns, wall_elapsed)
            self.reanchors += 1
        return self.sim_time()

    def set_scale(self, time_scale, wall_elapsed):
        """Change the pace from the current time on (0: unpaced)."""
        time_scale = float(time_scale)
        if time_scale != self.time_scale:
            self.time_scale = time_scale
            self._anchor = (self.t_ns, wall_elapsed)

    def achieved_scale(self, wall_elapsed):
        """Simulated seconds per wall second so far."""
        if wall_elapsed <= 0.0:
            return 0.0
        return (self.t_ns - self.start_ns) * 1e-9 / wall_elapsed


def next_tick_ns(t_ns, step_ns, busy_step_ns=None, busy_until_ns=None, hold_ns=None):
    """Simulated time of the next tick: one regular step, or, while something is under way in
    the world (busy_until_ns later than now), one busy step (coarser: fewer ticks while only
    motion is simulated) that lands exactly where the motion ends; never past the next hold of a
    sensor (hold_ns), so a frame due then is taken at its time."""
    step = step_ns
    if busy_step_ns and busy_until_ns is not None and busy_until_ns > t_ns:
        step = max(step_ns, min(busy_step_ns, busy_until_ns - t_ns))
    nxt = t_ns + step
    if hold_ns is not None and t_ns < hold_ns < nxt:
        nxt = hold_ns
    return nxt


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

    def next_limit(self, t_now):
        """Earliest hold limit later than t_now (None: none)."""
        ahead = [u for u in self._holds.values() if u > t_now + 1e-6]
        return min(ahead) if ahead else None

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

    def busy_until(self):
        """Latest end of what is under way (None: nothing reported yet)."""
        return max(self._busy.values()) if self._busy else None

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
