"""Tomato detection by colour and shape feature fusion (section 3.5.1.2), rospy-free.

Made to hold on real photographs as well as on harvest_sim's renders. For one BGR image:
  0. working copy: resized to ~scale, and at most ~max_work_width pixels wide, so the cost per
     frame is bounded whatever the camera (results come back in full-resolution pixels);
  1. colour constancy: the scene's illuminant is estimated from its brightest unclipped pixels
     among those an illuminant could have tinted from white or grey (white film, pipes,
     specular highlights: a white reference from the scene; daylight, warm light and red/blue
     LED casts lie near neutral, red fruit and green leaves do not) and divided out with
     per-channel gains; without such a reference the image is left as it is;
  2. colour evidence on the balanced image (OpenCV HSV): "ripe colours" (red, orange, pink:
     hue <= ~hue_max or >= ~hue_wrap, saturated: skin and wood are paler) and "green-fruit
     colours" (yellow-green to green); a ripe-colour mask is closed once more with a larger
     kernel (~bridge_px) through green or dark pixels only, so sepals and stems across a fruit
     do not cut it into pieces (those bridged pixels never count for its colour);
  3. shape evidence: connected regions, the distance transform's peaks split touching fruit
     (power diagram), a robust circle fit on outline pixels on the convex hull (leaf notches
     ignored; a RANSAC arc fit when a leaf edge cuts the outline), one-circle vs split vs
     joined-parts hypotheses compared by outline misfit; validated by fill ratio and by the
     fraction of the part inside the circle;
  4. green fruit share their colour with leaves, so a region with green-fruit colour (pass 2,
     at ~green_scale of the working size) is a fruit only when its shape and surface say so:
     a part no larger than ~max_area_ratio times its inscribed circle (leaf strips are
     longer), an outline that one circle follows (median misfit <= ~max_residual_green), a
     well filled disc (~min_fill_outline), and a brightness edge along most of the circle
     (~min_edge_support): a smooth, shaded sphere ends in an edge all round, a leaf's outline
     does not follow a circle;
  5. ripeness from the skin's colour on the balanced image: every skin pixel's hue (highlights,
     clipped and dark pixels excluded) maps to a per-pixel ripeness through a monotone
     piecewise-linear curve (score_hue -> score_values), desaturated pixels are pulled
     towards the middle (pale pink is not deep red), and the fruit's score is their mean, so
     a fruit half green and half red scores in between, as the colour-chart stages do:
     green < 0.25 <= turning < 0.5 <= pink < 0.7 <= red. Calibration and its source: README.
Cost is bounded by design: pixel work is vectorised OpenCV/numpy at the working size, regions
too small are rejected from their statistics before any per-region work, at most
~max_regions regions per pass (largest first) and ~max_peaks fruit per region are examined.
"""
import math

import cv2
import numpy as np

STAGE_GREEN, STAGE_TURNING, STAGE_PINK, STAGE_RED = 0, 1, 2, 3
STAGE_NAMES = ('green', 'turning', 'pink', 'red')
#: score thresholds between consecutive stages
STAGE_THRESHOLDS = (0.25, 0.5, 0.7)

#: default parameters (ROS params of the same names override them; see config/*.yaml)
DEFAULTS = {
    'scale': 0.5,               # processing scale of the input image
    'max_work_width': 640,      # ... and at most this many pixels wide (0: no cap)
    'min_radius_px': 20.0,      # smallest fruit radius [px, full resolution]
    'max_radius_px': 200.0,     # largest fruit radius [px, full resolution]
    # colour constancy (white reference from the scene's brightest pixels)
    'white_balance': True,
    'wb_top_fraction': 0.02,    # brightest fraction of the reference candidates averaged
    'wb_chroma_box': 0.16,      # candidates: each chromaticity within this of 1/3 ...
    'wb_max_green': 0.36,       # ... and green chromaticity at most this (no light is green)
    'wb_min_fraction': 0.003,   # fewer candidates (share of the pixels): no white reference
    'wb_max_gain': 2.0,         # per-channel gain limit
    # ripe colours on the balanced image: OpenCV hue (0..180) <= hue_max or >= hue_wrap
    'hue_max': 22,
    'hue_wrap': 160,
    'sat_min': 100,             # HSV saturation floor of fruit skin (0..255; skin, wood: less)
    'val_min': 25,              # HSV value floor (0..255)
    # green-fruit colours (hue_max < hue <= green_hue_max) and surface
    'green_hue_max': 44,        # leaves reach further into blue-green than fruit
    'green_sat_min': 55,
    'green_val_min': 45,
    'green_scale': 1.0,         # pass 2 (green fruit) runs at this fraction of the working size
    'edge_min': 0.12,           # gradient / brightness of an outline edge
    'min_edge_support': 0.8,    # fraction of a green fruit's circle that is such a radial edge
    'max_residual_green': 0.03,   # outline misfit (median / r) of a green fruit's circle
    'min_fill_outline': 0.8,    # ... and the share of that circle its region fills
    'outline_gate_score': 0.15,  # ... for strict-pass candidates graded below this (leaf green;
                                 # yellow-green fruit near the turning stage are not leaf-coloured)
    'max_area_ratio': 2.0,      # a green part's area / the area of its inscribed circle
    'max_green_region': 0.3,    # strict-pass regions up to this x the largest fruit's area
    # shape
    'min_fill': 0.35,           # part area / fitted circle area, ripe-coloured fruit
    'min_fill_green': 0.6,      # same for the strict pass and green-graded fruit
    'min_inside': 0.85,         # fraction of the part's pixels inside its fitted circle
    'peak_separation': 0.75,    # NMS: a peak closer than this x the stronger radius is merged
    'single_fit_residual_px': 0.9,  # a region whose outline fits one circle within this median
                                    # misfit [px at ~scale] (and better than its parts) is one fruit
    'join_residual_px': 1.2,    # two overlapping parts whose joint outline fits one circle within
                                # this median misfit [px at ~scale] are one fruit (leaf-cut outline)
    'open_px': 5,               # opening kernel [px at ~scale]: removes stems and twine
    'close_px': 9,              # closing kernel [px at ~scale]: bridges stems and sepals on fruit
    'bridge_px': 15,            # larger closing of ripe colours through green or dark pixels only
    'bridge_val_max': 90,       # ... dark = HSV value up to this
    'merge_score_diff': 0.25,   # fragments of one fruit: at most this ripeness-score apart
    'refit_radius': 1.3,        # a ripe part too thin for its circle: refit at most this x its
                                # inscribed radius (a fruit in front of another, one peak)
    'max_residual_refit': 0.03,  # ... when that circle follows its arc this well (median / r)
    'min_front_outline': 0.5,   # ... and when that much of its circle is the region's outline
    'max_shared_part': 0.5,     # a strict-pass fruit with more of its visible part inside the
                                # circle of a fruit of pass 1 is the rest of that fruit
    'max_regions': 30,          # regions examined per pass (largest first)
    'max_peaks': 6,             # fruit hypotheses per region
    # ripeness calibration: per-pixel wrapped hue (OpenCV units, red = 0) -> ripeness knots
    'score_hue': [4.0, 9.0, 14.0, 18.0, 22.0, 26.0, 30.0, 35.0, 41.0],
    'score_values': [1.0, 0.88, 0.7, 0.55, 0.42, 0.3, 0.18, 0.06, 0.0],
    'pale_sat': 130,            # pixels less saturated than this drift towards score 0.5
    'skin_min_ripeness': 0.25,  # pass 1: pixels graded below this (green) are not skin
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
                 'mask_origin', 'mask_scale', 'hue_angle', 'chroma', 'behind')

    def __init__(self, u, v, radius_px, score, mask=None, mask_origin=(0, 0), mask_scale=1.0,
                 fill=1.0, area_px=0.0, hue_angle=float('nan'), chroma=float('nan'),
                 behind=False):
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
        self.behind = bool(behind)        # seen behind a fruit in front (split off its region)

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


def _support(circle, xs, ys, tol=1.0, rel=0.03):
    """Number of points within tol + rel * r of the circle."""
    cx, cy, r = circle
    return int(np.count_nonzero(np.abs(np.hypot(xs - cx, ys - cy) - r) <= tol + rel * r))


#: linear sRGB -> CIE XYZ (D65), rows X, Y, Z, divided by the D65 white point
_RGB_TO_XYZ_WHITE = np.array([[0.4124, 0.3576, 0.1805], [0.2126, 0.7152, 0.0722],
                              [0.0193, 0.1192, 0.9505]]) / np.array([[0.95047], [1.0], [1.08883]])


def lab_hue_angle(bgr):
    """CIE Lab hue angle [deg] of one sRGB colour given as B, G, R in 0..255 (diagnostics;
    computed here: OpenCV's Lab conversion sets up tables on its first call, ~0.1 s)."""
    rgb = np.clip(np.asarray(bgr, dtype=np.float64)[::-1] / 255.0, 0.0, 1.0)
    linear = np.where(rgb <= 0.04045, rgb / 12.92, ((rgb + 0.055) / 1.055) ** 2.4)
    t = _RGB_TO_XYZ_WHITE.dot(linear)
    f = np.where(t > 0.008856, np.cbrt(t), 7.787 * t + 16.0 / 116.0)
    return math.degrees(math.atan2(200.0 * (f[1] - f[2]), 500.0 * (f[0] - f[1])))


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


class _Frame(object):
    """The working images of one detect() call."""

    __slots__ = ('small', 'hsv', 'scale', 'fill', 'gx', 'gy')

    def __init__(self, small, hsv, scale):
        self.small, self.hsv, self.scale = small, hsv, scale
        self.fill = self.gx = self.gy = None


class TomatoDetector(object):
    """Finds tomatoes in BGR images; parameters as in DEFAULTS."""

    def __init__(self, **params):
        unknown = set(params) - set(DEFAULTS)
        if unknown:
            raise ValueError('unknown detector parameters: %s' % sorted(unknown))
        self.params = dict(DEFAULTS)
        self._lut = None
        #: a list to collect the evidence of every strict-pass candidate (tuning), or None
        self.trace = None
        self.update(**params)

    def update(self, **params):
        """Change parameters at run time (dynamic_reconfigure); unknown keys are ignored."""
        for key, value in params.items():
            if key in DEFAULTS:
                kind = type(DEFAULTS[key])
                self.params[key] = [float(x) for x in value] if kind is list else kind(value)
        p = self.params
        if len(p['score_hue']) != len(p['score_values']) or len(p['score_hue']) < 2:
            raise ValueError('score_hue and score_values must have the same length (>= 2)')
        if any(b <= a for a, b in zip(p['score_hue'][:-1], p['score_hue'][1:])):
            raise ValueError('score_hue must increase')
        for key in ('scale', 'min_radius_px', 'max_radius_px', 'wb_max_gain'):
            if not (math.isfinite(p[key]) and p[key] > 0):
                raise ValueError('detector parameter %s must be a positive number, not %r'
                                 % (key, p[key]))
        self._lut = self._score_table()

    def _score_table(self):
        """Per-pixel ripeness as a 180 x 256 table over (OpenCV hue, saturation)."""
        p = self.params
        hue = np.arange(180, dtype=np.float64)
        wrapped = np.where(hue >= 90, hue - 180.0, hue)       # purple-red wraps to below 0
        ripe = np.interp(wrapped, p['score_hue'], p['score_values'])
        sat = np.arange(256, dtype=np.float64)
        pale = np.clip(sat / max(float(p['pale_sat']), 1.0), 0.0, 1.0)
        table = 0.5 + (ripe[:, None] - 0.5) * pale[None, :]
        return table.astype(np.float32)

    # -- colour -------------------------------------------------------------------------------
    def working_scale(self, width):
        """Processing scale for an image `width` pixels wide."""
        p = self.params
        scale = float(p['scale'])
        cap = int(p['max_work_width'])
        if cap > 0 and width * scale > cap:
            scale = cap / float(width)
        return scale

    def white_gains(self, bgr):
        """Per-channel gains (B, G, R) that make the scene's white reference neutral.

        Reference candidates are unclipped, not dark pixels whose chromaticity an illuminant
        could give to a white or grey surface (film, pipes, specular highlights): within
        `wb_chroma_box` of neutral and never greener than `wb_max_green` (no greenhouse or
        plant-factory light is green, but leaves are). Red or orange fruit skin lies outside
        the box. The reference is the mean of the brightest `wb_top_fraction` of them
        (a sample of every 4th pixel in each direction); with fewer than `wb_min_fraction` of
        the sample as candidates there is no white reference and the gains are 1. Gains keep
        the mean brightness and stay within [1 / wb_max_gain, wb_max_gain]."""
        p = self.params
        ones = np.ones(3, dtype=np.float64)
        if not p['white_balance']:
            return ones
        pix = bgr[::4, ::4].reshape(-1, 3)
        top = pix.max(axis=1)
        total = pix.astype(np.int32).sum(axis=1)
        chroma = pix.astype(np.float32) / np.maximum(total, 1)[:, None].astype(np.float32)
        box = float(p['wb_chroma_box'])
        neutral = 1.0 / 3.0
        cand = (top < 250) & (top > 60) & (np.abs(chroma - neutral).max(axis=1) <= box) & \
            (chroma[:, 1] <= float(p['wb_max_green']))
        count = int(cand.sum())
        if count < max(20, float(p['wb_min_fraction']) * len(pix)):
            return ones
        total = total[cand]
        k = max(int(count * float(p['wb_top_fraction'])), 20)
        k = min(k, count)
        brightest = pix[cand][np.argpartition(total, count - k)[-k:]]
        ref = brightest.astype(np.float64).mean(axis=0)
        gains = (ref.sum() / 3.0) / np.maximum(ref, 1.0)
        gains /= gains.mean()
        bound = float(p['wb_max_gain'])
        return np.clip(gains, 1.0 / bound, bound)

    def balance(self, bgr):
        """(white-balanced uint8 copy, gains) of a BGR image."""
        gains = self.white_gains(bgr)
        if np.allclose(gains, 1.0):
            return bgr, gains
        return cv2.transform(bgr, np.diag(gains).astype(np.float32)), gains

    def colour_masks(self, hsv):
        """(ripe-colour mask, green-fruit-colour mask) of a balanced HSV image (uint8 0/255)."""
        p = self.params
        h, s, v = cv2.split(hsv)
        hue_ok = cv2.bitwise_or(cv2.inRange(h, 0, int(p['hue_max'])),
                                cv2.inRange(h, int(p['hue_wrap']), 180))
        sv_ok = cv2.bitwise_and(cv2.inRange(s, int(p['sat_min']), 255),
                                cv2.inRange(v, int(p['val_min']), 255))
        ripe = cv2.bitwise_and(hue_ok, sv_ok)
        green = cv2.bitwise_and(
            cv2.inRange(h, int(p['hue_max']) + 1, int(p['green_hue_max'])),
            cv2.bitwise_and(cv2.inRange(s, int(p['green_sat_min']), 255),
                            cv2.inRange(v, int(p['green_val_min']), 255)))
        return ripe, green

    @staticmethod
    def gradient_maps(gray):
        """(gx, gy) float32 brightness gradient of a grey image relative to the local mean
        brightness, so an outline's edge strength does not depend on the exposure."""
        g = gray.astype(np.float32)
        bright = cv2.blur(g, (5, 5)) + 12.0
        gx = cv2.Sobel(g, cv2.CV_32F, 1, 0, ksize=3) / (4.0 * bright)
        gy = cv2.Sobel(g, cv2.CV_32F, 0, 1, ksize=3) / (4.0 * bright)
        return gx, gy

    def _clean(self, mask, factor=1.0):
        """Opening removes stems, twine and speckle; closing bridges thin gaps on the fruit
        (kernels scaled by `factor` for a smaller image)."""
        p = self.params
        for op, size in ((cv2.MORPH_OPEN, p['open_px']), (cv2.MORPH_CLOSE, p['close_px'])):
            size = int(round(size * factor)) | 1
            if size > 1:
                mask = cv2.morphologyEx(mask, op, cv2.getStructuringElement(
                    cv2.MORPH_ELLIPSE, (size, size)))
        return mask

    def _bridge(self, mask, hsv, green):
        """Sepals and stems across a fruit, too thick for the closing: a larger closing
        (`bridge_px`) fills only green or dark pixels (sepals, stems, shadow), never the
        bright background between two fruit."""
        size = int(self.params['bridge_px'])
        if size <= 1:
            return mask
        closed = cv2.morphologyEx(mask, cv2.MORPH_CLOSE, cv2.getStructuringElement(
            cv2.MORPH_ELLIPSE, (size, size)))
        fillable = cv2.bitwise_or(green, cv2.inRange(hsv[:, :, 2], 0,
                                                     int(self.params['bridge_val_max'])))
        bridged = cv2.bitwise_or(mask, cv2.bitwise_and(closed, fillable))
        # opened like the colour mask (`open_px`): a bridge is as wide as the sepal or leaf it
        # crosses; a thin neck through a leaf to a sliver of another fruit is not one
        size = int(self.params['open_px']) | 1
        if size > 1:
            bridged = cv2.morphologyEx(bridged, cv2.MORPH_OPEN, cv2.getStructuringElement(
                cv2.MORPH_ELLIPSE, (size, size)))
        return bridged

    def pixel_ripeness(self, hsv_pixels):
        """Per-pixel ripeness (0..1) of Nx3 uint8 HSV pixels."""
        hsv_pixels = np.asarray(hsv_pixels, dtype=np.uint8).reshape(-1, 3)
        return self._lut[np.minimum(hsv_pixels[:, 0], 179), hsv_pixels[:, 1]]

    def _score_pixels(self, hsv_pixels, bgr_pixels):
        """score_of() for pixels whose HSV values are known."""
        if len(hsv_pixels) == 0:
            return 0.0, float('nan'), float('nan')
        score = float(self.pixel_ripeness(hsv_pixels).mean())
        mean = bgr_pixels.astype(np.float64).mean(axis=0)
        total = float(mean.sum())
        chroma = float(mean[2]) / total if total > 0 else 0.0
        return min(max(score, 0.0), 1.0), chroma, lab_hue_angle(mean)

    def score_of(self, bgr_pixels):
        """(score, red chromaticity, Lab hue angle [deg]) of an Nx3 uint8 BGR skin sample
        (already white-balanced)."""
        bgr_pixels = np.asarray(bgr_pixels, dtype=np.uint8).reshape(-1, 3)
        if len(bgr_pixels) == 0:
            return 0.0, float('nan'), float('nan')
        hsv = cv2.cvtColor(bgr_pixels.reshape(-1, 1, 3), cv2.COLOR_BGR2HSV).reshape(-1, 3)
        return self._score_pixels(hsv, bgr_pixels)

    # -- main ---------------------------------------------------------------------------------
    def detect(self, bgr):
        """Detect tomatoes in a BGR uint8 image. Returns a list of Detection."""
        if bgr is None or bgr.ndim != 3 or bgr.shape[2] != 3 or bgr.dtype != np.uint8:
            raise ValueError('detect() takes a BGR uint8 image (H x W x 3)')
        p = self.params
        scale = self.working_scale(bgr.shape[1])
        if abs(scale - 1.0) > 1e-9:
            small = cv2.resize(bgr, None, fx=scale, fy=scale, interpolation=cv2.INTER_AREA)
        else:
            small = bgr
        small, _ = self.balance(small)
        hsv = cv2.cvtColor(small, cv2.COLOR_BGR2HSV)
        r_min = p['min_radius_px'] * scale
        r_max = p['max_radius_px'] * scale
        ripe, green = self.colour_masks(hsv)
        frame = _Frame(small, hsv, scale)
        # pass 1: ripe colours (red, orange, pink; the coloured part of turning fruit)
        ripe = self._clean(ripe)
        bridged = self._bridge(ripe, hsv, green)
        if bridged is not ripe:
            frame.fill = cv2.bitwise_and(bridged, cv2.bitwise_not(ripe))
        found = self._candidates(bridged, frame, r_min, r_max, strict=False)
        frame.fill = None
        # pass 2: every fruit colour; regions with green-fruit colour must be round, well
        # filled and outlined by a circular brightness edge (leaves are green too).
        # Green regions can be large (the canopy), so this pass runs at ~green_scale of the
        # working size: green fruit matter as obstacles and for the record, not for 3D.
        if cv2.countNonZero(green) > math.pi * r_min * r_min * 0.3:
            factor = float(p['green_scale'])
            if factor < 1.0:
                small2 = cv2.resize(small, None, fx=factor, fy=factor,
                                    interpolation=cv2.INTER_AREA)
                hsv2 = cv2.cvtColor(small2, cv2.COLOR_BGR2HSV)
                ripe2, green2 = self.colour_masks(hsv2)
                ripe2 = self._clean(ripe2, factor)
            else:
                factor, small2, hsv2, ripe2, green2 = 1.0, small, hsv, ripe, green
            frame2 = _Frame(small2, hsv2, scale * factor)
            frame2.gx, frame2.gy = self.gradient_maps(cv2.cvtColor(small2, cv2.COLOR_BGR2GRAY))
            both = cv2.bitwise_or(ripe2, green2)
            # the visible parts of the fruit found in pass 1 are taken out first: a turning
            # fruit touching a red one would otherwise join it in one region, often with one
            # distance-transform peak, and their joint circle would be dropped as a duplicate
            # of the red fruit (parts, not circles: a red fruit behind keeps its full circle)
            self._erase_parts(both, found, frame2.scale)
            for det in self._candidates(self._clean(both, factor), frame2, r_min * factor,
                                        r_max * factor, strict=True, need=green2):
                # the rest of a fruit already found (its yellow-green shoulder, say) lies
                # mostly inside that fruit's circle; a fruit in front of or behind it does not
                if all(_share_inside(det, o) <= p['max_shared_part'] for o in found):
                    found.append(det)
        return self._merge_fragments(found)

    @staticmethod
    def _erase_parts(mask, detections, mask_scale):
        """Clear the visible part (mask crop, grown by a pixel) of each detection from a mask
        of the input image at `mask_scale`, in place."""
        kernel = cv2.getStructuringElement(cv2.MORPH_RECT, (3, 3))
        height, width = mask.shape
        for det in detections:
            # padded by a pixel so that the growth may leave the crop
            part = cv2.dilate(np.pad(det.mask.astype(np.uint8), 1), kernel)
            x0, y0 = det.mask_origin[0] - 1, det.mask_origin[1] - 1
            ratio = mask_scale / det.mask_scale
            if abs(ratio - 1.0) > 1e-9:
                part = cv2.resize(part, None, fx=ratio, fy=ratio,
                                  interpolation=cv2.INTER_NEAREST)
                x0, y0 = int(round(x0 * ratio)), int(round(y0 * ratio))
            h, w = part.shape
            cx0, cy0 = max(x0, 0), max(y0, 0)
            cx1, cy1 = min(x0 + w, width), min(y0 + h, height)
            if cx0 >= cx1 or cy0 >= cy1:
                continue
            sub = part[cy0 - y0:cy1 - y0, cx0 - x0:cx1 - x0]
            mask[cy0:cy1, cx0:cx1][sub > 0] = 0

    def _candidates(self, mask, frame, r_min, r_max, strict, need=None):
        """Fruit in the regions of a mask; with `need`, only regions of which at least a
        tenth is in that mask (the strict pass: regions with green-fruit colour)."""
        count, labels, stats, _ = cv2.connectedComponentsWithStats(mask, connectivity=8)
        height, width = mask.shape
        areas = stats[1:, cv2.CC_STAT_AREA]
        sizes = np.maximum(stats[1:, cv2.CC_STAT_WIDTH], stats[1:, cv2.CC_STAT_HEIGHT])
        ok = (areas >= math.pi * r_min * r_min * 0.3) & (sizes >= 1.5 * r_min)
        if need is not None:
            needed = np.bincount(labels[need > 0], minlength=count)[1:]
            ok &= needed >= 0.1 * areas
            # a green region larger than a few of the largest fruit is canopy
            ok &= areas <= float(self.params['max_green_region']) * math.pi * r_max * r_max
        order = np.flatnonzero(ok)
        order = order[np.argsort(-areas[order], kind='stable')][:int(self.params['max_regions'])]
        detections = []
        for index in order:
            label = int(index) + 1
            x, y, w, h, _ = stats[label]
            x0, y0 = max(x - 1, 0), max(y - 1, 0)
            x1, y1 = min(x + w + 1, width), min(y + h + 1, height)
            comp = _fill_holes((labels[y0:y1, x0:x1] == label).astype(np.uint8))
            detections.extend(self._split_component(comp, (x0, y0), frame, r_min, r_max,
                                                    (width, height), strict))
        return detections

    @staticmethod
    def _skin_pixels(frame, part, ox, oy, cx, cy, radius):
        """(rows, cols) in the working image of the skin sample of a fruit circle."""
        height, width = frame.hsv.shape[:2]
        x0, y0 = max(int(cx + ox - radius), 0), max(int(cy + oy - radius), 0)
        x1 = min(int(math.ceil(cx + ox + radius)) + 1, width)
        y1 = min(int(math.ceil(cy + oy + radius)) + 1, height)
        if x0 >= x1 or y0 >= y1:
            return np.zeros(0, np.int64), np.zeros(0, np.int64)
        yy, xx = np.mgrid[y0:y1, x0:x1]
        disc = (xx - (cx + ox)) ** 2 + (yy - (cy + oy)) ** 2 <= radius * radius
        on_part = np.zeros(disc.shape, dtype=bool)
        px0, py0 = max(x0 - ox, 0), max(y0 - oy, 0)
        px1, py1 = min(x1 - ox, part.shape[1]), min(y1 - oy, part.shape[0])
        if px0 < px1 and py0 < py1:
            on_part[py0 + oy - y0:py1 + oy - y0, px0 + ox - x0:px1 + ox - x0] = \
                part[py0:py1, px0:px1]
        skin = disc & on_part
        if frame.fill is not None:
            skin &= frame.fill[y0:y1, x0:x1] == 0
        rows, cols = np.nonzero(skin)
        return rows + y0, cols + x0

    def _round_fruit_surface(self, frame, cx, cy, r, hsv_px, circle, fill, inside, score):
        """Surface and outline evidence of a candidate from the strict pass (a green fruit
        must be told from leaves by more than colour)."""
        p = self.params
        support = self.edge_support(frame, cx, cy, r)
        if self.trace is not None:
            self.trace.append(dict(
                cx=cx / frame.scale, cy=cy / frame.scale, r=r / frame.scale, score=score,
                fill=fill, inside=inside, residual=circle[3] if len(circle) > 3 else 1.0,
                edges=self.edge_profile(frame, cx, cy, r).tolist(),
                highlight=float(np.mean((hsv_px[:, 1] < 70) & (hsv_px[:, 2] > 170)))
                if len(hsv_px) else 0.0,
                sat=float(np.median(hsv_px[:, 1])) if len(hsv_px) else 0.0,
                val=float(np.median(hsv_px[:, 2])) if len(hsv_px) else 0.0,
                hue_iqr=float(np.subtract(*np.percentile(hsv_px[:, 0], [75, 25])))
                if len(hsv_px) else 0.0))
            return True
        residual = circle[3] if len(circle) > 3 else 1.0
        return support >= p['min_edge_support'] and residual <= p['max_residual_green'] and \
            fill >= p['min_fill_outline']

    def edge_profile(self, frame, cx, cy, r, samples=48):
        """Strongest radial edge (relative gradient) within +-2 px of each of `samples` points
        of a circle (working pixels); NaN where the circle leaves the image."""
        height, width = frame.gx.shape
        a = np.linspace(0.0, 2.0 * math.pi, samples, endpoint=False)
        ca, sa = np.cos(a), np.sin(a)
        best = np.zeros(samples, dtype=np.float32)
        inside = np.zeros(samples, dtype=bool)
        for dr in (-2.0, -1.0, 0.0, 1.0, 2.0):
            xs = np.rint(cx + (r + dr) * ca).astype(np.int64)
            ys = np.rint(cy + (r + dr) * sa).astype(np.int64)
            ok = (xs >= 1) & (ys >= 1) & (xs < width - 1) & (ys < height - 1)
            inside |= ok
            xs, ys = np.clip(xs, 0, width - 1), np.clip(ys, 0, height - 1)
            radial = np.abs(frame.gx[ys, xs] * ca + frame.gy[ys, xs] * sa)
            best = np.maximum(best, np.where(ok, radial, 0.0))
        return np.where(inside, best, np.nan)

    def edge_support(self, frame, cx, cy, r, samples=48):
        """Fraction of a circle (working pixels) along which the brightness has a radial edge
        of at least `edge_min` (relative gradient), within +-2 px of the circle."""
        if frame.gx is None:
            return 1.0
        best = self.edge_profile(frame, cx, cy, r, samples)
        best = best[np.isfinite(best)]
        if not len(best):
            return 0.0
        return float(np.mean(best >= float(self.params['edge_min'])))

    def _merge_fragments(self, detections):
        """Drop fragments whose centre lies inside a larger, similarly coloured fruit.

        A fruit cut into pieces by a stem or a leaf in front of it gives several parts; the
        largest fitted circle stands for the fruit and the smaller ones inside it go.
        """
        keep = []
        for det in sorted(detections, key=lambda d: -d.radius_px):
            host = None
            for big in keep:
                # (a fruit split off the region of the fruit in front of it is not a
                # fragment, though its centre may lie inside the front fruit's circle)
                if not det.behind and \
                        math.hypot(det.u - big.u, det.v - big.v) < 0.9 * big.radius_px and \
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
                if len(peaks) >= int(self.params['max_peaks']):
                    break
        return peaks

    def _split_component(self, comp, origin, frame, r_min, r_max, size, strict):
        p = self.params
        small, hsv, scale = frame.small, frame.hsv, frame.scale
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
        if frame.fill is not None:
            # nor is the edge of a bridge (a leaf, sepal or shadow filled between ripe parts)
            h, w = comp.shape
            outer &= frame.fill[oy:oy + h, ox:ox + w] == 0
        # hypothesis A: one fruit per distance-transform peak (power-diagram parts)
        candidates = []          # (part mask, circle)
        peak_rs = []
        for k, (px, py, pr) in enumerate(peaks):
            part = (parts == k)
            area = part.sum()
            if area < math.pi * r_min * r_min * 0.3:
                continue
            if strict and area > p['max_area_ratio'] * math.pi * pr * pr:
                continue      # far larger than its inscribed circle: a leaf or canopy strip
            circle = self._fit_part(part, outer, pr)
            if circle is not None:
                candidates.append((part, circle))
                peak_rs.append(pr)
        if len(candidates) > 1 and not strict:
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
        in_front = {}        # candidate index -> the part of the fruit in front of it
        for index, (part, circle) in enumerate(candidates):
            area = int(part.sum())
            cx, cy, r = circle[:3]
            residual = circle[3] if len(circle) > 3 else 1.0
            if r < r_min or (r > r_max and strict):
                continue
            pys, pxs = np.nonzero(part)
            if not strict and (area < p['min_fill'] * math.pi * r * r or r > r_max):
                # a circle far larger than the part: the gentle outline of two fruit, one in
                # front of the other, in one part (one distance-transform peak between them)
                # fits a circle around both; the front fruit's own arc has about the radius of
                # the part's inscribed circle
                refit = self._fit_part(part, outer, float(cv2.distanceTransform(
                    part.astype(np.uint8), cv2.DIST_L2, 5).max()), r_high=p['refit_radius'])
                if refit is not None and refit[3] <= p['max_residual_refit']:
                    cx, cy, r, residual = refit
            inside = (pxs - cx) ** 2 + (pys - cy) ** 2 <= (r + 1.5) ** 2
            if not strict and np.mean(inside) < p['min_inside'] and \
                    residual <= p['max_residual_refit'] and r_min <= r <= r_max and \
                    inside.sum() >= p['min_fill_green'] * math.pi * r * r and \
                    len(candidates) < 2 * int(p['max_peaks']) and \
                    _outline_cover(outer, cx, cy, r) >= p['min_front_outline']:
                # the circle follows its arc and is well filled, but much of the part lies
                # outside: that is a fruit behind it. The front fruit is what its circle holds;
                # the rest, if large enough, is examined as a part of its own.
                rest = part.copy()
                rest[pys[inside], pxs[inside]] = False
                rest = cv2.morphologyEx(rest.astype(np.uint8), cv2.MORPH_OPEN,
                                        cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (5, 5)))
                if cv2.countNonZero(rest) >= math.pi * r_min * r_min * 0.3:
                    rest_circle = self._fit_part(rest > 0, outer, float(
                        cv2.distanceTransform(rest, cv2.DIST_L2, 5).max()))
                    if rest_circle is not None:
                        candidates.append((rest > 0, rest_circle))
                        in_front[len(candidates) - 1] = part & ~(rest > 0)
                part = part.copy()
                part[pys[~inside], pxs[~inside]] = False
                pxs, pys = pxs[inside], pys[inside]
                area = int(inside.sum())
                inside = 1.0
            else:
                inside = float(np.mean(inside))
            if inside < p['min_inside'] and len(candidates) > 1:
                # a fruit behind a neighbour and cut by leaves: its outline is mostly leaf
                # edges and the border with the neighbour, which no circle follows; its
                # visible part still lies inside the fruit, so the smallest circle around
                # that part stands for it
                (ex, ey), er = cv2.minEnclosingCircle(
                    np.column_stack([pxs, pys]).astype(np.float32))
                if r_min <= er <= r_max:
                    cx, cy, r, inside = float(ex), float(ey), float(er), 1.0
            if r > r_max:
                continue
            fill = area / (math.pi * r * r)
            if index in in_front:
                # the fruit in front hides part of this one's circle: that part is explained
                yy, xx = np.nonzero(in_front[index])
                fill += float(np.sum((xx - cx) ** 2 + (yy - cy) ** 2 <= r * r)) / (math.pi * r * r)
            # skin pixels for colour: inside 0.85 r, on the part, not bridged (sepals), not
            # highlight or deep shadow
            sy, sx = self._skin_pixels(frame, part, ox, oy, cx, cy, 0.85 * r)
            hsv_px = hsv[sy, sx]
            bgr_px = small[sy, sx]
            good = (hsv_px[:, 2] > 2 * p['val_min']) & ~((hsv_px[:, 1] < 60) & (hsv_px[:, 2] > 200)) & \
                (bgr_px.max(axis=1) < 250)
            if not strict:
                # a part of ripening colour: its green-graded pixels are not its skin but the
                # calyx, sepals and stems across it (seen from the calyx side, a star of
                # them fills the middle of a red fruit and graded it pink)
                good &= self.pixel_ripeness(hsv_px) >= p['skin_min_ripeness']
            score, chroma, angle = self._score_pixels(hsv_px[good], bgr_px[good])
            min_fill = p['min_fill_green'] if strict or score < STAGE_THRESHOLDS[0] else \
                p['min_fill']
            if inside < p['min_inside'] or fill < min_fill:
                continue
            if strict and score < p['outline_gate_score'] and not self._round_fruit_surface(
                    frame, cx + ox, cy + oy, r, hsv_px, circle, fill, inside, score):
                continue          # green, but not round or no edge all round: a leaf
            x0 = max(int(math.floor(cx - r)) - 1, 0)
            y0 = max(int(math.floor(cy - r)) - 1, 0)
            crop = part[y0:int(math.ceil(cy + r)) + 2, x0:int(math.ceil(cx + r)) + 2]
            results.append(Detection(
                (cx + ox + 0.5) / scale - 0.5, (cy + oy + 0.5) / scale - 0.5, r / scale, score,
                mask=crop.copy(), mask_origin=(x0 + ox, y0 + oy), mask_scale=scale,
                fill=fill, area_px=area / (scale * scale), hue_angle=angle, chroma=chroma,
                behind=index in in_front))
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
    def _fit_part(part, outer, peak_r, r_high=3.0):
        """(cx, cy, r, residual) of the circle through the part's outer-boundary pixels that
        lie on its convex hull, radius in [0.8, r_high] x the inscribed radius `peak_r` (+2);
        residual = median radial misfit / r (1.0 for the fallback)."""
        part8 = part.astype(np.uint8)
        # the work is done on the part's bounding box (+1 px): a part of a large cluster is
        # a small share of its region's crop
        bx, by, bw, bh = cv2.boundingRect(part8)
        if bw == 0 or bh == 0:
            return None
        x0, y0 = max(bx - 1, 0), max(by - 1, 0)
        x1, y1 = min(bx + bw + 1, part8.shape[1]), min(by + bh + 1, part8.shape[0])
        circle = TomatoDetector._fit_crop(part8[y0:y1, x0:x1], outer[y0:y1, x0:x1], peak_r,
                                          r_high)
        if circle is None:
            return None
        return (circle[0] + x0, circle[1] + y0) + tuple(circle[2:])

    @staticmethod
    def _fit_crop(part8, outer, peak_r, r_high):
        """_fit_part() on a crop: part as 0/1 uint8."""
        ys, xs = np.nonzero((part8 > 0) & outer)
        moments = cv2.moments(part8, True)
        if moments['m00'] <= 0:
            return None
        mx, my = moments['m10'] / moments['m00'], moments['m01'] / moments['m00']
        fallback = (mx, my, max(peak_r, math.sqrt(moments['m00'] / math.pi)), 1.0)
        if len(xs) < 8:
            return fallback
        # the hull of a region is the hull of its outline
        contours = cv2.findContours(part8, cv2.RETR_EXTERNAL, cv2.CHAIN_APPROX_SIMPLE)[-2]
        if not contours:
            return fallback
        hull = cv2.convexHull(np.vstack(contours))
        if hull is None or len(hull) < 3:
            return fallback
        on_hull = _hull_distance(hull, xs, ys) <= 1.5
        if on_hull.sum() >= 8:
            xs, ys = xs[on_hull], ys[on_hull]
        xs = xs.astype(np.float64)
        ys = ys.astype(np.float64)
        r_lo, r_hi = 0.8 * peak_r, r_high * peak_r + 2.0
        circle = robust_fit_circle(xs, ys)
        if circle is not None and not r_lo <= circle[2] <= r_hi:
            circle = None
        support = _support(circle, xs, ys) if circle is not None else 0
        arc = None
        if support < 0.9 * len(xs):
            arc = arc_fit_circle(xs, ys, r_lo, r_hi)
        if arc is not None and _support(arc, xs, ys) > support:
            # the outline is partly a straight or concave cut (a leaf or stem in front of the
            # fruit): the circle that most of the outline follows is the fruit
            circle = arc
        if circle is None:
            return fallback
        cx, cy, r = circle
        # the radius must be consistent with the inscribed radius, the centre near the part
        if r < r_lo or r > r_hi:
            return fallback
        if math.hypot(cx - mx, cy - my) > r:
            return fallback
        residual = float(np.median(np.abs(np.hypot(xs - cx, ys - cy) - r))) / r
        return cx, cy, r, residual


def _outline_cover(outer, cx, cy, r, samples=48):
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


def _share_inside(det, other):
    """Fraction of det's visible part (its mask; every detection of detect() has one) inside
    other's fitted circle."""
    ys, xs = np.nonzero(det.mask)
    if not len(xs):
        return 0.0
    u = (xs + det.mask_origin[0] + 0.5) / det.mask_scale - 0.5
    v = (ys + det.mask_origin[1] + 0.5) / det.mask_scale - 0.5
    return float(np.mean((u - other.u) ** 2 + (v - other.v) ** 2 <= other.radius_px ** 2))


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
