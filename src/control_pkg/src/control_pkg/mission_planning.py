"""Pure planning helpers of the mission, free of ROS: the choice of pull and the pipelined schedule.

- choose_pull: CHOOSE_PULL's choice of the way to draw a held fruit out of its cluster;
- the pipelined schedule's guard (`schedule_step`): may two arm moves run at once? motion_pkg's
  kinematics collision check extended over both whole paths, each arm's axes on their trapezoids.

Re-exported by control_pkg.mission.
"""
import math


def distance(a, b):
    """Euclidean distance of two 3D points given as sequences."""
    return math.sqrt((a[0] - b[0]) ** 2 + (a[1] - b[1]) ** 2 + (a[2] - b[2]) ** 2)


def choose_pull(centre, radius, obstacles, candidates, clearance=0.0, cut_height=0.01, cut_clearance=0.01):
    """The first pull in ``candidates`` that leaves a held fruit clear of every other fruit.

    centre, radius: the held fruit (base frame, m). obstacles: (centre, radius) of the other
    fruit seen at this picking point and still there. candidates: displacement vectors in order
    of preference. A pull is clear when, where it ends, the fruit's sphere is ``clearance`` away
    from each obstacle's sphere (one that already touches it must not come closer) and the cut
    point (``cut_height`` above the fruit's top, where the shear closes) is ``cut_clearance``
    outside every obstacle. The way there is not checked: fruit of a truss give way to each
    other; what must not happen is the shear closing in another fruit.
    Returns the vector (tuple) or None when none is clear (then the fruit is cut where it hangs).
    """
    cx, cy, cz = (float(v) for v in centre)
    r = float(radius)
    obs = [((float(o[0][0]), float(o[0][1]), float(o[0][2])), float(o[1])) for o in obstacles]
    dist = distance
    for cand in candidates:
        dx, dy, dz = (float(v) for v in cand)
        end = (cx + dx, cy + dy, cz + dz)
        cut = (end[0], end[1], end[2] + r + cut_height)
        if all(dist(end, o) >= min(r + orad + clearance, dist((cx, cy, cz), o)) and
               dist(cut, o) >= orad + cut_clearance for o, orad in obs):
            return (dx, dy, dz)
    return None


# --- the pipelined schedule: may two arm moves run at once? --------------------------------------
SCHEDULE_PAPER = 'paper'
SCHEDULE_PIPELINED = 'pipelined'
SCHEDULES = (SCHEDULE_PAPER, SCHEDULE_PIPELINED)


def trapezoid_position(start, goal, speed, acceleration, t):
    """Where an axis moving rest to rest from `start` to `goal` with a trapezoidal (or
    triangular) speed profile, `speed` and `acceleration` > 0, is `t` seconds (a number or a
    numpy array) after it set off."""
    import numpy as np
    dist = goal - start
    d = abs(dist)
    t = np.asarray(t, dtype=float)
    if d == 0.0:
        return start + 0.0 * t
    sign = 1.0 if dist > 0.0 else -1.0
    t_acc = speed / acceleration
    if d < speed * t_acc:                       # triangle: top speed never reached
        t_acc = math.sqrt(d / acceleration)
        speed = acceleration * t_acc
    total = 2.0 * t_acc + (d - speed * t_acc) / speed
    tc = np.clip(t, 0.0, total)
    s = np.where(tc < t_acc, 0.5 * acceleration * tc * tc,
                 np.where(tc < total - t_acc, 0.5 * speed * t_acc + speed * (tc - t_acc),
                          d - 0.5 * acceleration * (total - tc) ** 2))
    return start + sign * s


def arm_path(start, goal, speeds, accelerations, dt):
    """Joint configurations (n x 3 array of lift, boom, forearm) every `dt` seconds of an arm
    moving from `start` to `goal`, each axis on its own trapezoid (as the motion controller runs
    them: every axis at its own speed, all starting together), both ends included. A resting
    arm (no goal, or goal == start) is its start alone."""
    import numpy as np
    start = tuple(float(v) for v in start)
    if goal is None:
        return np.array([start])
    goal = tuple(float(v) for v in goal)
    times = []
    for a, b, v, acc in zip(start, goal, speeds, accelerations):
        d = abs(b - a)
        times.append(0.0 if d == 0.0 else
                     (d / v + v / acc if d >= v * v / acc else 2.0 * math.sqrt(d / acc)))
    total = max(times)
    steps = max(1, int(math.ceil(total / dt)))
    t = np.linspace(0.0, total, steps + 1)
    return np.stack([trapezoid_position(a, b, v, acc, t)
                     for a, b, v, acc in zip(start, goal, speeds, accelerations)], axis=1)


def _segments_distance_2d(a0, a1, b0, b1):
    """Shortest distances (n x m) between the 2-D segments a0[i]-a1[i] and b0[j]-b1[j]
    (arrays n x 2 and m x 2)."""
    import numpy as np

    def point_segment2(px, py, sx, sy, ex, ey):
        """Squared distances of points (px, py) to segments (sx, sy)-(ex, ey), broadcast."""
        dx, dy = ex - sx, ey - sy
        dd = np.maximum(dx * dx + dy * dy, 1e-30)
        t = np.clip(((px - sx) * dx + (py - sy) * dy) / dd, 0.0, 1.0)
        qx, qy = px - sx - dx * t, py - sy - dy * t
        return qx * qx + qy * qy

    ax0, ay0 = a0[:, 0:1], a0[:, 1:2]          # n x 1
    ax1, ay1 = a1[:, 0:1], a1[:, 1:2]
    bx0, by0 = b0[None, :, 0], b0[None, :, 1]  # 1 x m
    bx1, by1 = b1[None, :, 0], b1[None, :, 1]
    best = np.minimum(np.minimum(point_segment2(ax0, ay0, bx0, by0, bx1, by1),
                                 point_segment2(ax1, ay1, bx0, by0, bx1, by1)),
                      np.minimum(point_segment2(bx0, by0, ax0, ay0, ax1, ay1),
                                 point_segment2(bx1, by1, ax0, ay0, ax1, ay1)))

    def cross(ox, oy, px, py, qx, qy):
        return (px - ox) * (qy - oy) - (py - oy) * (qx - ox)
    crossing = (cross(ax0, ay0, ax1, ay1, bx0, by0) * cross(ax0, ay0, ax1, ay1, bx1, by1) < 0.0) & \
        (cross(bx0, by0, bx1, by1, ax0, ay0) * cross(bx0, by0, bx1, by1, ax1, ay1) < 0.0)
    return np.where(crossing, 0.0, np.sqrt(best))


def arm_segments(geometry, arm, configs):
    """The forearm+tool segments of `arm` in `configs` ((lift, boom, forearm) each), vectorised:
    (elbow xy (n x 2), tool xy (n x 2), height (n)), the points RobotGeometry.arm_points gives
    (the segment motion_pkg's kinematics keeps `arm_clearance` from the other arm's)."""
    import numpy as np
    base, elbow0, _ = geometry.arm_points(arm, 0.0, 0.0, 0.0)
    yaw = math.atan2(elbow0[1] - base[1], elbow0[0] - base[0])
    q = np.asarray(configs, dtype=float).reshape(-1, 3)
    a1 = yaw + q[:, 1]
    a2 = a1 + q[:, 2]
    elbow = base[:2] + geometry.boom * np.stack([np.cos(a1), np.sin(a1)], axis=1)
    tip = elbow + (geometry.forearm + geometry.tool) * np.stack([np.cos(a2), np.sin(a2)], axis=1)
    return elbow, tip, base[2] + q[:, 0]


def thin_path(segments, spacing):
    """Indices of the samples of a path (arm_segments) to keep so that every sample is within
    `spacing` m of a kept one: the way each end of the forearm+tool segment and its height have
    come since the last kept sample stays below `spacing` (a point of a segment moves at most
    as far as its farther end)."""
    import numpy as np
    elbow, tip, z = segments
    if len(z) < 3:
        return list(range(len(z)))
    step = np.maximum(np.hypot(*(elbow[1:] - elbow[:-1]).T), np.hypot(*(tip[1:] - tip[:-1]).T))
    step = np.hypot(step, np.diff(z))
    travelled = np.concatenate([[0.0], np.cumsum(step)])
    keep = np.flatnonzero(np.diff(np.floor(travelled / spacing), prepend=-1.0) > 0).tolist()
    if keep[-1] != len(z) - 1:
        keep.append(len(z) - 1)
    return keep


def arms_min_distance(geometry, left_configs, right_configs, spacing=0.0):
    """The smallest distance between the left arm's forearm+tool segment in any of
    `left_configs` and the right arm's in any of `right_configs` (every pair, whatever the
    timing); with `spacing` > 0 only samples about that many metres of travel apart are
    compared (thin_path), and the result can then be up to 2 * `spacing` larger. The segments are
    horizontal, so a pair's distance is the plane distance combined with their difference in
    height."""
    import numpy as np
    segs = []
    for arm, configs in (('left', left_configs), ('right', right_configs)):
        elbow, tip, z = arm_segments(geometry, arm, configs)
        if spacing > 0.0:
            keep = thin_path((elbow, tip, z), spacing)
            elbow, tip, z = elbow[keep], tip[keep], z[keep]
        segs.append((elbow, tip, z))
    (le, lt, lz), (re_, rt, rz) = segs
    plane = _segments_distance_2d(le, lt, re_, rt)
    dz = lz[:, None] - rz[None, :]
    return float(np.sqrt(plane * plane + dz * dz).min())


class OverlapVerdict(object):
    """Whether two arm moves may run at once (`clear`), the smallest distance found between the
    arms over both paths (m, None when not computed) and why not (text)."""

    def __init__(self, clear, distance=None, why=''):
        self.clear = clear
        self.distance = distance
        self.why = why


#: m: arms that start closer than the clearance (both hands at one fruit) may overlap moves
#: that never bring them more than this closer than they start
START_TOLERANCE = 0.001


def overlap_clear(geometry, starts, goals, clearance, resolution=0.01, floor=None, coarse=3.0):
    """May the two arms move from `starts` to `goals` ({'left': joints, 'right': joints};
    a goal None = that arm rests) at the same time?

    Every configuration each arm passes through (its axes on their trapezoids at robot.yaml's
    speeds and accelerations, sampled so that every configuration is within `resolution` / 2
    of a sample) is checked against every configuration of the other arm, whatever the timing
    (either arm may start late, pause or be halted), on the forearm+tool segments that
    motion_pkg's kinematics keeps `arm_clearance` apart. Clear when the smallest distance found
    is `clearance` + `resolution` (the sampling's own error), or, for arms that start closer
    than that (both hands at one fruit), when they never come closer than they start; and in
    any case `floor` (default `clearance`) + `resolution`. An unknown start is not clear.

    A first look at `coarse` x `resolution` (paths sampled that much more sparsely) decides the
    moves that keep far apart: clear when even that look finds `clearance` + `resolution`
    plus its own error, which the fine look would then find too."""
    floor = clearance if floor is None else floor
    for arm in ('left', 'right'):
        if starts.get(arm) is None:
            return OverlapVerdict(False, why='%s arm position unknown' % arm)
        if goals.get(arm) is not None and len(goals[arm]) != 3:
            # a 4th value turns the waist, and both arms with it: never beside another move
            return OverlapVerdict(False, why='the %s arm\'s move turns the waist' % arm)
    speeds = [geometry.speed[j] for j in ('lift', 'boom', 'forearm')]
    accel = geometry.config.get('motion', {}).get('acceleration', {})
    accels = [float(accel.get(j, 3.0 * v)) for j, v in zip(('lift', 'boom', 'forearm'), speeds)]
    # fine samples (no point of the segment moves more than `resolution` / 8 between two, at
    # the axes' top speeds), thinned to those 3/8 `resolution` of travel apart: every
    # configuration of an arm on its way is within `resolution` / 2 of a compared one
    reach = geometry.boom + geometry.forearm + geometry.tool
    tool_speed = speeds[0] + reach * speeds[1] + (geometry.forearm + geometry.tool) * speeds[2]

    def smallest(step):
        dt = step / 8.0 / tool_speed
        paths = {arm: arm_path(starts[arm], goals.get(arm), speeds, accels, dt)
                 for arm in ('left', 'right')}
        return paths, arms_min_distance(geometry, paths['left'], paths['right'], 0.375 * step)

    if coarse > 1.0:
        _, distance = smallest(coarse * resolution)
        if distance >= max(clearance, floor) + resolution + coarse * resolution:
            return OverlapVerdict(True, distance)
    paths, distance = smallest(resolution)
    at_start = arms_min_distance(geometry, paths['left'][:1], paths['right'][:1])
    if distance < floor + resolution:
        return OverlapVerdict(False, distance, 'the arms would come %.3f m close (< %.3f m)'
                              % (distance, floor + resolution))
    if distance < clearance + resolution and distance < at_start - START_TOLERANCE:
        return OverlapVerdict(False, distance, 'the arms would come %.3f m close (< %.3f m, and '
                              'closer than the %.3f m they start at)'
                              % (distance, clearance + resolution, at_start))
    return OverlapVerdict(True, distance)


#: rad: a joint goal's waist angle this close to the waist's is no waist move
WAIST_TOLERANCE = 1e-3


def without_waist(goal, waist):
    """An arm's joint goal as [lift, boom, forearm] when its optional 4th value (the waist angle
    the move turns to) is where the waist already is (`waist`, rad; None: unknown); else as it
    is (a waist move: both arms turn with it)."""
    if goal is None or len(goal) != 4 or waist is None:
        return goal
    return tuple(goal[:3]) if abs(float(goal[3]) - float(waist)) <= WAIST_TOLERANCE else goal


def schedule_step(geometry, starts, goals, margin=0.0, waist=None):
    """The pipelined schedule's guard of one overlap: may the arms move from `starts` to `goals`
    at once (overlap_clear with robot.yaml's `arm_clearance` + `margin`)? A goal that turns the
    waist from `waist` never overlaps; without the robot's geometry nothing does."""
    if geometry is None:
        return OverlapVerdict(False, why='no robot geometry for the collision check')
    goals = dict((arm, without_waist(g, waist)) for arm, g in goals.items())
    return overlap_clear(geometry, starts, goals, float(geometry.arm_clearance) + float(margin),
                         floor=float(geometry.arm_clearance))
