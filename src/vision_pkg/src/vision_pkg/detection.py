"""Tomato detection by colour and shape feature fusion (section 3.5.1.2), rospy-free.

Pipeline for one BGR image (run at ~scale for speed, results in full-resolution pixels):
  1. colour evidence: HSV hue/saturation/value gate for fruit colours (red through yellow-green,
     i.e. not leaf green), so green, turning, pink and red fruit all enter the candidate mask;
  2. shape evidence: the distance transform of each connected candidate region; its local maxima
     (non-maximum suppressed) are fruit centres, which splits touching fruit in a cluster; the
     region's pixels go to the nearest centre in the power-diagram sense (|x - c|^2 - r^2);
  3. a circle fitted to each part's outer boundary points that lie on its convex hull (leaf
     notches and the cut between touching fruit are ignored), validated by fill ratio and by
     the fraction of the part inside the circle; green parts must look rounder than ripe ones;
  4. ripeness from the mean colour of the fruit skin (highlights, clipped and deep-shadow pixels
     excluded) as its red chromaticity r = R / (R + G + B): independent of brightness and
     shading, and monotone from mature green (~0.30) through turning and pink to deep red
     (~0.88). A piecewise-linear calibration curve (score_chroma -> score_values, measured on
     the simulated crop, see README) maps it to a 0..1 score, then to the four stages
     green < 0.25 <= turning < 0.5 <= pink < 0.7 <= red. The CIE Lab hue angle is kept for
     diagnostics.
"""
import math

import cv2
import numpy as np

STAGE_GREEN, STAGE_TURNING, STAGE_PINK, STAGE_RED = 0, 1, 2, 3
STAGE_NAMES = ('green', 'turning', 'pink', 'red')
#: score thresholds between consecutive stages
STAGE_THRESHOLDS = (0.25, 0.5, 0.7)

#: default parameters (ROS params of the same names override them; see config/detection.yaml)
DEFAULTS = {
    'scale': 0.5,               # processing scale of the input image
    'min_radius_px': 20.0,      # smallest fruit radius [px, full resolution]
    'max_radius_px': 200.0,     # largest fruit radius [px, full resolution]
    'hue_max': 42,              # fruit hue band: OpenCV hue (0..180) <= hue_max or >= hue_wrap
    'hue_wrap': 165,
    'sat_min': 80,              # HSV saturation floor of fruit skin (0..255)
    'val_min': 10,              # HSV value floor (0..255)
    'min_fill': 0.35,           # part area / fitted circle area, ripe-coloured fruit
    'min_fill_green': 0.6,      # same for green-coloured fruit (stricter: leaves are green)
    'min_inside': 0.85,         # fraction of the part's pixels inside its fitted circle
    'peak_separation': 0.75,    # NMS: a peak closer than this x the stronger radius is merged
    'single_fit_residual_px': 0.9,  # a region whose outline fits one circle within this median
                                    # misfit [px at ~scale] (and better than its parts) is one fruit
    'join_residual_px': 1.2,    # two overlapping parts whose joint outline fits one circle within
                                # this median misfit [px at ~scale] are one fruit (leaf-cut outline)
    'hue_split': 15,            # OpenCV hue: red/orange pass up to here, then the whole band
    'open_px': 5,               # opening kernel [px at ~scale]: removes stems and twine
    'close_px': 5,              # closing kernel [px at ~scale]: bridges stems in front of fruit
    'merge_score_diff': 0.25,   # fragments of one fruit: at most this ripeness-score apart
    # ripeness calibration: red chromaticity knots and the scores they map to (monotone)
    'score_chroma': [0.30, 0.36, 0.42, 0.46, 0.50, 0.534, 0.62, 0.70, 0.766, 0.81, 0.842, 0.875],
    'score_values': [0.0, 0.175, 0.275, 0.325, 0.425, 0.525, 0.625, 0.70, 0.825, 0.925, 0.975,
                     1.0],
}


def stage_of(score):
    """Ripeness stage (STAGE_*) of a 0..1 ripeness score."""
    for stage, threshold in enumerate(STAGE_THRESHOLDS):
        if score < threshold:
            return stage
    return STAGE_RED


class Detection(object):
    """One detected fruit, in full-resolution pixel coordinates of the input image."""

    __slots__ = ('u', 'v', 'radius_px', 'score', 'stage', 'fill', 'area_px', 'mask',
                 'mask_origin', 'mask_scale', 'hue_angle', 'chroma')

    def __init__(self, u, v, radius_px, score, mask=None, mask_origin=(0, 0), mask_scale=1.0,
                 fill=1.0, area_px=0.0, hue_angle=float('nan'), chroma=float('nan')):
        self.u = float(u)
        self.v = float(v)
        self.radius_px = float(radius_px)
        self.score = float(score)
        self.stage = stage_of(self.score)
        self.mask = mask                  # bool crop of the fruit part at mask_scale
        self.mask_origin = mask_origin    # (x, y) of the crop in mask_scale pixels
        self.mask_scale = mask_scale
        self.fill = float(fill)
        self.area_px = float(area_px)
        self.hue_angle = float(hue_angle)
        self.chroma = float(chroma)

    def box(self, width=None, height=None):
        """(x, y, w, h) integer box around the fitted circle, clipped to the image if given."""
        x0 = int(math.floor(self.u - self.radius_px))
        y0 = int(math.floor(self.v - self.radius_px))
        x1 = int(math.ceil(self.u + self.radius_px))
        y1 = int(math.ceil(self.v + self.radius_px))
        if width is not None:
            x0, x1 = max(x0, 0), min(x1, width)
        if height is not None:
            y0, y1 = max(y0, 0), min(y1, height)
        return x0, y0, max(x1 - x0, 0), max(y1 - y0, 0)

    def contains(self, u, v):
        """Vectorised: is full-resolution pixel (u, v) on this fruit's visible part?"""
        u = np.asarray(u, dtype=np.float64)
        v = np.asarray(v, dtype=np.float64)
        finite = np.isfinite(u) & np.isfinite(v)
        u = np.where(finite, u, -1e6)
        v = np.where(finite, v, -1e6)
        inside = (u - self.u) ** 2 + (v - self.v) ** 2 <= self.radius_px ** 2
        if self.mask is None:
            return inside
        mx = np.floor(u * self.mask_scale).astype(np.int64) - self.mask_origin[0]
        my = np.floor(v * self.mask_scale).astype(np.int64) - self.mask_origin[1]
        h, w = self.mask.shape
        ok = inside & (mx >= 0) & (my >= 0) & (mx < w) & (my < h)
        out = np.zeros(ok.shape, dtype=bool)
        out[ok] = self.mask[my[ok], mx[ok]]
        return out

    def __repr__(self):
        return 'Detection(u=%.1f, v=%.1f, r=%.1f, score=%.2f, %s)' % (
            self.u, self.v, self.radius_px, self.score, STAGE_NAMES[self.stage])


def fit_circle(xs, ys):
    """Algebraic least-squares circle (Kasa). Returns (cx, cy, r) or None."""
    if len(xs) < 5:
        return None
    a = np.column_stack([xs, ys, np.ones(len(xs))])
    b = -(xs * xs + ys * ys)
    try:
        sol, _, rank, _ = np.linalg.lstsq(a, b, rcond=None)
    except np.linalg.LinAlgError:
        return None
    if rank < 3:
        return None
    cx, cy = -sol[0] / 2.0, -sol[1] / 2.0
    r2 = cx * cx + cy * cy - sol[2]
    if r2 <= 0:
        return None
    return cx, cy, math.sqrt(r2)


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


def _support(circle, xs, ys, tol=1.0, rel=0.03):
    """Number of points within tol + rel * r of the circle."""
    cx, cy, r = circle
    return int(np.count_nonzero(np.abs(np.hypot(xs - cx, ys - cy) - r) <= tol + rel * r))


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
    rng = np.random.default_rng(seed)
    idx = rng.integers(0, n, size=(trials, 3))
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


class TomatoDetector(object):
    """Finds tomatoes in BGR images; parameters as in DEFAULTS."""

    def __init__(self, **params):
        unknown = set(params) - set(DEFAULTS)
        if unknown:
            raise ValueError('unknown detector parameters: %s' % sorted(unknown))
        self.params = dict(DEFAULTS)
        self.params.update(params)

    def update(self, **params):
        """Change parameters at run time (dynamic_reconfigure)."""
        for key, value in params.items():
            if key in DEFAULTS:
                self.params[key] = type(DEFAULTS[key])(value)
        if len(self.params['score_chroma']) != len(self.params['score_values']):
            raise ValueError('score_chroma and score_values must have the same length')

    # -- colour -------------------------------------------------------------------------------
    def colour_mask(self, hsv, hue_max=None):
        """Fruit-colour pixels: hue <= hue_max (default ~hue_max) or >= ~hue_wrap, S, V floors."""
        p = self.params
        h, s, v = cv2.split(hsv)
        top = int(p['hue_max'] if hue_max is None else hue_max)
        hue_ok = cv2.bitwise_or(cv2.inRange(h, 0, top), cv2.inRange(h, int(p['hue_wrap']), 180))
        sv_ok = cv2.bitwise_and(cv2.inRange(s, int(p['sat_min']), 255),
                                cv2.inRange(v, int(p['val_min']), 255))
        return cv2.bitwise_and(hue_ok, sv_ok)

    def _clean(self, mask):
        """Opening removes stems, twine and speckle; closing bridges thin gaps on the fruit."""
        p = self.params
        for op, size in ((cv2.MORPH_OPEN, int(p['open_px'])), (cv2.MORPH_CLOSE,
                                                                 int(p['close_px']))):
            if size > 1:
                mask = cv2.morphologyEx(mask, op, cv2.getStructuringElement(
                    cv2.MORPH_ELLIPSE, (size, size)))
        return mask

    def score_of(self, bgr_pixels):
        """(score, red chromaticity, Lab hue angle [deg]) of an Nx3 uint8 BGR skin sample."""
        if len(bgr_pixels) == 0:
            return 0.0, float('nan'), float('nan')
        mean = bgr_pixels.reshape(-1, 3).astype(np.float64).mean(axis=0)
        total = float(mean.sum())
        chroma = float(mean[2]) / total if total > 0 else 0.0
        lab = cv2.cvtColor(np.uint8(np.clip(mean + 0.5, 0, 255)).reshape(1, 1, 3),
                           cv2.COLOR_BGR2LAB).reshape(3).astype(np.float64) - 128.0
        angle = math.degrees(math.atan2(lab[2], lab[1]))
        p = self.params
        score = float(np.interp(chroma, p['score_chroma'], p['score_values']))
        return min(max(score, 0.0), 1.0), chroma, angle

    # -- main ---------------------------------------------------------------------------------
    def detect(self, bgr):
        """Detect tomatoes in a BGR uint8 image. Returns a list of Detection."""
        p = self.params
        scale = float(p['scale'])
        if scale != 1.0:
            small = cv2.resize(bgr, None, fx=scale, fy=scale, interpolation=cv2.INTER_AREA)
        else:
            small = bgr
        hsv = cv2.cvtColor(small, cv2.COLOR_BGR2HSV)
        r_min = p['min_radius_px'] * scale
        r_max = p['max_radius_px'] * scale
        # pass 1: red to orange (pink and red fruit, the red side of turning ones)
        red = self._candidates(self._clean(self.colour_mask(hsv, p['hue_split'])), small, hsv,
                               r_min, r_max, scale, strict=False)
        # pass 2: the whole fruit band, which also takes in yellowish stems, twine and leaves
        # in dim warm light: only round, well-filled fruit not already found in pass 1
        full = self._candidates(self._clean(self.colour_mask(hsv)), small, hsv, r_min, r_max,
                                scale, strict=True)
        found = list(red)
        for det in full:
            if all(math.hypot(det.u - o.u, det.v - o.v) > 0.8 * max(det.radius_px, o.radius_px)
                   for o in red):
                found.append(det)
        return self._merge_fragments(found)

    def _candidates(self, mask, small, hsv, r_min, r_max, scale, strict):
        count, labels, stats, _ = cv2.connectedComponentsWithStats(mask, connectivity=8)
        height, width = mask.shape
        detections = []
        for label in range(1, count):
            x, y, w, h, area = stats[label]
            if area < math.pi * r_min * r_min * 0.3 or max(w, h) < 1.5 * r_min:
                continue
            x0, y0 = max(x - 1, 0), max(y - 1, 0)
            x1, y1 = min(x + w + 1, width), min(y + h + 1, height)
            comp = _fill_holes((labels[y0:y1, x0:x1] == label).astype(np.uint8))
            detections.extend(self._split_component(comp, (x0, y0), small, hsv, r_min, r_max,
                                                    scale, (width, height), strict))
        return detections

    def _merge_fragments(self, detections):
        """Drop fragments whose centre lies inside a larger, similarly coloured fruit.

        A fruit cut into pieces by a stem or a leaf in front of it gives several parts; the
        largest fitted circle stands for the fruit and the smaller ones inside it go.
        """
        keep = []
        for det in sorted(detections, key=lambda d: -d.radius_px):
            host = None
            for big in keep:
                if math.hypot(det.u - big.u, det.v - big.v) < 0.9 * big.radius_px and \
                        abs(det.score - big.score) <= self.params['merge_score_diff']:
                    host = big
                    break
            if host is None:
                keep.append(det)
        return keep

    def _peaks(self, dist, r_min):
        """Non-maximum-suppressed distance-transform maxima: list of (x, y, r)."""
        dil = cv2.dilate(dist, cv2.getStructuringElement(cv2.MORPH_RECT, (5, 5)))
        ys, xs = np.nonzero((dist >= dil) & (dist >= max(r_min * 0.6, 1.5)))
        if len(xs) == 0:
            return []
        values = dist[ys, xs]
        order = np.argsort(-values)
        sep = self.params['peak_separation']
        peaks = []
        for i in order:
            px, py, pr = float(xs[i]), float(ys[i]), float(values[i])
            if all(math.hypot(px - qx, py - qy) > sep * max(qr, pr) + 1.0
                   for qx, qy, qr in peaks):
                peaks.append((px, py, pr))
        return peaks

    def _split_component(self, comp, origin, small, hsv, r_min, r_max, scale, size, strict):
        p = self.params
        dist = cv2.distanceTransform(comp, cv2.DIST_L2, 5)
        peaks = self._peaks(dist, r_min)
        if not peaks:
            return []
        ys, xs = np.nonzero(comp)
        if len(peaks) == 1:
            owner = np.zeros(len(xs), dtype=np.int64)
        else:
            c = np.array(peaks)
            power = ((xs[:, None] - c[None, :, 0]) ** 2 + (ys[:, None] - c[None, :, 1]) ** 2
                     - c[None, :, 2] ** 2)
            owner = np.argmin(power, axis=1)
        parts = np.full(comp.shape, -1, dtype=np.int32)
        parts[ys, xs] = owner
        # outer boundary of the whole component (pixels with a background 4-neighbour)
        eroded = cv2.erode(comp, cv2.getStructuringElement(cv2.MORPH_CROSS, (3, 3)),
                           borderType=cv2.BORDER_CONSTANT, borderValue=0)
        outer = (comp > 0) & (eroded == 0)
        ox, oy = origin
        width, height = size
        # boundary pixels on the image border are not fruit edges
        gy, gx = np.nonzero(outer)
        on_border = (gx + ox <= 0) | (gy + oy <= 0) | (gx + ox >= width - 1) | \
            (gy + oy >= height - 1)
        outer[gy[on_border], gx[on_border]] = False
        # hypothesis A: one fruit per distance-transform peak (power-diagram parts)
        candidates = []          # (part mask, circle)
        peak_rs = []
        for k, (px, py, pr) in enumerate(peaks):
            part = (parts == k)
            if part.sum() < math.pi * r_min * r_min * 0.3:
                continue
            circle = self._fit_part(part, outer, pr)
            if circle is not None:
                candidates.append((part, circle))
                peak_rs.append(pr)
        if len(candidates) > 1:
            candidates = self._join_parts(candidates, peak_rs, outer)
        if len(peaks) > 1:
            # hypothesis B: one fruit seen in pieces (a leaf or stem in front of it) also has
            # several peaks; keep it whole when one circle explains its outline at least as
            # well as the parts explain theirs
            whole = self._fit_part(comp > 0, outer, max(pk[2] for pk in peaks))
            if whole is not None and whole[3] * whole[2] <= p['single_fit_residual_px']:
                areas = [float(c[0].sum()) for c in candidates]
                split = sum(a * c[1][3] for a, c in zip(areas, candidates)) / sum(areas) \
                    if candidates else 1.0
                pys, pxs = np.nonzero(comp)
                cx, cy, r = whole[:3]
                if whole[3] <= split and np.mean(
                        (pxs - cx) ** 2 + (pys - cy) ** 2 <= (r + 1.5) ** 2) >= p['min_inside']:
                    candidates = [(comp > 0, whole)]
        results = []
        for part, circle in candidates:
            area = int(part.sum())
            cx, cy, r = circle[:3]
            if r < r_min or r > r_max:
                continue
            pys, pxs = np.nonzero(part)
            inside = float(np.mean((pxs - cx) ** 2 + (pys - cy) ** 2 <= (r + 1.5) ** 2))
            fill = area / (math.pi * r * r)
            # skin pixels for colour: inside 0.85 r, not highlight, not deep shadow
            skin = ((pxs - cx) ** 2 + (pys - cy) ** 2 <= (0.85 * r) ** 2)
            sy, sx = pys[skin] + oy, pxs[skin] + ox
            hsv_px = hsv[sy, sx]
            bgr_px = small[sy, sx]
            good = (hsv_px[:, 2] > 2 * p['val_min']) & ~((hsv_px[:, 1] < 60) & (hsv_px[:, 2] > 200)) & \
                (bgr_px.max(axis=1) < 250)
            score, chroma, angle = self.score_of(bgr_px[good])
            min_fill = p['min_fill_green'] if strict or score < STAGE_THRESHOLDS[0] else \
                p['min_fill']
            if inside < p['min_inside'] or fill < min_fill:
                continue
            x0 = max(int(math.floor(cx - r)) - 1, 0)
            y0 = max(int(math.floor(cy - r)) - 1, 0)
            crop = part[y0:int(math.ceil(cy + r)) + 2, x0:int(math.ceil(cx + r)) + 2]
            results.append(Detection(
                (cx + ox + 0.5) / scale - 0.5, (cy + oy + 0.5) / scale - 0.5, r / scale, score,
                mask=crop.copy(), mask_origin=(x0 + ox, y0 + oy), mask_scale=scale,
                fill=fill, area_px=area / (scale * scale), hue_angle=angle, chroma=chroma))
        return results

    def _join_parts(self, candidates, peak_rs, outer):
        """Hypothesis C: two neighbouring parts are one fruit (a leaf or calyx notch in its
        outline made two distance-transform peaks) when their circles overlap, one circle
        follows their joint outline within `join_residual_px` (median) and holds `min_inside`
        of their pixels. (Small parts fit their own short arcs almost exactly, so comparing
        with the parts' fits, as hypothesis B does, would keep them apart.) Greedy, best first."""
        p = self.params
        kernel = cv2.getStructuringElement(cv2.MORPH_RECT, (3, 3))
        cands = [(part, circle, pr) for (part, circle), pr in zip(candidates, peak_rs)]
        while len(cands) > 1:
            best = None
            for i in range(len(cands)):
                grown = None
                for j in range(i + 1, len(cands)):
                    (xi, yi, ri), (xj, yj, rj) = cands[i][1][:3], cands[j][1][:3]
                    if math.hypot(xi - xj, yi - yj) > 0.9 * (ri + rj):
                        continue      # two whole fruit side by side, not halves of one
                    if grown is None:
                        grown = cv2.dilate(cands[i][0].astype(np.uint8), kernel) > 0
                    if not np.any(grown & cands[j][0]):
                        continue
                    union = cands[i][0] | cands[j][0]
                    fit = self._fit_part(union, outer, max(cands[i][2], cands[j][2]))
                    if fit is None or fit[3] * fit[2] > p['join_residual_px']:
                        continue
                    pys, pxs = np.nonzero(union)
                    cx, cy, r = fit[:3]
                    if np.mean((pxs - cx) ** 2 + (pys - cy) ** 2 <= (r + 1.5) ** 2) < p['min_inside']:
                        continue
                    if best is None or fit[3] < best[0]:
                        best = (fit[3], i, j, union, fit)
            if best is None:
                break
            _, i, j, union, fit = best
            joined = (union, fit, max(cands[i][2], cands[j][2]))
            cands = [c for k, c in enumerate(cands) if k not in (i, j)] + [joined]
        return [(part, circle) for part, circle, _ in cands]

    @staticmethod
    def _fit_part(part, outer, peak_r):
        """(cx, cy, r, residual) of the circle through the part's outer-boundary pixels that
        lie on its convex hull; residual = median radial misfit / r (1.0 for the fallback)."""
        edge = part & outer
        ys, xs = np.nonzero(edge)
        pys, pxs = np.nonzero(part)
        if len(pxs) == 0:
            return None
        mx, my = float(pxs.mean()), float(pys.mean())
        fallback = (mx, my, max(peak_r, math.sqrt(len(pxs) / math.pi)), 1.0)
        if len(xs) < 8:
            return fallback
        hull = cv2.convexHull(np.column_stack([pxs, pys]).astype(np.int32))
        if hull is None or len(hull) < 3:
            return fallback
        on_hull = _hull_distance(hull, xs, ys) <= 1.5
        if on_hull.sum() >= 8:
            xs, ys = xs[on_hull], ys[on_hull]
        xs = xs.astype(np.float64)
        ys = ys.astype(np.float64)
        circle = robust_fit_circle(xs, ys)
        support = _support(circle, xs, ys) if circle is not None else 0
        arc = None
        if support < 0.9 * len(xs):
            arc = arc_fit_circle(xs, ys, 0.8 * peak_r, 3.0 * peak_r + 2.0)
        if arc is not None and _support(arc, xs, ys) > support:
            # the outline is partly a straight or concave cut (a leaf or stem in front of the
            # fruit): the circle that most of the outline follows is the fruit
            circle = arc
        if circle is None:
            return fallback
        cx, cy, r = circle
        # the radius must be consistent with the inscribed radius, the centre near the part
        if r < 0.8 * peak_r or r > 3.0 * peak_r + 2.0:
            return fallback
        if math.hypot(cx - mx, cy - my) > r:
            return fallback
        residual = float(np.median(np.abs(np.hypot(xs - cx, ys - cy) - r))) / r
        return cx, cy, r, residual


def _fill_holes(comp):
    """Fill the holes of a 0/1 uint8 region (highlights, dark spots on the skin)."""
    padded = cv2.copyMakeBorder(comp, 1, 1, 1, 1, cv2.BORDER_CONSTANT, value=0)
    flood = padded.copy()
    ffmask = np.zeros((padded.shape[0] + 2, padded.shape[1] + 2), np.uint8)
    cv2.floodFill(flood, ffmask, (0, 0), 1)
    holes = flood[1:-1, 1:-1] == 0
    out = comp.copy()
    out[holes] = 1
    return out


def _hull_distance(hull, xs, ys):
    """Distance of points to a convex polygon's boundary (points assumed inside)."""
    pts = hull.reshape(-1, 2).astype(np.float64)
    a = pts
    b = np.roll(pts, -1, axis=0)
    ab = b - a
    len2 = np.maximum((ab * ab).sum(1), 1e-9)
    px = xs.astype(np.float64)[:, None]
    py = ys.astype(np.float64)[:, None]
    t = np.clip(((px - a[None, :, 0]) * ab[None, :, 0] + (py - a[None, :, 1]) * ab[None, :, 1])
                / len2[None, :], 0.0, 1.0)
    dx = px - (a[None, :, 0] + t * ab[None, :, 0])
    dy = py - (a[None, :, 1] + t * ab[None, :, 1])
    return np.sqrt(dx * dx + dy * dy).min(axis=1)
