"""Surface and outline evidence of a green fruit, rospy-free (step 4 of vision_pkg.detection).

Green fruit share their colour with leaves; a smooth, shaded sphere ends in a brightness edge all
round its circle, a leaf's outline does not follow a circle. RoundSurface holds the gradient maps
and the edge measures along a candidate circle that TomatoDetector (its subclass, with its
params) uses for the candidates of its strict pass.
"""
import math

import cv2
import numpy as np


class RoundSurface(object):
    """Edge evidence along fruit circles (a mixin of TomatoDetector: self.params, self.trace)."""

    @staticmethod
    def gradient_maps(gray):
        """(gx, gy) float32 brightness gradient of a grey image relative to the local mean
        brightness, so an outline's edge strength does not depend on the exposure."""
        g = gray.astype(np.float32)
        bright = cv2.blur(g, (5, 5)) + 12.0
        gx = cv2.Sobel(g, cv2.CV_32F, 1, 0, ksize=3) / (4.0 * bright)
        gy = cv2.Sobel(g, cv2.CV_32F, 0, 1, ksize=3) / (4.0 * bright)
        return gx, gy

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
        height, width = frame.gray.shape
        a = np.linspace(0.0, 2.0 * math.pi, samples, endpoint=False)
        ca, sa = np.cos(a), np.sin(a)
        best = np.zeros(samples, dtype=np.float32)
        inside = np.zeros(samples, dtype=bool)
        points = []
        for dr in (-2.0, -1.0, 0.0, 1.0, 2.0):
            xs = np.rint(cx + (r + dr) * ca).astype(np.int64)
            ys = np.rint(cy + (r + dr) * sa).astype(np.int64)
            ok = (xs >= 1) & (ys >= 1) & (xs < width - 1) & (ys < height - 1)
            inside |= ok
            xs = np.minimum(np.maximum(xs, 0), width - 1)
            ys = np.minimum(np.maximum(ys, 0), height - 1)
            points.append((xs, ys, ok))
        # the gradients of the window the samples lie in, not of the whole image
        x0 = min(int(p[0].min()) for p in points)
        y0 = min(int(p[1].min()) for p in points)
        gx, gy = frame.gradients(x0, y0, max(int(p[0].max()) for p in points) + 1,
                                 max(int(p[1].max()) for p in points) + 1)
        for xs, ys, ok in points:
            radial = np.abs(gx[ys - y0, xs - x0] * ca + gy[ys - y0, xs - x0] * sa)
            best = np.maximum(best, np.where(ok, radial, 0.0))
        return np.where(inside, best, np.nan)

    def edge_support(self, frame, cx, cy, r, samples=48):
        """Fraction of a circle (working pixels) along which the brightness has a radial edge
        of at least `edge_min` (relative gradient), within +-2 px of the circle."""
        if frame.gray is None:
            return 1.0
        best = self.edge_profile(frame, cx, cy, r, samples)
        best = best[np.isfinite(best)]
        if not len(best):
            return 0.0
        return float(np.mean(best >= float(self.params['edge_min'])))
