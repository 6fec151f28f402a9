"""Circle fits for fruit outlines, rospy-free: least squares (Kasa), its robust refit, a RANSAC
arc fit that follows the largest arc of an outline cut by a leaf, the outline tests the
detector's hypotheses use (vision_pkg.detection, vision_pkg.regions), and fit_part: the circle of
a region part's outline on its convex hull, the one the hypotheses compare."""
import math

import cv2
import numpy as np


def _points(xs, ys):
    """(q, x0, y0): the points as the rows x, y, x^2 + y^2, 1 of a 4 x n array, relative to
    (x0, y0), their mean rounded (integer pixel coordinates stay exact). A subset's moment
    sums, all of them, are then one matrix product (_kasa), and a circle's squared distances
    to every point one more."""
    n = len(xs)
    xs = np.asarray(xs, dtype=np.float64)
    ys = np.asarray(ys, dtype=np.float64)
    x0 = float(round(float(xs.sum()) / n)) if n else 0.0
    y0 = float(round(float(ys.sum()) / n)) if n else 0.0
    q = np.empty((4, n))
    np.subtract(xs, x0, out=q[0])
    np.subtract(ys, y0, out=q[1])
    np.multiply(q[0], q[0], out=q[2])
    q[2] += q[1] * q[1]
    q[3] = 1.0
    return q, x0, y0


def _kasa(m):
    """Algebraic least-squares circle (Kasa) from the 4 x 4 moment matrix q q^T of points as
    _points gives them, in their coordinates: its 2 x 2 normal equations in coordinates
    centred on the points' mean. (cx, cy, r), or None (fewer than 5 points, or collinear)."""
    (sxx, sxy, sxz, sx), (_, syy, syz, sy), (_, _, _, sz), (_, _, _, n) = m.tolist()
    if n < 5:
        return None
    mx, my = sx / n, sy / n
    uu, vv, uv = sxx - sx * mx, syy - sy * my, sxy - sx * my
    det = uu * vv - uv * uv
    if det <= 1e-9 * max(uu * vv, 1e-12):
        return None
    # uz, vz: the sums of u z and v z (u, v centred on the mean, z = x^2 + y^2). Kasa's centre
    # solves [uu uv; uv vv] (cx, cy) = (uz, vz) / 2 (its normal equations in the centred
    # coordinates, written for the centre itself rather than its offset from the mean)
    uz, vz = sxz - mx * sz, syz - my * sz
    cx = 0.5 * (uz * vv - vz * uv) / det
    cy = 0.5 * (vz * uu - uz * uv) / det
    r2 = (cx - mx) ** 2 + (cy - my) ** 2 + (uu + vv) / n
    if r2 <= 0:
        return None
    return cx, cy, math.sqrt(r2)


def _robust_kasa(q, iterations=2, keep=0.8):
    """robust_fit_circle on points as _points gives them (their coordinates)."""
    circle = _kasa(q.dot(q.T))
    for _ in range(iterations):
        if circle is None:
            return None
        res = np.abs(np.hypot(q[0] - circle[0], q[1] - circle[1]) - circle[2])
        n = max(int(q.shape[1] * keep), 5)
        if n >= q.shape[1]:
            break
        q = q.take(np.argpartition(res, n - 1)[:n], axis=1)
        circle = _kasa(q.dot(q.T))
    return circle


def _support(circle, q, tol=1.0, rel=0.03):
    """Number of points (as _points gives them) within tol + rel * r of the circle (in their
    coordinates)."""
    cx, cy, r = circle
    return int(np.count_nonzero(np.abs(np.hypot(q[0] - cx, q[1] - cy) - r) <= tol + rel * r))


def fit_circle(xs, ys):
    """Algebraic least-squares circle (Kasa), solved in centred coordinates from its 2 x 2
    normal equations. Returns (cx, cy, r) or None (fewer than 5 points, or collinear)."""
    q, x0, y0 = _points(xs, ys)
    return _shifted(_kasa(q.dot(q.T)), x0, y0)


def robust_fit_circle(xs, ys, iterations=2, keep=0.8):
    """Kasa fit, then refits on the best `keep` fraction of points by radial residual."""
    q, x0, y0 = _points(xs, ys)
    return _shifted(_robust_kasa(q, iterations, keep), x0, y0)


def _shifted(circle, x0, y0):
    """A circle (cx, cy, r) moved by (x0, y0); None stays None."""
    return None if circle is None else (circle[0] + x0, circle[1] + y0, circle[2])


_TRIPLES = {}
_TRIPLE_INDEX = {}


def _triples(seed, trials):
    """trials x 3 uniform numbers in [0, 1) drawn once per (seed, trials): point triples."""
    key = (seed, trials)
    if key not in _TRIPLES:
        _TRIPLES[key] = np.random.default_rng(seed).random((trials, 3))
    return _TRIPLES[key]


def _triple_index(seed, trials, n):
    """The point triples of _triples(seed, trials) as indices into n points (kept per n:
    outlines of the same length recur)."""
    key = (seed, trials, n)
    idx = _TRIPLE_INDEX.get(key)
    if idx is None:
        if len(_TRIPLE_INDEX) >= 4096:
            _TRIPLE_INDEX.clear()
        idx = np.minimum((_triples(seed, trials) * n).astype(np.int64), n - 1)
        _TRIPLE_INDEX[key] = idx
    return idx


def arc_fit_circle(xs, ys, r_min, r_max, trials=60, seed=0):
    """Circle that the largest part of an outline follows (RANSAC over point triples, then a
    Kasa refit on its inliers), with r in [r_min, r_max]; None when none is found.

    A fruit partly behind a leaf has an outline of its own arc plus the leaf's edge; a
    least-squares fit over both shrinks the circle, the arc's own circle does not. Triples are
    drawn from a fixed seed, so the result is repeatable.
    """
    q, x0, y0 = _points(xs, ys)
    return _shifted(_arc_kasa(q, r_min, r_max, trials, seed), x0, y0)


def _arc_kasa(q, r_min, r_max, trials=60, seed=0):
    """arc_fit_circle on points as _points gives them (their coordinates)."""
    n = q.shape[1]
    if n < 8:
        return None
    idx = _triple_index(seed, trials, n)
    px, py = q[0].take(idx), q[1].take(idx)     # trials x 3
    (x1, x2, x3), (y1, y2, y3) = px.T, py.T
    d = 2.0 * (x1 * (y2 - y3) + x2 * (y3 - y1) + x3 * (y1 - y2))
    ok = np.abs(d) > 1e-6
    d = np.where(ok, d, 1.0)
    s1, s2, s3 = q[2].take(idx).T
    cx = (s1 * (y2 - y3) + s2 * (y3 - y1) + s3 * (y1 - y2)) / d
    cy = (s1 * (x3 - x2) + s2 * (x1 - x3) + s3 * (x2 - x1)) / d
    r = np.hypot(x1 - cx, y1 - cy)
    cand = np.flatnonzero(ok & (r >= r_min) & (r <= r_max))
    if not len(cand):
        return None
    cx, cy, r = cx[cand], cy[cand], r[cand]
    # support: points within 1 px + 3 % of r of each circle, from the squared distances of
    # every point to every centre as one matrix product (rows -2 cx, -2 cy, 1, cx^2 + cy^2)
    tol = 1.0 + 0.03 * r
    centres = np.empty((len(cx), 4))
    np.multiply(cx, -2.0, out=centres[:, 0])
    np.multiply(cy, -2.0, out=centres[:, 1])
    centres[:, 2] = 1.0
    centres[:, 3] = cx * cx + cy * cy
    d2 = centres.dot(q)                         # candidates x points
    within = (d2 >= (np.maximum(r - tol, 0.0) ** 2)[:, None]) & (d2 <= ((r + tol) ** 2)[:, None])
    support = within.sum(axis=1)
    best = int(np.argmax(support))
    if support[best] < 8:
        return None
    inliers = q[:, within[best]]
    refit = _kasa(inliers.dot(inliers.T))
    if refit is None or not r_min <= refit[2] <= r_max:
        return float(cx[best]), float(cy[best]), float(r[best])
    return refit


def circle_pixels(cx, cy, r, shape, samples=48):
    """(xs, ys, inside) of `samples` points evenly round a circle, rounded to pixels of an
    image of `shape` (rows, cols); inside: which of them lie in it."""
    a = np.linspace(0.0, 2.0 * math.pi, samples, endpoint=False)
    xs = np.rint(cx + r * np.cos(a)).astype(np.int64)
    ys = np.rint(cy + r * np.sin(a)).astype(np.int64)
    return xs, ys, (xs >= 0) & (ys >= 0) & (xs < shape[1]) & (ys < shape[0])


def outline_cover(outer, cx, cy, r, samples=48):
    """Fraction of a circle (crop pixels) that runs along outline pixels of a region (within
    1 px + 3 % of r): a fruit in front of another shows most of its outline, a circle inscribed
    in a strip of fruit colour touches it on two sides only."""
    xs, ys, ok = circle_pixels(cx, cy, r, outer.shape, samples)
    if not ok.any():
        return 0.0
    tol = int(math.ceil(1.0 + 0.03 * r))
    near = cv2.dilate(outer.astype(np.uint8), cv2.getStructuringElement(
        cv2.MORPH_ELLIPSE, (2 * tol + 1, 2 * tol + 1)))
    return float(np.sum(near[ys[ok], xs[ok]] > 0)) / samples


def own_arc_misfit(part, outer, cx, cy, r):
    """Median radial misfit / r of a part's outline pixels (those of `outer` on it; crop
    pixels) that do not lie outside the circle: outline beyond 1 px + 3 % of r from it is
    another fruit's, the one behind. 1.0 when fewer than 8 such pixels."""
    ys, xs = np.nonzero(outer & part)
    if len(xs) < 8:
        return 1.0
    d = np.hypot(xs - cx, ys - cy) - r
    own = np.abs(d[d <= 1.0 + 0.03 * r])
    if len(own) < 8:
        return 1.0
    return _median(own) / r


def hull_distance(hull, xs, ys, max_chord=0.0):
    """Distance of points to a convex polygon's boundary (points assumed inside or on it).

    Inside a convex polygon the nearest boundary point lies on the edge whose line is nearest,
    so the distance is the smallest distance to the edges' lines (no segment clipping).
    With `max_chord` > 0, points whose nearest edge is longer than max_chord x the polygon's
    equivalent radius (sqrt(area / pi)) get an infinite distance, but for the 1.5 px at either
    end of that edge: along a region's hull such an edge is a straight cut (a leaf's edge
    across a fruit, or the chord between two fruit), which a fruit's curved outline never
    makes, and its ends are where the fruit's own arc meets it."""
    pts = hull.reshape(-1, 2).astype(np.float64)
    # edge vectors to the next vertex, the last one closing the polygon
    ab = np.empty_like(pts)
    np.subtract(pts[1:], pts[:-1], out=ab[:-1])
    np.subtract(pts[0], pts[-1], out=ab[-1])
    length = np.sqrt(ab[:, 0] * ab[:, 0] + ab[:, 1] * ab[:, 1])
    if not length.min() > 1e-9:
        keep = length > 1e-9
        if not keep.any():
            return np.hypot(xs - pts[0, 0], ys - pts[0, 1])
        pts, ab, length = pts[keep], ab[keep], length[keep]
    # |cross(ab, p - a)| / |ab| for every edge and point, as one product of the edges' lines
    # (unit normal, minus offset) with the points in homogeneous coordinates
    lines = np.empty((len(ab), 3))
    np.divide(-ab[:, 1], length, out=lines[:, 0])
    np.divide(ab[:, 0], length, out=lines[:, 1])
    lines[:, 2] = -(pts[:, 0] * lines[:, 0] + pts[:, 1] * lines[:, 1])
    points = np.empty((3, len(xs)))
    points[0] = xs
    points[1] = ys
    points[2] = 1.0
    d = lines.dot(points)
    np.abs(d, out=d)
    if max_chord <= 0:
        return d.min(axis=0)
    near = d.argmin(axis=0)
    out = d[near, np.arange(len(near))]
    area = abs(cv2.contourArea(pts.astype(np.float32).reshape(-1, 1, 2)))
    cut = length[near] > max_chord * math.sqrt(area / math.pi)
    if cut.any():
        # the position along the nearest edge, from its first vertex
        along = ((xs - pts[near, 0]) * ab[near, 0] + (ys - pts[near, 1]) * ab[near, 1]) / \
            length[near]
        out[cut & (along > 1.5) & (along < length[near] - 1.5)] = np.inf
    return out


def fit_part(part, outer, peak_r, r_high=3.0, max_chord=0.0):
    """(cx, cy, r, residual) of the circle through the part's outer-boundary pixels that
    lie on its convex hull, radius in [0.8, r_high] x the inscribed radius `peak_r` (+2);
    residual = median radial misfit / r (1.0 for the fallback). With `max_chord` > 0 the
    pixels along the hull's straight cuts are left out (hull_distance), and there is no circle
    (None) when the hull has none."""
    part8 = (part if part.dtype == bool else part != 0).astype(np.uint8)     # 0 and 1 only
    # the work is done on the part's bounding box (+1 px): a part of a large cluster is
    # a small share of its region's crop
    bx, by, bw, bh = cv2.boundingRect(part8)
    if bw == 0 or bh == 0:
        return None
    x0, y0 = max(bx - 1, 0), max(by - 1, 0)
    x1, y1 = min(bx + bw + 1, part8.shape[1]), min(by + bh + 1, part8.shape[0])
    circle = _fit_crop(part8[y0:y1, x0:x1], outer[y0:y1, x0:x1], peak_r, r_high, max_chord)
    if circle is None:
        return None
    return (circle[0] + x0, circle[1] + y0) + tuple(circle[2:])


def _fit_crop(part8, outer, peak_r, r_high, max_chord=0.0):
    """fit_part() on a crop: part as 0/1 uint8."""
    ys, xs = np.nonzero(outer & part8.view(bool))      # part8 holds 0 and 1 only
    # area and centroid (cv2.moments' m00, m10, m01: exact integers either way) from the
    # column and row counts, cheaper than every moment up to the third order
    cols = part8.sum(axis=0, dtype=np.int64)
    m00 = float(cols.sum())
    if m00 <= 0:
        return None
    rows = part8.sum(axis=1, dtype=np.int64)
    mx = float(cols.dot(np.arange(len(cols)))) / m00
    my = float(rows.dot(np.arange(len(rows)))) / m00
    fallback = (mx, my, max(peak_r, math.sqrt(m00 / math.pi)), 1.0)
    if len(xs) < 8:
        return fallback
    # the hull of a region is the hull of its outline
    contours = cv2.findContours(part8, cv2.RETR_EXTERNAL, cv2.CHAIN_APPROX_SIMPLE)[-2]
    if not contours:
        return fallback
    hull = cv2.convexHull(np.vstack(contours))
    if hull is None or len(hull) < 3:
        return fallback
    dist = hull_distance(hull, xs, ys, max_chord)
    if max_chord > 0 and np.isfinite(dist).all():
        return None       # no straight cut to leave out
    on_hull = dist <= 1.5
    if on_hull.sum() >= 8:
        xs, ys = xs[on_hull], ys[on_hull]
    # the points relative to their rounded mean (_points), shared by every fit below
    q, x0, y0 = _points(xs, ys)
    r_lo, r_hi = 0.8 * peak_r, r_high * peak_r + 2.0
    circle = _robust_kasa(q)
    if circle is not None and not r_lo <= circle[2] <= r_hi:
        circle = None
    support = _support(circle, q) if circle is not None else 0
    arc = None
    if support < 0.9 * q.shape[1]:
        arc = _arc_kasa(q, r_lo, r_hi)
    if arc is not None and _support(arc, q) > support:
        # the outline is partly a straight or concave cut (a leaf or stem in front of the
        # fruit): the circle that most of the outline follows is the fruit
        circle = arc
    if circle is None:
        return fallback
    cx, cy, r = circle
    # the radius must be consistent with the inscribed radius, the centre near the part
    if r < r_lo or r > r_hi:
        return fallback
    if math.hypot(cx + x0 - mx, cy + y0 - my) > r:
        return fallback
    residual = _median(np.abs(np.hypot(q[0] - cx, q[1] - cy) - r)) / r
    cx, cy = cx + x0, cy + y0
    return cx, cy, r, residual


def _median(values):
    """np.median of a 1-D float array (the same value) without its overhead, which is most
    of its cost on the few hundred misfits of an outline."""
    n = len(values)
    half = n // 2
    if n % 2:
        return float(np.partition(values, half)[half])
    low, high = np.partition(values, (half - 1, half))[half - 1:half + 1]
    return float((low + high) / 2.0)
