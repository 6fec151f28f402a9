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
    return _segment_distance(a0[:, 0:1], a0[:, 1:2], a1[:, 0:1], a1[:, 1:2],      # n x 1
                             b0[None, :, 0], b0[None, :, 1], b1[None, :, 0], b1[None, :, 1])


def _segments_distance_pairs(a0, a1, b0, b1):
    """Distances between the 2-D segments a0[k]-a1[k] and b0[k]-b1[k] (arrays k x 2), pair
    by pair (_segments_distance_2d's diagonal)."""
    return _segment_distance(a0[:, 0], a0[:, 1], a1[:, 0], a1[:, 1],
                             b0[:, 0], b0[:, 1], b1[:, 0], b1[:, 1])


def _segment_distance(ax0, ay0, ax1, ay1, bx0, by0, bx1, by1):
    """Shortest distances between the 2-D segments (ax0, ay0)-(ax1, ay1) and
    (bx0, by0)-(bx1, by1), numpy-broadcast."""
    import numpy as np

    def point_segment2(px, py, sx, sy, ex, ey):
        """Squared distances of points (px, py) to segments (sx, sy)-(ex, ey), broadcast."""
        dx, dy = ex - sx, ey - sy
        dd = np.maximum(dx * dx + dy * dy, 1e-30)
        t = np.clip(((px - sx) * dx + (py - sy) * dy) / dd, 0.0, 1.0)
        qx, qy = px - sx - dx * t, py - sy - dy * t
        return qx * qx + qy * qy

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
    return _min_segment_distance(segs[0], segs[1])


def _pairs_distance(a, b):
    """Distances (n x m) between the n segments `a` and the m segments `b` ((start xy, end xy,
    height) each)."""
    import numpy as np
    plane = _segments_distance_2d(a[0], a[1], b[0], b[1])
    dz = a[2][:, None] - b[2][None, :]
    return np.sqrt(plane * plane + dz * dz)


#: samples per block of a path in _min_segment_distance
DISTANCE_BLOCK = 16


def _blocks(path, block):
    """Per block of `block` consecutive samples of a path (start xy, end xy, height), its
    bounding box: (lo, hi) arrays (blocks x 3) of x, y and height over both segment ends."""
    import numpy as np
    elbow, tip, z = path
    n = len(z)
    count = -(-n // block)
    pad = np.minimum(np.arange(count * block), n - 1)     # the last block repeats its last
    xyz = []
    for axis in (0, 1):
        both = np.stack([elbow[pad, axis], tip[pad, axis]], axis=1).reshape(count, -1)
        xyz.append((both.min(axis=1), both.max(axis=1)))
    zz = z[pad].reshape(count, block)
    xyz.append((zz.min(axis=1), zz.max(axis=1)))
    return np.stack([lo for lo, _ in xyz], axis=1), np.stack([hi for _, hi in xyz], axis=1)


def _min_segment_distance(a, b, block=DISTANCE_BLOCK):
    """The smallest distance between any segment of path `a` and any of path `b` (start xy,
    end xy, height each), exactly as every pair would give it, without computing every pair:
    the paths are cut into blocks of `block` samples; a block pair whose bounding boxes are
    farther apart than the nearest pair found so far cannot hold a nearer one. The nearest
    block pair by its boxes is computed first, then at once every block pair that could still
    beat it."""
    import numpy as np
    n, m = len(a[2]), len(b[2])
    if n * m <= 4 * block * block:
        return float(_pairs_distance(a, b).min())
    (alo, ahi), (blo, bhi) = _blocks(a, block), _blocks(b, block)
    gap = np.maximum(np.maximum(alo[:, None, :] - bhi[None, :, :],
                                blo[None, :, :] - ahi[:, None, :]), 0.0)
    bound = np.sqrt((gap * gap).sum(axis=2))                   # blocks(a) x blocks(b)
    i, j = np.unravel_index(int(np.argmin(bound)), bound.shape)

    def rows(path, k, length):
        idx = np.arange(k * block, min((k + 1) * block, length))
        return tuple(part[idx] for part in path)
    best = float(_pairs_distance(rows(a, i, n), rows(b, j, m)).min())
    bi, bj = np.nonzero(bound < best)
    if len(bi) == 0:
        return best
    # every sample pair of the remaining block pairs, one vectorised computation
    offs = np.arange(block)
    ia = np.minimum(bi[:, None] * block + offs[None, :], n - 1)     # pairs x block
    ib = np.minimum(bj[:, None] * block + offs[None, :], m - 1)
    ia = np.repeat(ia, block, axis=1).ravel()
    ib = np.tile(ib, (1, block)).ravel()
    plane = _segments_distance_pairs(a[0][ia], a[1][ia], b[0][ib], b[1][ib])
    dz = a[2][ia] - b[2][ib]
    return min(best, float(np.sqrt(plane * plane + dz * dz).min()))


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


def overlap_clear(geometry, starts, goals, clearance, resolution=0.01, floor=None):
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
    (About 1 ms, 2.5 ms at most, for moves between home, the box and the plant: the pairs
    are pruned by bounding boxes, _min_segment_distance.)"""
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

    dt = resolution / 8.0 / tool_speed
    paths = {arm: arm_path(starts[arm], goals.get(arm), speeds, accels, dt)
             for arm in ('left', 'right')}
    distance = arms_min_distance(geometry, paths['left'], paths['right'], 0.375 * resolution)
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
