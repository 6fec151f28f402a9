"""Regions of fruit colour split into fruit circles, rospy-free: the shape half of
vision_pkg.detection (its step 3; the detector's class takes these methods from RegionSplitter).

A region's distance-transform peaks split touching fruit (power diagram); each part's circle is
fitted to its outline pixels on the convex hull (circle_fit); hypotheses compared by outline
misfit: one fruit per peak, one fruit seen in pieces, two parts of one fruit joined, a fruit in
front of another (the rest examined as the fruit behind). Candidates are validated by fill
ratio and by the share of the part inside the circle.
"""
import math

import cv2
import numpy as np

from vision_pkg.circle_fit import circle_pixels, fit_part, outline_cover, own_arc_misfit
from vision_pkg.fruit import STAGE_THRESHOLDS, Detection, lab_hue_angle
from vision_pkg.surface import RoundSurface


class Frame(object):
    """The working images of one detect() call. `gray` (set for the strict pass) gives the
    brightness gradients of the windows that the outline tests look at (`gradients`)."""

    __slots__ = ('small', 'hsv', 'scale', 'fill', 'gray')

    def __init__(self, small, hsv, scale):
        self.small, self.hsv, self.scale = small, hsv, scale
        self.fill = self.gray = None

    def gradients(self, x0, y0, x1, y1):
        """(gx, gy) of the window [y0:y1, x0:x1] of `gray` (clipped to the image), computed
        on the window grown by 3 pixels: the same values as the whole image's maps there
        (`gradient_maps` looks 2 pixels around a pixel), for a few windows per frame."""
        height, width = self.gray.shape
        x0, y0, x1, y1 = max(x0, 0), max(y0, 0), min(x1, width), min(y1, height)
        gx0, gy0 = max(x0 - 3, 0), max(y0 - 3, 0)
        gx1, gy1 = min(x1 + 3, width), min(y1 + 3, height)
        gx, gy = RoundSurface.gradient_maps(np.ascontiguousarray(self.gray[gy0:gy1, gx0:gx1]))
        rows, cols = slice(y0 - gy0, y1 - gy0), slice(x0 - gx0, x1 - gx0)
        return gx[rows, cols], gy[rows, cols]


class RegionSplitter(object):
    """Shape methods of TomatoDetector (self.params, and its colour and surface methods)."""

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
        # Grana's block-based labelling: the same labels as the default, in half the time
        count, labels, stats, _ = cv2.connectedComponentsWithStatsWithAlgorithm(
            mask, 8, cv2.CV_32S, cv2.CCL_GRANA)
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
            comp = fill_holes((labels[y0:y1, x0:x1] == label).astype(np.uint8))
            detections.extend(self._split_component(comp, (x0, y0), frame, r_min, r_max,
                                                    (width, height), strict))
        return detections

    @staticmethod
    def _disc(frame, cx, cy, radius):
        """(x0, y0, disc) of a circle in the working image (centre in image pixels): the
        window around it that lies in the image, at (x0, y0), and the disc as a mask of it;
        None when the window is empty."""
        height, width = frame.hsv.shape[:2]
        x0, y0 = max(int(cx - radius), 0), max(int(cy - radius), 0)
        x1 = min(int(math.ceil(cx + radius)) + 1, width)
        y1 = min(int(math.ceil(cy + radius)) + 1, height)
        if x0 >= x1 or y0 >= y1:
            return None
        # broadcast row and column (np.mgrid's values, without building its two grids)
        yy, xx = np.arange(y0, y1)[:, None], np.arange(x0, x1)[None, :]
        return x0, y0, (xx - cx) ** 2 + (yy - cy) ** 2 <= radius * radius

    @staticmethod
    def _on_part(part, ox, oy, x0, y0, shape):
        """Mask of an image window (at x0, y0, of `shape`) that the part covers (a crop of the
        image at ox, oy)."""
        on_part = np.zeros(shape, dtype=bool)
        px0, py0 = max(x0 - ox, 0), max(y0 - oy, 0)
        px1, py1 = min(x0 + shape[1] - ox, part.shape[1]), min(y0 + shape[0] - oy, part.shape[0])
        if px0 < px1 and py0 < py1:
            on_part[py0 + oy - y0:py1 + oy - y0, px0 + ox - x0:px1 + ox - x0] = \
                part[py0:py1, px0:px1]
        return on_part

    def _skin_pixels(self, frame, part, ox, oy, cx, cy, radius):
        """(rows, cols) in the working image of the skin sample of a fruit circle (centre
        relative to the part's crop at ox, oy): the disc on the part, not bridged."""
        window = self._disc(frame, cx + ox, cy + oy, radius)
        if window is None:
            return np.zeros(0, np.int64), np.zeros(0, np.int64)
        x0, y0, disc = window
        skin = disc & self._on_part(part, ox, oy, x0, y0, disc.shape)
        if frame.fill is not None:
            skin &= frame.fill[y0:y0 + disc.shape[0], x0:x0 + disc.shape[1]] == 0
        rows, cols = np.nonzero(skin)
        return rows + y0, cols + x0

    def _see_through(self, frame, part, ox, oy, cx, cy, radius):
        """Share of a fruit circle's inner disc (0.9 r; crop-relative centre, working pixels)
        that is neither its part nor something that could hide a fruit: bright, pale pixels
        of the background (plastic film, floor, sky, pipes). A fruit hidden behind a leaf,
        stem or another fruit is covered by them; where the background shows, the fruit is
        not, so the circle is too large or misplaced."""
        window = self._disc(frame, cx + ox, cy + oy, 0.9 * radius)
        if window is None:
            return 0.0
        x0, y0, disc = window
        hsv = frame.hsv[y0:y0 + disc.shape[0], x0:x0 + disc.shape[1]]
        pale = (hsv[:, :, 1] < int(self.params['see_through_sat'])) & \
            (hsv[:, :, 2] > int(self.params['see_through_val']))
        shows = pale & ~self._on_part(part, ox, oy, x0, y0, disc.shape)
        return float(np.count_nonzero(shows & disc)) / max(int(np.count_nonzero(disc)), 1)

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
            # the peak of least power distance, peak by peak (np.argmin's first minimum:
            # a later peak takes a pixel only when strictly nearer)
            owner = np.zeros(len(xs), dtype=np.int64)
            best = None
            for k, (px, py, pr) in enumerate(peaks):
                power = (xs - px) ** 2 + (ys - py) ** 2 - pr ** 2
                if best is None:
                    best = power
                else:
                    nearer = power < best
                    owner[nearer] = k
                    np.minimum(best, power, out=best)
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
        # (part mask, circle, its pixels' (rows, cols) in np.nonzero's order, or None where
        # not known)
        candidates = []
        peak_rs = []
        for k, (px, py, pr) in enumerate(peaks):
            part = (parts == k)
            own = owner == k
            coords = (ys[own], xs[own])
            area = len(coords[0])
            if area < math.pi * r_min * r_min * 0.3:
                continue
            if strict and area > p['max_area_ratio'] * math.pi * pr * pr:
                continue      # far larger than its inscribed circle: a leaf or canopy strip
            circle = self._fit_part(part, outer, pr)
            if circle is not None:
                candidates.append((part, circle, coords))
                peak_rs.append(pr)
        if len(candidates) > 1 and not strict:
            candidates = self._join_parts(candidates, peak_rs, outer)
        if len(peaks) > 1:
            # hypothesis B: one fruit seen in pieces (a leaf or stem in front of it) also has
            # several peaks; keep it whole when one circle explains its outline at least as
            # well as the parts explain theirs
            whole_part = comp > 0
            whole = self._fit_part(whole_part, outer, max(pk[2] for pk in peaks))
            if whole is not None and whole[3] * whole[2] <= p['single_fit_residual_px']:
                areas = [float(np.count_nonzero(c[0])) for c in candidates]
                split = sum(a * c[1][3] for a, c in zip(areas, candidates)) / sum(areas) \
                    if candidates else 1.0
                cx, cy, r = whole[:3]
                if whole[3] <= split and _share(
                        (xs - cx) ** 2 + (ys - cy) ** 2 <= (r + 1.5) ** 2) >= p['min_inside']:
                    candidates = [(whole_part, whole, (ys, xs))]
        if not strict and p['front_ratio'] > 0:
            # (one peak: its part is the whole region, whose distance map is `dist`)
            candidates = [self._front_fruit(c, outer, dist if len(peaks) == 1 else None)
                          for c in candidates]
        results = []
        in_front = {}        # candidate index -> the part of the fruit in front of it
        for index, (part, circle, coords) in enumerate(candidates):
            pys, pxs = coords if coords is not None else np.nonzero(part)
            area = len(pys)
            cx, cy, r = circle[:3]
            residual = circle[3] if len(circle) > 3 else 1.0
            if r < r_min or (r > r_max and strict):
                continue
            if not strict and (area < p['refit_fill'] * math.pi * r * r or r > r_max):
                # a circle far larger than the part: the gentle outline of two fruit, one in
                # front of the other, in one part (one distance-transform peak between them)
                # fits a circle around both; the front fruit's own arc has about the radius of
                # the part's inscribed circle. (So does a wide fruit half behind another: the
                # flat bottom arc of its outline, with the other's, fits a circle far too
                # large that still holds a third of the part.)
                refit = self._fit_part(part, outer, float(cv2.distanceTransform(
                    part.astype(np.uint8), cv2.DIST_L2, 5).max()), r_high=p['refit_radius'])
                if refit is not None and refit[3] <= p['max_residual_refit']:
                    cx, cy, r, residual = refit
            inside = (pxs - cx) ** 2 + (pys - cy) ** 2 <= (r + 1.5) ** 2
            if not strict and _share(inside) < p['min_inside'] and r_min <= r <= r_max and \
                    np.count_nonzero(inside) >= p['min_fill_green'] * math.pi * r * r and \
                    len(candidates) < 2 * int(p['max_peaks']) and \
                    (residual <= p['max_residual_refit'] or own_arc_misfit(
                        part, outer, cx, cy, r) <= p['max_residual_refit']) and \
                    outline_cover(outer, cx, cy, r) >= p['min_front_outline']:
                # the circle follows its arc and is well filled, but much of the part lies
                # outside: that is a fruit behind it. The front fruit is what its circle holds;
                # the rest, if large enough, is examined as a part of its own. (Its arc: the
                # fit's misfit is over the whole outline, the fruit behind's arc too, so a
                # circle whose own arc is that close, with the outline outside it left out,
                # counts as following it.)
                rest = part.copy()
                rest[pys[inside], pxs[inside]] = False
                rest = cv2.morphologyEx(rest.astype(np.uint8), cv2.MORPH_OPEN,
                                        cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (5, 5)))
                if cv2.countNonZero(rest) >= math.pi * r_min * r_min * 0.3:
                    rest_circle = self._fit_part(rest > 0, outer, float(
                        cv2.distanceTransform(rest, cv2.DIST_L2, 5).max()))
                    if rest_circle is not None:
                        candidates.append((rest > 0, rest_circle, None))
                        in_front[len(candidates) - 1] = part & ~(rest > 0)
                part = part.copy()
                part[pys[~inside], pxs[~inside]] = False
                pxs, pys = pxs[inside], pys[inside]
                area = np.count_nonzero(inside)
                inside = 1.0
            else:
                inside = _share(inside)
            if inside < p['min_inside'] and len(candidates) > 1:
                # a fruit behind a neighbour and cut by leaves: its outline is mostly leaf
                # edges and the border with the neighbour, which no circle follows; its
                # visible part still lies inside the fruit, so the smallest circle around
                # that part stands for it
                # (the circle around a point set is the one around its convex hull, and the
                # hull has a few dozen points where the part has thousands)
                (ex, ey), er = cv2.minEnclosingCircle(cv2.convexHull(
                    np.column_stack([pxs, pys]).astype(np.float32)))
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
            good = self.skin_mask(hsv_px, bgr_px)
            if not strict:
                # a part of ripening colour: its green-graded pixels are not its skin but the
                # calyx, sepals and stems across it (seen from the calyx side, a star of
                # them fills the middle of a red fruit and graded it pink)
                ripeness = self.pixel_ripeness(hsv_px)
                good &= ripeness >= p['skin_min_ripeness']
                score, chroma, mean_bgr = self._score_pixels(hsv_px[good], bgr_px[good],
                                                             ripeness[good], mean_bgr=True)
            else:
                score, chroma, mean_bgr = self._score_pixels(hsv_px[good], bgr_px[good],
                                                             mean_bgr=True)
            min_fill = p['min_fill_green'] if strict or score < STAGE_THRESHOLDS[0] else \
                p['min_fill']
            if inside < p['min_inside'] or fill < min_fill:
                continue
            if self._see_through(frame, part, ox, oy, cx, cy, r) > p['max_see_through']:
                continue          # background shows where the circle says fruit: wrong circle
            if strict and score < p['outline_gate_score'] and not self._round_fruit_surface(
                    frame, cx + ox, cy + oy, r, hsv_px, circle, fill, inside, score):
                continue          # green, but not round or no edge all round: a leaf
            if not strict and p['chord_refit'] > 0:
                # a leaf's straight edge across the fruit lies on its outline's hull and pulls
                # the circle in: fitted again without it, the circle is taken when it is no
                # smaller, at most `chord_grow` x as large, moved by at most 0.3 r, and
                # follows its points at least as well
                fit = self._fit_part(part, outer, r, max_chord=p['chord_refit'])
                if fit is not None and fit[3] < 1.0 and fit[3] <= residual and \
                        r <= fit[2] <= p['chord_grow'] * r and \
                        math.hypot(fit[0] - cx, fit[1] - cy) <= 0.3 * r:
                    cx, cy, r = fit[:3]
            x0 = max(int(math.floor(cx - r)) - 1, 0)
            y0 = max(int(math.floor(cy - r)) - 1, 0)
            crop = part[y0:int(math.ceil(cy + r)) + 2, x0:int(math.ceil(cx + r)) + 2]
            # the outline pixels' centres lie half a pixel inside the fruit's edge: r + 0.5
            results.append(Detection(
                (cx + ox + 0.5) / scale - 0.5, (cy + oy + 0.5) / scale - 0.5, (r + 0.5) / scale,
                score,
                mask=crop.copy(), mask_origin=(x0 + ox, y0 + oy), mask_scale=scale,
                fill=fill, area_px=area / (scale * scale), chroma=chroma,
                hue_angle=float('nan') if mean_bgr is None else lab_hue_angle(mean_bgr),
                behind=index in in_front))
        return results

    def _front_fruit(self, candidate, outer, inscribed=None, samples=48, min_inner=6):
        """Hypothesis D: a ripe part is a fruit in front of another of its colour. Both are in
        one part (one distance-transform peak, the front fruit's), whose outline is the front
        fruit's arc and the arc of the one behind; the circle fitted to it spans both, wider
        than the part's inscribed circle (more than `front_ratio` x its radius), where the
        front fruit's own circle is about as wide as that inscribed circle. When the outline
        holds such an arc (its circle at most `front_radius` x the inscribed radius, following
        the arc at least as well as the wide circle follows the outline, `max_residual_refit`
        at most, `min_front_outline` of it along the outline, filled as a green fruit's must be)
        and the small circle runs through the part's inside for at least `min_inner` of
        `samples` points (the front fruit's rim across the one behind), the candidate takes
        that circle: the result loop then keeps what it holds as the front fruit and examines
        the rest as the fruit behind (as the refit of a thin part does). Else the candidate
        comes back as it was. candidate: (part, circle, pixels) as _split_component has them;
        inscribed: the part's distance map (cv2.DIST_L2, mask 5) when known."""
        p = self.params
        part, circle, coords = candidate
        area = len(coords[0]) if coords is not None else int(np.count_nonzero(part))
        if area < p['refit_fill'] * math.pi * circle[2] ** 2:
            return candidate      # too thin for its circle: the result loop refits it
        ox = oy = 0
        if inscribed is None:
            # on the part's bounding box (+1 px of background): a part of a large region is a
            # small share of its crop
            bx, by, bw, bh = cv2.boundingRect(part.view(np.uint8))
            if bw == 0 or bh == 0:
                return candidate
            ox, oy = max(bx - 1, 0), max(by - 1, 0)
            inscribed = cv2.distanceTransform(
                part[oy:by + bh + 1, ox:bx + bw + 1].view(np.uint8), cv2.DIST_L2, 5)
        pr = float(inscribed.max())
        residual = circle[3] if len(circle) > 3 else 1.0
        if pr <= 0 or circle[2] <= p['front_ratio'] * pr or area > 2.0 * math.pi * pr * pr:
            return candidate      # (larger than the front fruit and one of its size behind)
        # fit_part's radii reach r_high x pr + 2 px: the front fruit's at most front_radius x pr
        front = self._fit_part(part, outer, pr,
                               r_high=max(p['front_radius'] - 2.0 / pr, 0.85))
        if front is None or front[2] >= circle[2] or \
                front[3] > min(residual, p['max_residual_refit']):
            return candidate
        cx, cy, r = front[:3]
        xs, ys, on = circle_pixels(cx - ox, cy - oy, r, inscribed.shape, samples)
        # inside the part, 3 px or more from its edge
        if np.count_nonzero(inscribed[ys[on], xs[on]] > 3.0) < min_inner:
            return candidate
        pys, pxs = coords if coords is not None else np.nonzero(part)
        held = np.count_nonzero((pxs - cx) ** 2 + (pys - cy) ** 2 <= (r + 1.5) ** 2)
        if held < p['min_fill_green'] * math.pi * r * r or \
                outline_cover(outer, cx, cy, r) < p['min_front_outline']:
            return candidate
        return part, front, coords

    def _join_parts(self, candidates, peak_rs, outer):
        """Hypothesis C: two neighbouring parts are one fruit (a leaf or calyx notch in its
        outline made two distance-transform peaks) when their circles overlap, one circle
        follows their joint outline within `join_residual_px` (median) and holds `min_inside`
        of their pixels. (Small parts fit their own short arcs almost exactly, so comparing
        with the parts' fits, as hypothesis B does, would keep them apart.) Greedy, best first.
        candidates: (part, circle, (rows, cols) of its pixels), disjoint parts. A joined part
        comes back with None for its pixels (they are not in np.nonzero's order)."""
        p = self.params
        kernel = cv2.getStructuringElement(cv2.MORPH_RECT, (3, 3))
        # each part gets a serial number; a pair's verdict does not change when another pair
        # is joined, so it is computed once (a cluster of n parts has n^2 / 2 pairs per round)
        # (part, circle, inscribed radius, serial, [(rows, cols) of its pieces] or None)
        cands = [(part, circle, pr, k, [coords])
                 for k, ((part, circle, coords), pr) in enumerate(zip(candidates, peak_rs))]
        serial = len(cands)
        verdicts = {}        # (serial i, serial j) -> (residual, union, fit) or None
        grown = {}           # serial -> the part grown by a pixel (once per part, not per pair)

        def verdict(a, b):
            (xi, yi, ri), (xj, yj, rj) = a[1][:3], b[1][:3]
            if math.hypot(xi - xj, yi - yj) > 0.9 * (ri + rj):
                return None       # two whole fruit side by side, not halves of one
            if a[3] not in grown:
                grown[a[3]] = cv2.dilate(a[0].view(np.uint8), kernel).view(bool)
            if not np.any(grown[a[3]] & b[0]):
                return None
            union = a[0] | b[0]
            fit = self._fit_part(union, outer, max(a[2], b[2]))
            if fit is None or fit[3] * fit[2] > p['join_residual_px']:
                return None
            cx, cy, r = fit[:3]
            # the union's pixels are the disjoint parts' pixels: counted piece by piece
            pieces = a[4] + b[4]
            share = float(sum(np.count_nonzero((pxs - cx) ** 2 + (pys - cy) ** 2 <=
                                               (r + 1.5) ** 2) for pys, pxs in pieces)) / \
                sum(len(pys) for pys, _ in pieces)
            if share < p['min_inside']:
                return None
            return fit[3], union, fit

        while len(cands) > 1:
            best = None
            for i in range(len(cands)):
                for j in range(i + 1, len(cands)):
                    key = (cands[i][3], cands[j][3])
                    if key not in verdicts:
                        verdicts[key] = verdict(cands[i], cands[j])
                    found = verdicts[key]
                    if found is not None and (best is None or found[0] < best[0]):
                        best = (found[0], i, j, found[1], found[2])
            if best is None:
                break
            _, i, j, union, fit = best
            joined = (union, fit, max(cands[i][2], cands[j][2]), serial,
                      cands[i][4] + cands[j][4])
            serial += 1
            cands = [c for k, c in enumerate(cands) if k not in (i, j)] + [joined]
        return [(c[0], c[1], c[4][0] if len(c[4]) == 1 else None) for c in cands]

    #: circle of a part's outline (vision_pkg.circle_fit.fit_part)
    _fit_part = staticmethod(fit_part)


def share_inside(det, other):
    """Fraction of det's visible part (its mask; every detection of detect() has one) inside
    other's fitted circle."""
    ys, xs = np.nonzero(det.mask)
    if not len(xs):
        return 0.0
    u = (xs + det.mask_origin[0] + 0.5) / det.mask_scale - 0.5
    v = (ys + det.mask_origin[1] + 0.5) / det.mask_scale - 0.5
    return _share((u - other.u) ** 2 + (v - other.v) ** 2 <= other.radius_px ** 2)


def _share(flags):
    """np.mean of a boolean array (the same float; NaN when empty) without its overhead."""
    return float(np.count_nonzero(flags)) / flags.size if flags.size else float('nan')


def fill_holes(comp):
    """Fill the holes of a 0/1 uint8 region (highlights, dark spots on the skin)."""
    padded = cv2.copyMakeBorder(comp, 1, 1, 1, 1, cv2.BORDER_CONSTANT, value=0)
    flood = padded.copy()
    ffmask = np.zeros((padded.shape[0] + 2, padded.shape[1] + 2), np.uint8)
    cv2.floodFill(flood, ffmask, (0, 0), 1)
    holes = flood[1:-1, 1:-1] == 0
    out = comp.copy()
    out[holes] = 1
    return out
