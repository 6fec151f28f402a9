"""Trapezoidal (or triangular) velocity profiles of one simulated drive axis.

Pure logic, no ROS. A profile is a list of constant-acceleration segments that starts at a
given time, position and velocity; :meth:`Profile.state` evaluates it at any later time, so the
simulated controller answers exactly at the moment a register is read, whatever the tick rate.

Units are whatever the caller uses consistently (the controller uses SI: m or rad, per second).
"""

import math


class Segment(object):
    """Constant acceleration ``a`` for ``duration`` seconds from (``t0``, ``p0``, ``v0``)."""

    __slots__ = ('t0', 'p0', 'v0', 'a', 'duration')

    def __init__(self, t0, p0, v0, a, duration):
        self.t0 = t0
        self.p0 = p0
        self.v0 = v0
        self.a = a
        self.duration = max(0.0, duration)

    @property
    def t1(self):
        return self.t0 + self.duration

    def state(self, t):
        """Position and velocity at time t (clamped to the segment)."""
        tau = min(max(t - self.t0, 0.0), self.duration)
        return self.p0 + self.v0 * tau + 0.5 * self.a * tau * tau, self.v0 + self.a * tau

    def end(self):
        return self.state(self.t1)


class Profile(object):
    """A chain of segments ending at rest at ``end_position``."""

    def __init__(self, t0, p0, segments, end_position):
        self.t0 = t0
        self.p0 = p0
        self.segments = list(segments)
        self.end_position = end_position

    @property
    def end_time(self):
        return self.segments[-1].t1 if self.segments else self.t0

    @property
    def duration(self):
        return self.end_time - self.t0

    def done(self, t):
        return t >= self.end_time

    def state(self, t):
        """(position, velocity) at time t; at rest on end_position after end_time."""
        if t >= self.end_time:
            return self.end_position, 0.0
        if t <= self.t0 or not self.segments:
            return (self.segments[0].p0, self.segments[0].v0) if self.segments else (self.p0, 0.0)
        for seg in self.segments:
            if t < seg.t1:
                return seg.state(t)
        return self.end_position, 0.0


def _append(segments, t, p, v, a, duration):
    """Append a segment (skipping empty ones) and return the new (t, p, v)."""
    if duration <= 0.0:
        return t, p, v
    seg = Segment(t, p, v, a, duration)
    segments.append(seg)
    p1, v1 = seg.end()
    return seg.t1, p1, v1


def plan_stop(t0, p0, v0, amax):
    """Decelerate at ``amax`` from velocity ``v0`` to rest (the drive's halt)."""
    if amax <= 0.0:
        raise ValueError('acceleration must be positive')
    segments = []
    if v0 != 0.0:
        _append(segments, t0, p0, v0, -math.copysign(amax, v0), abs(v0) / amax)
    end = segments[-1].end()[0] if segments else p0
    return Profile(t0, p0, segments, end)


def plan_move(t0, p0, v0, p1, vmax, amax):
    """Time-optimal profile from (p0, v0) to rest at p1 with |v| <= vmax, |a| <= amax.

    From rest this is the classic trapezoid (triangle for short moves). When the axis is already
    moving (a new target while a move runs) it first brakes to rest if it would overshoot or is
    moving away from the target, and sheds any speed above vmax.
    """
    if vmax <= 0.0 or amax <= 0.0:
        raise ValueError('speed and acceleration must be positive')
    segments = []
    t, p, v = t0, p0, v0
    d = p1 - p
    stop_dist = v * abs(v) / (2.0 * amax)          # signed distance needed to stop
    if v != 0.0 and (d == 0.0 or math.copysign(1.0, v) != math.copysign(1.0, d)
                     or abs(stop_dist) > abs(d)):
        t, p, v = _append(segments, t, p, v, -math.copysign(amax, v), abs(v) / amax)
        v = 0.0
        d = p1 - p
    if d == 0.0:
        return Profile(t0, p0, segments, p1)
    s = math.copysign(1.0, d)
    dist = abs(d)
    u = abs(v)                                      # speed towards the target, >= 0
    peak = math.sqrt(amax * dist + 0.5 * u * u)
    if peak <= vmax:
        # triangle: accelerate u -> peak, decelerate peak -> 0
        t, p, v = _append(segments, t, p, s * u, s * amax, (peak - u) / amax)
        _append(segments, t, p, s * peak, -s * amax, peak / amax)
    else:
        # trapezoid: reach vmax (accelerating or braking), cruise, decelerate
        d_ramp = abs(vmax * vmax - u * u) / (2.0 * amax)
        d_brake = vmax * vmax / (2.0 * amax)
        cruise = max(0.0, dist - d_ramp - d_brake)
        a_ramp = s * amax if u < vmax else -s * amax
        t, p, v = _append(segments, t, p, s * u, a_ramp, abs(vmax - u) / amax)
        t, p, v = _append(segments, t, p, s * vmax, 0.0, cruise / vmax)
        _append(segments, t, p, s * vmax, -s * amax, vmax / amax)
    return Profile(t0, p0, segments, p1)


def move_duration(distance, vmax, amax):
    """Duration of a rest-to-rest move over |distance| (trapezoid or triangle)."""
    dist = abs(distance)
    if dist == 0.0:
        return 0.0
    if dist >= vmax * vmax / amax:
        return dist / vmax + vmax / amax
    return 2.0 * math.sqrt(dist / amax)
