"""Tomato detection by colour and shape feature fusion (section 3.5.1.2), rospy-free.

Made to hold on real photographs as well as on harvest_sim's renders. For one BGR image:
  0. working copy: resized to ~scale, and at most ~max_work_width pixels wide, so the cost per
     frame is bounded whatever the camera (results come back in full-resolution pixels); an
     image wider than ~reference_width is first treated as if resized to that width, so that
     the fruit it finds, and the sizes in pixels, do not depend on the camera's resolution;
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
     joined-parts vs fruit-in-front hypotheses compared by outline misfit; validated by fill
     ratio and by the fraction of the part inside the circle;
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

This module holds the parameters, colour (steps 0-2), the passes and grading (4-5); step 3 is
vision_pkg.regions (RegionSplitter, which TomatoDetector extends), its circle fits
vision_pkg.circle_fit, the green fruit's surface and outline evidence of step 4
vision_pkg.surface (RoundSurface), and the result type and stages vision_pkg.fruit (re-exported
here).
"""
import math

import cv2
import numpy as np

from vision_pkg.circle_fit import arc_fit_circle, fit_circle, robust_fit_circle  # noqa: F401
from vision_pkg.fruit import (STAGE_GREEN, STAGE_NAMES, STAGE_PINK, STAGE_RED,  # noqa: F401
                              STAGE_THRESHOLDS, STAGE_TURNING, Detection, lab_hue_angle,
                              stage_of)
from vision_pkg.regions import Frame, RegionSplitter, share_inside
from vision_pkg.surface import RoundSurface

#: default parameters (ROS params of the same names override them; see config/*.yaml)
DEFAULTS = {
    'scale': 0.5,               # processing scale of the input image
    'max_work_width': 640,      # ... and at most this many pixels wide (0: no cap)
    'reference_width': 1024,    # a wider image is treated as if resized to this width (0: off)
    'min_radius_px': 20.0,      # smallest fruit radius [px of an image reference_width wide]
    'max_radius_px': 200.0,     # largest fruit radius [px of an image reference_width wide]
    # colour constancy (white reference from the scene's brightest pixels)
    'white_balance': True,
    'wb_top_fraction': 0.02,    # brightest fraction of the reference candidates averaged
    'wb_chroma_box': 0.16,      # candidates: each chromaticity within this of 1/3 ...
    'wb_max_green': 0.36,       # ... and green chromaticity at most this (no light is green)
    'wb_min_fraction': 0.003,   # fewer candidates (share of the pixels): no white reference
    # a green cast (light through the canopy, a camera's white balance off to green): the
    # scene's whites and greys are all greener than wb_max_green. When fewer than
    # wb_cast_fraction of the pixels (0: off; a close-up of fruit and leaves, as the hand
    # camera sees, has few pale pixels and those are leaves) and fewer than wb_cast_ratio of
    # the candidates up to wb_max_green_cast are candidates, those greener ones are
    'wb_max_green_cast': 0.40,
    'wb_cast_fraction': 0.0,
    'wb_cast_ratio': 0.35,
    'wb_max_gain': 2.0,         # per-channel gain limit
    'wb_level': 0.0,            # > 0: the gains also bring the white reference up to this
                                # level (0..255; never down, at most wb_max_gain): exposure
                                # constancy, so "shaded" and dark thresholds mean the same in an
                                # under-exposed frame (0: the gains keep the mean brightness)
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
    'max_see_through': 0.2,     # share of a circle's disc where pale, bright background shows
    'see_through_sat': 70,      # ... background: HSV saturation below this
    'see_through_val': 120,     # ... and value above this (film, floor, sky, pipes)
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
    'fragment_max_reach': 1.5,  # ... and a fragment's circle reaches at most this x the larger
                                # circle's radius from its centre (0: no limit)
    'refit_fill': 0.7,          # a ripe part filling less than this of its circle is too thin
                                # for it (at min_fill and below it would be refused) ...
    'refit_radius': 1.3,        # ... and is refitted at most this x its inscribed radius (a
                                # fruit in front of another, one peak; a wide fruit's flat arc)
    'max_residual_refit': 0.03,  # ... when that circle follows its arc this well (median / r)
    'min_front_outline': 0.5,   # ... and when that much of its circle is the region's outline
    'front_ratio': 1.1,         # a ripe part's circle over this x its inscribed radius may span
                                # a fruit of its colour behind the one in front (0: off) ...
    'front_radius': 1.08,       # ... whose own arc's circle is at most this x that radius and
                                # follows its arc at least as well (then split as in refit_*)
    'chord_refit': 0.9,         # a ripe fruit's circle is fitted again without its outline's
                                # straight cuts: hull edges longer than this x the hull's
                                # equivalent radius (0: off) ...
    'chord_grow': 1.25,         # ... and taken when at most this x as large (and no smaller)
    'max_shared_part': 0.5,     # a strict-pass fruit with more of its visible part inside the
                                # circle of a fruit of pass 1 is the rest of that fruit
    'max_regions': 30,          # regions examined per pass (largest first)
    'max_peaks': 6,             # fruit hypotheses per region
    # ripeness calibration: per-pixel wrapped hue (OpenCV units, red = 0) -> ripeness knots
    'score_hue': [4.0, 9.0, 14.0, 18.0, 22.0, 26.0, 30.0, 35.0, 41.0],
    'score_values': [1.0, 0.88, 0.7, 0.55, 0.42, 0.3, 0.18, 0.06, 0.0],
    'pale_sat': 130,            # pixels less saturated than this drift towards score 0.5
    'pale_sat_red_low': 90,     # red-side pixels (ripeness > 0.5) drift to 0.5 linearly from
    'pale_sat_red': 170,        # ... this saturation (score 0.5) up to this one (pale red: pink),
    'shade_val_low': 110,       # ... in the shade: HSV value up to this; from shade_val_high up
    'shade_val_high': 160,      # ... (0: everywhere) the red side has pale_sat's pull, blended
    'skin_min_ripeness': 0.25,  # pass 1: pixels graded below this (green) are not skin
}


class TomatoDetector(RegionSplitter, RoundSurface):
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
        low = min(float(p['pale_sat_red_low']), float(p['pale_sat_red']) - 1.0)
        pale_red = np.clip((sat - low) / max(float(p['pale_sat_red']) - low, 1.0), 0.0, 1.0)
        self._shade = None
        if p['shade_val_high'] > 0:
            # two tables: bright pixels keep the linear pull of pale_sat on both sides, dark
            # ones get the red side's stronger one; pixel_ripeness blends them by HSV value
            bright = 0.5 + (ripe[:, None] - 0.5) * pale[None, :]
            self._shade = bright.astype(np.float32)
        pale = np.where(ripe[:, None] > 0.5, pale_red[None, :], pale[None, :])
        table = 0.5 + (ripe[:, None] - 0.5) * pale
        return table.astype(np.float32)

    # -- colour -------------------------------------------------------------------------------
    def size_factor(self, width):
        """Scale of an image `width` pixels wide to the reference width (at most 1): the
        detector sees a wider image as that image resized to `reference_width`, so what it finds
        does not depend on the camera's resolution, and its pixel sizes (min/max_radius_px)
        are pixels of the reference width."""
        ref = int(self.params['reference_width'])
        return ref / float(width) if 0 < ref < width else 1.0

    def min_radius_input(self, width):
        """The smallest fruit radius the detector looks for, in pixels of an image `width`
        pixels wide."""
        return float(self.params['min_radius_px']) / self.size_factor(width)

    def working_scale(self, width):
        """Processing scale for an image `width` pixels wide."""
        p = self.params
        scale = float(p['scale']) * self.size_factor(width)
        cap = int(p['max_work_width'])
        if cap > 0 and width * scale > cap:
            scale = cap / float(width)
        return scale

    def white_gains(self, bgr):
        """Per-channel gains (B, G, R) that make the scene's white reference neutral.

        Reference candidates are unclipped, not dark pixels whose chromaticity an illuminant
        could give to a white or grey surface (film, pipes, specular highlights): within
        `wb_chroma_box` of neutral and never greener than `wb_max_green` (no greenhouse or
        plant-factory light is that green, but leaves are). Red or orange fruit skin lies outside
        the box. The reference is the mean of the brightest `wb_top_fraction` of them
        (a sample of every 4th pixel in each direction); with fewer than `wb_min_fraction` of
        the sample as candidates there is no white reference and the gains are 1. Under a green
        cast the scene's whites lie beyond that bound: with `wb_cast_fraction` > 0, when the
        candidates are fewer than that share of the sample and fewer than `wb_cast_ratio` of
        those up to `wb_max_green_cast`, the greener ones are the candidates (in the
        development photos and the renders, 41 % or more of those are within wb_max_green,
        under a green cast 27 % or less). Gains keep the mean brightness, or with `wb_level`
        > 0 raise the balanced reference to that level when it is darker, and stay within
        [1 / wb_max_gain, wb_max_gain]."""
        p = self.params
        ones = np.ones(3, dtype=np.float64)
        if not p['white_balance']:
            return ones
        pix = bgr[::4, ::4].reshape(-1, 3)
        # per channel (numpy's reductions along a 3-wide axis cost more than the arithmetic)
        b, g, r = pix[:, 0], pix[:, 1], pix[:, 2]
        top = np.maximum(np.maximum(b, g), r)
        total = b.astype(np.int32) + g + r
        norm = np.maximum(total, 1).astype(np.float32)
        box = float(p['wb_chroma_box'])
        neutral = 1.0 / 3.0
        cand = (top < 250) & (top > 60)
        for channel in (b, g, r):
            cand &= np.abs(channel.astype(np.float32) / norm - neutral) <= box
        green = g.astype(np.float32) / norm
        strict = cand & (green <= float(p['wb_max_green']))
        count = np.count_nonzero(strict)
        if count < float(p['wb_cast_fraction']) * len(pix):
            cast = cand & (green <= float(p['wb_max_green_cast']))
            count_cast = np.count_nonzero(cast)
            if count < float(p['wb_cast_ratio']) * count_cast:
                strict, count = cast, count_cast
        cand = strict
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
        level = float(p['wb_level'])
        if level > 0:
            gains *= min(max(level / max(float(ref.dot(gains)) / 3.0, 1.0), 1.0), bound)
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
        hue, sat = np.minimum(hsv_pixels[:, 0], 179), hsv_pixels[:, 1]
        dark = self._lut[hue, sat]
        if self._shade is None:
            return dark
        p = self.params
        low, high = float(p['shade_val_low']), max(float(p['shade_val_high']), p['shade_val_low'] + 1.0)
        w = np.minimum(np.maximum((hsv_pixels[:, 2].astype(np.float32) - low) / (high - low), 0.0), 1.0)
        return dark + (self._shade[hue, sat] - dark) * w

    def _score_pixels(self, hsv_pixels, bgr_pixels, ripeness=None, mean_bgr=False):
        """score_of() for pixels whose HSV values (or per-pixel ripeness) are known; with
        `mean_bgr`, the mean BGR colour (None when empty) in place of its hue angle, which a
        caller that drops most candidates computes only for those it keeps."""
        if len(hsv_pixels) == 0:
            return 0.0, float('nan'), None if mean_bgr else float('nan')
        if ripeness is None:
            ripeness = self.pixel_ripeness(hsv_pixels)
        score = float(ripeness.mean())
        # channel sums of uint8 values are exact in double whatever the order: OpenCV's sum,
        # many times faster than numpy's cast-and-reduce along a 3-wide axis
        mean = np.array(cv2.sumElems(np.ascontiguousarray(bgr_pixels).reshape(-1, 1, 3))[:3]) / \
            len(bgr_pixels)
        total = float(mean.sum())
        chroma = float(mean[2]) / total if total > 0 else 0.0
        return min(max(score, 0.0), 1.0), chroma, mean if mean_bgr else lab_hue_angle(mean)

    def score_of(self, bgr_pixels):
        """(score, red chromaticity, Lab hue angle [deg]) of an Nx3 uint8 BGR skin sample
        (already white-balanced)."""
        bgr_pixels = np.asarray(bgr_pixels, dtype=np.uint8).reshape(-1, 3)
        if len(bgr_pixels) == 0:
            return 0.0, float('nan'), float('nan')
        hsv = cv2.cvtColor(bgr_pixels.reshape(-1, 1, 3), cv2.COLOR_BGR2HSV).reshape(-1, 3)
        return self._score_pixels(hsv, bgr_pixels)

    def skin_mask(self, hsv_pixels, bgr_pixels):
        """Which pixels of a fruit's colour sample are skin to grade: neither deep shadow,
        highlight nor clipped."""
        p = self.params
        s, v = hsv_pixels[:, 1], hsv_pixels[:, 2]
        return (v > 2 * p['val_min']) & ~((s < 60) & (v > 200)) & \
            (np.maximum(np.maximum(bgr_pixels[:, 0], bgr_pixels[:, 1]), bgr_pixels[:, 2]) < 250)

    def grade_at(self, bgr, u, v, min_pixels=24):
        """Ripeness score of the skin at full-resolution pixels (u, v) of a BGR image, graded
        as detect() grades a fruit of the ripe-colour pass: the image's white balance, then
        the pixels of `skin_mask` that are not green-graded (calyx, stems). None with fewer
        than `min_pixels` of them."""
        gains = self.white_gains(self._working_image(bgr)[0])
        h, w = bgr.shape[:2]
        ui = np.clip(np.rint(np.asarray(u, dtype=np.float64)).astype(np.int64), 0, w - 1)
        vi = np.clip(np.rint(np.asarray(v, dtype=np.float64)).astype(np.int64), 0, h - 1)
        bgr_px = np.clip(np.rint(bgr[vi, ui].astype(np.float64) * gains), 0, 255).astype(np.uint8)
        hsv_px = cv2.cvtColor(bgr_px.reshape(-1, 1, 3), cv2.COLOR_BGR2HSV).reshape(-1, 3)
        ripeness = self.pixel_ripeness(hsv_px)
        good = self.skin_mask(hsv_px, bgr_px) & (ripeness >= self.params['skin_min_ripeness'])
        if np.count_nonzero(good) < min_pixels:
            return None
        return self._score_pixels(hsv_px[good], bgr_px[good], ripeness[good])[0]

    def _working_image(self, bgr):
        """(the image at the working scale, not yet white-balanced; that scale)."""
        scale = self.working_scale(bgr.shape[1])
        if abs(scale - 1.0) > 1e-9:
            return cv2.resize(bgr, None, fx=scale, fy=scale, interpolation=cv2.INTER_AREA), scale
        return bgr, scale

    # -- main ---------------------------------------------------------------------------------
    def detect(self, bgr):
        """Detect tomatoes in a BGR uint8 image. Returns a list of Detection."""
        if bgr is None or bgr.ndim != 3 or bgr.shape[2] != 3 or bgr.dtype != np.uint8:
            raise ValueError('detect() takes a BGR uint8 image (H x W x 3)')
        p = self.params
        small, scale = self._working_image(bgr)
        small, _ = self.balance(small)
        hsv = cv2.cvtColor(small, cv2.COLOR_BGR2HSV)
        # radii in working pixels (min/max_radius_px are pixels of the reference width)
        sizes = scale / self.size_factor(bgr.shape[1])
        r_min = p['min_radius_px'] * sizes
        r_max = p['max_radius_px'] * sizes
        ripe, green = self.colour_masks(hsv)
        frame = Frame(small, hsv, scale)
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
            frame2 = Frame(small2, hsv2, scale * factor)
            frame2.gray = cv2.cvtColor(small2, cv2.COLOR_BGR2GRAY)
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
                if all(share_inside(det, o) <= p['max_shared_part'] for o in found):
                    found.append(det)
        return self._merge_fragments(found)

    def _merge_fragments(self, detections):
        """Drop fragments whose centre lies inside a larger, similarly coloured fruit.

        A fruit cut into pieces by a stem or a leaf in front of it gives several parts; the
        largest fitted circle stands for the fruit and the smaller ones inside it go. A piece's
        circle follows a piece of the fruit's own outline, so it stays within the fruit's
        circle: it reaches at most `fragment_max_reach` of that circle's radius from its centre
        (the pieces merged on three seeds of renders, the mission scenarios and the photos
        reach 1.0-1.4). A red neighbour half behind a red fruit, whose centre lies inside the
        fruit's circle, has a circle of its own that reaches far out of it (1.7-1.8 at
        long_row's picking point 19, where one of the two was dropped in 12 of 16 noise-frame
        pairs) and is kept.
        """
        reach = float(self.params['fragment_max_reach'])
        keep = []
        for det in sorted(detections, key=lambda d: -d.radius_px):
            host = None
            for big in keep:
                # (a fruit split off the region of the fruit in front of it is not a
                # fragment, though its centre may lie inside the front fruit's circle)
                if det.behind or abs(det.score - big.score) > self.params['merge_score_diff']:
                    continue
                apart = math.hypot(det.u - big.u, det.v - big.v)
                if apart < 0.9 * big.radius_px and \
                        (reach <= 0 or apart + det.radius_px <= reach * big.radius_px):
                    host = big
                    break
            if host is None:
                keep.append(det)
        return keep
