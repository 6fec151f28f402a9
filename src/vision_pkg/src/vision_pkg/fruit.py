"""A detected fruit and the ripeness stages, rospy-free (vision_pkg.detection finds them)."""
import math

import numpy as np

STAGE_GREEN, STAGE_TURNING, STAGE_PINK, STAGE_RED = 0, 1, 2, 3
STAGE_NAMES = ('green', 'turning', 'pink', 'red')
#: score thresholds between consecutive stages
STAGE_THRESHOLDS = (0.25, 0.5, 0.7)


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

    def with_score(self, score):
        """A copy of this detection with another ripeness score (and the stage it gives)."""
        other = Detection.__new__(Detection)
        for name in Detection.__slots__:
            setattr(other, name, getattr(self, name))
        other.score = float(score)
        other.stage = stage_of(other.score)
        return other

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
