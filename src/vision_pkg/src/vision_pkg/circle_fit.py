"""Circle fits for fruit outlines, rospy-free: least squares (Kasa), its robust refit, a RANSAC
arc fit that follows the largest arc of an outline cut by a leaf, and the outline tests the
detector's hypotheses use (vision_pkg.detection, vision_pkg.regions)."""
import math

import cv2
import numpy as np

def fit_circle(xs, ys):
    """Algebraic least-squares circle (Kasa), solved in centred coordinates from its 2 x 2
    normal equations. Returns (cx, cy, r) or None (fewer than 5 points, or collinear)."""
    n = len(xs)
    if n < 5:
        return None
    mx, my = float(np.mean(xs)), float(np.mean(ys))
    u = np.asarray(xs, dtype=np.float64) - mx
    v = np.asarray(ys, dtype=np.float64) - my
    uu, vv, uv = float(u.dot(u)), float(v.dot(v)), float(u.dot(v))
    det = uu * vv - uv * uv
    if det <= 1e-9 * max(uu * vv, 1e-12):
        return None
    w = u * u + v * v
    bu, bv = 0.5 * float(u.dot(w)), 0.5 * float(v.dot(w))
    uc = (bu * vv - bv * uv) / det
    vc = (bv * uu - bu * uv) / det
    r2 = uc * uc + vc * vc + (uu + vv) / n
    if r2 <= 0:
        return None
    return uc + mx, vc + my, math.sqrt(r2)


def robust_fit_circle(xs, ys, iterations=2, keep=0.8):
    """Kasa fit, then refits on the best `keep` fraction of points by radial residual."""
    circle = fit_circle(xs, ys)
    for _ in range(iterations):
        if circle is None:
            return None
        res = np.abs(np.hypot(xs - circle[0], ys - circle[1]) - circle[2])
        n = max(int(len(xs) * keep), 5)
        if n >= len(xs):
            break
        idx = np.argpartition(res, n - 1)[:n]
        xs, ys = xs[idx], ys[idx]
        circle = fit_circle(xs, ys)
    return circle


def count_support(circle, xs, ys, tol=1.0, rel=0.03):
    """Number of points within tol + rel * r of the circle."""
    cx, cy, r = circle
    return int(np.count_nonzero(np.abs(np.hypot(xs - cx, ys - cy) - r) <= tol + rel * r))


_TRIPLES = {}


def _triples(seed, trials):
    """trials x 3 uniform numbers in [0, 1) drawn once per (seed, trials): point triples."""
    key = (seed, trials)
    if key not in _TRIPLES:
        _TRIPLES[key] = np.random.default_rng(seed).random((trials, 3))
    return _TRIPLES[key]


def arc_fit_circle(xs, ys, r_min, r_max, trials=60, seed=0):
    """Circle that the largest part of an outline follows (RANSAC over point triples, then a
    Kasa refit on its inliers), with r in [r_min, r_max]; None when none is found.

    A fruit partly behind a leaf has an outline of its own arc plus the leaf's edge; a
    least-squares fit over both shrinks the circle, the arc's own circle does not. Triples are
    drawn from a fixed seed, so the result is repeatable.
    """
    n = len(xs)
    if n < 8:
        return None
    idx = np.minimum((_triples(seed, trials) * n).astype(np.int64), n - 1)
    x1, x2, x3 = xs[idx[:, 0]], xs[idx[:, 1]], xs[idx[:, 2]]
    y1, y2, y3 = ys[idx[:, 0]], ys[idx[:, 1]], ys[idx[:, 2]]
    d = 2.0 * (x1 * (y2 - y3) + x2 * (y3 - y1) + x3 * (y1 - y2))
    ok = np.abs(d) > 1e-6
    if not ok.any():
        return None
    d = np.where(ok, d, 1.0)
    s1, s2, s3 = x1 * x1 + y1 * y1, x2 * x2 + y2 * y2, x3 * x3 + y3 * y3
    cx = (s1 * (y2 - y3) + s2 * (y3 - y1) + s3 * (y1 - y2)) / d
    cy = (s1 * (x3 - x2) + s2 * (x1 - x3) + s3 * (x2 - x1)) / d
    r = np.hypot(x1 - cx, y1 - cy)
    ok &= (r >= r_min) & (r <= r_max)
    if not ok.any():
        return None
    cand = np.flatnonzero(ok)
    res = np.abs(np.hypot(xs[None, :] - cx[cand, None], ys[None, :] - cy[cand, None])
                 - r[cand, None])
    support = (res <= 1.0 + 0.03 * r[cand, None]).sum(axis=1)
    best = cand[int(np.argmax(support))]
    inliers = res[int(np.argmax(support))] <= 1.0 + 0.03 * r[best]
    if inliers.sum() < 8:
        return None
    refit = fit_circle(xs[inliers], ys[inliers])
    if refit is None or not r_min <= refit[2] <= r_max:
        return float(cx[best]), float(cy[best]), float(r[best])
    return refit


def outline_cover(outer, cx, cy, r, samples=48):
    """Fraction of a circle (crop pixels) that runs along outline pixels of a region (within
    1 px + 3 % of r): a fruit in front of another shows most of its outline, a circle inscribed
    in a strip of fruit colour touches it on two sides only."""
    height, width = outer.shape
    a = np.linspace(0.0, 2.0 * math.pi, samples, endpoint=False)
    xs = np.rint(cx + r * np.cos(a)).astype(np.int64)
    ys = np.rint(cy + r * np.sin(a)).astype(np.int64)
    ok = (xs >= 0) & (ys >= 0) & (xs < width) & (ys < height)
    if not ok.any():
        return 0.0
    tol = int(math.ceil(1.0 + 0.03 * r))
    near = cv2.dilate(outer.astype(np.uint8), cv2.getStructuringElement(
        cv2.MORPH_ELLIPSE, (2 * tol + 1, 2 * tol + 1)))
    return float(np.sum(near[ys[ok], xs[ok]] > 0)) / samples


def hull_distance(hull, xs, ys):
    """Distance of points to a convex polygon's boundary (points assumed inside or on it).

    Inside a convex polygon the nearest boundary point lies on the edge whose line is nearest,
    so the distance is the smallest distance to the edges' lines (no segment clipping)."""
    pts = hull.reshape(-1, 2).astype(np.float64)
    ab = np.roll(pts, -1, axis=0) - pts
    length = np.sqrt((ab * ab).sum(1))
    keep = length > 1e-9
    if not keep.any():
        return np.hypot(xs - pts[0, 0], ys - pts[0, 1])
    pts, ab, length = pts[keep], ab[keep], length[keep]
    # |cross(ab, p - a)| / |ab| for every point and edge: (n x 2) . (2 x m) minus a constant
    normal = np.stack([-ab[:, 1], ab[:, 0]]) / length
    offset = (pts * normal.T).sum(1)
    p = np.column_stack([xs, ys]).astype(np.float64)
    return np.abs(p.dot(normal) - offset).min(axis=1)
