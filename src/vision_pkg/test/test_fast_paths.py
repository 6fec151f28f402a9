"""The detector's fast paths give exactly what their plain numpy/OpenCV forms give (they were
written for speed; bench_detection's figures must not move with them)."""
import math

import cv2
import numpy as np
import pytest

from vision_pkg import circle_fit
from vision_pkg.detection import TomatoDetector
from vision_pkg.regions import Frame, _share


def _hull_distance_plain(hull, xs, ys):
    """Distance of each point to the nearest edge line of the polygon, edge by edge."""
    pts = hull.reshape(-1, 2).astype(np.float64)
    best = np.full(len(xs), np.inf)
    for a, b in zip(pts, np.roll(pts, -1, axis=0)):
        ab = b - a
        length = math.hypot(*ab)
        if length <= 1e-9:
            continue
        cross = ab[0] * (ys - a[1]) - ab[1] * (xs - a[0])
        best = np.minimum(best, np.abs(cross) / length)
    return best


@pytest.mark.parametrize('seed', range(5))
def test_hull_distance_matches_the_edge_by_edge_distance(seed):
    rng = np.random.default_rng(seed)
    blob = np.zeros((120, 140), np.uint8)
    for _ in range(4):
        cv2.circle(blob, tuple(int(c) for c in rng.integers(30, 100, 2)),
                   int(rng.integers(10, 30)), 1, -1)
    contours = cv2.findContours(blob, cv2.RETR_EXTERNAL, cv2.CHAIN_APPROX_SIMPLE)[-2]
    hull = cv2.convexHull(np.vstack(contours))
    ys, xs = np.nonzero(blob)
    fast = circle_fit.hull_distance(hull, xs, ys)
    assert np.allclose(fast, _hull_distance_plain(hull, xs, ys), rtol=0.0, atol=1e-9)
    # and the outline test the fit uses picks the same pixels
    assert np.array_equal(fast <= 1.5, _hull_distance_plain(hull, xs, ys) <= 1.5)


def test_median_is_numpys_median_for_odd_and_even_lengths():
    rng = np.random.default_rng(3)
    for n in (1, 2, 3, 10, 11, 128, 129):
        values = rng.random(n)
        assert circle_fit._median(values) == float(np.median(values))


def test_share_is_the_mean_of_a_boolean_array():
    flags = np.random.default_rng(4).random(1001) < 0.3
    assert _share(flags) == float(np.mean(flags))
    assert math.isnan(_share(np.zeros(0, bool)))


def test_triple_index_is_the_scaled_triples():
    for n in (8, 57, 300):
        expected = np.minimum((circle_fit._triples(0, 60) * n).astype(np.int64), n - 1)
        assert np.array_equal(circle_fit._triple_index(0, 60, n), expected)


def test_a_parts_centroid_is_cv2_moments_one():
    part = np.zeros((90, 70), np.uint8)
    cv2.ellipse(part, (33, 41), (25, 17), 30.0, 0.0, 360.0, 1, -1)
    outer = part.astype(bool) & (cv2.erode(part, np.ones((3, 3), np.uint8)) == 0)
    moments = cv2.moments(part, True)
    mx, my = moments['m10'] / moments['m00'], moments['m01'] / moments['m00']
    # a fit that falls back (outline of fewer than 8 pixels) returns the centroid itself
    few = np.zeros_like(outer)
    ys, xs = np.nonzero(outer)
    few[ys[:5], xs[:5]] = True
    fallback = circle_fit._fit_crop(part, few, 10.0, 3.0)
    assert fallback[:2] == (mx, my)
    assert fallback[2] == max(10.0, math.sqrt(moments['m00'] / math.pi))


def test_window_gradients_equal_the_whole_images_maps():
    rng = np.random.default_rng(5)
    gray = cv2.GaussianBlur(rng.integers(0, 256, (150, 210), dtype=np.uint8), (5, 5), 1.5)
    gx, gy = TomatoDetector.gradient_maps(gray)
    frame = Frame(None, None, 1.0)
    frame.gray = gray
    for x0, y0, x1, y1 in ((0, 0, 40, 30), (100, 60, 160, 130), (170, 120, 210, 150),
                           (-5, 20, 30, 200), (2, 1, 3, 2)):
        wx, wy = frame.gradients(x0, y0, x1, y1)
        cx0, cy0 = max(x0, 0), max(y0, 0)
        assert np.array_equal(wx, gx[cy0:y1, cx0:x1])
        assert np.array_equal(wy, gy[cy0:y1, cx0:x1])


def test_white_gains_per_channel_test_matches_the_chromaticity_box():
    """The reference candidates of white_gains, tested channel by channel, are the pixels
    whose chromaticity lies in the box (the form it had before)."""
    det = TomatoDetector()
    p = det.params
    rng = np.random.default_rng(6)
    image = rng.integers(0, 256, (200, 240, 3), dtype=np.uint8)
    image[:60, :80] = (200, 205, 210)       # a pale, nearly neutral patch: a white reference
    pix = image[::4, ::4].reshape(-1, 3)
    total = pix.astype(np.int32).sum(axis=1)
    chroma = pix.astype(np.float32) / np.maximum(total, 1)[:, None].astype(np.float32)
    top = pix.max(axis=1)
    cand = (top < 250) & (top > 60) & \
        (np.abs(chroma - 1.0 / 3.0).max(axis=1) <= float(p['wb_chroma_box'])) & \
        (chroma[:, 1] <= float(p['wb_max_green']))
    count = int(cand.sum())
    assert count >= max(20, float(p['wb_min_fraction']) * len(pix))
    k = min(max(int(count * float(p['wb_top_fraction'])), 20), count)
    ref = pix[cand][np.argpartition(total[cand], count - k)[-k:]].astype(np.float64).mean(axis=0)
    gains = (ref.sum() / 3.0) / np.maximum(ref, 1.0)
    gains /= gains.mean()
    bound = float(p['wb_max_gain'])
    assert np.array_equal(det.white_gains(image), np.clip(gains, 1.0 / bound, bound))


def test_skin_mean_colour_is_numpys_mean():
    """_score_pixels' mean BGR (OpenCV's channel sums) equals numpy's float64 mean."""
    det = TomatoDetector()
    rng = np.random.default_rng(7)
    for n in (1, 37, 4000):
        bgr = rng.integers(0, 256, (n, 3), dtype=np.uint8)
        hsv = cv2.cvtColor(bgr.reshape(-1, 1, 3), cv2.COLOR_BGR2HSV).reshape(-1, 3)
        mean = det._score_pixels(hsv, bgr, mean_bgr=True)[2]
        assert np.array_equal(mean, bgr.sum(axis=0, dtype=np.float64) / n)


def _kasa_plain(xs, ys):
    """Kasa's circle from its 2 x 2 normal equations in coordinates centred on the points'
    mean, sum by sum (the form circle_fit had before it took the sums as one matrix product)."""
    u, v = xs - xs.mean(), ys - ys.mean()
    uu, vv, uv = u.dot(u), v.dot(v), u.dot(v)
    w = u * u + v * v
    bu, bv = 0.5 * u.dot(w), 0.5 * v.dot(w)
    det = uu * vv - uv * uv
    uc, vc = (bu * vv - bv * uv) / det, (bv * uu - bu * uv) / det
    return uc + xs.mean(), vc + ys.mean(), math.sqrt(uc * uc + vc * vc + (uu + vv) / len(xs))


@pytest.mark.parametrize('seed', range(6))
def test_the_moment_matrix_kasa_fit_is_the_centred_one(seed):
    rng = np.random.default_rng(seed)
    for _ in range(20):
        # an arc of an outline in image pixels, far from the origin, with pixel noise
        cx, cy, r = rng.uniform(50, 1500), rng.uniform(50, 1000), rng.uniform(8, 150)
        a = rng.uniform(0, 2 * math.pi) + np.linspace(0, rng.uniform(0.8, 2 * math.pi),
                                                      int(rng.integers(8, 600)))
        xs = np.rint(cx + r * np.cos(a)) + rng.integers(-1, 2, len(a))
        ys = np.rint(cy + r * np.sin(a)) + rng.integers(-1, 2, len(a))
        if len(set(zip(xs, ys))) < 5:
            continue
        assert np.allclose(circle_fit.fit_circle(xs, ys), _kasa_plain(xs, ys),
                           rtol=0.0, atol=1e-7)
    # and the degenerate cases stay None
    assert circle_fit.fit_circle(np.arange(10.0), 2.0 * np.arange(10.0)) is None
    assert circle_fit.fit_circle(np.arange(4.0), np.arange(4.0) ** 2) is None


def test_the_fits_are_the_same_wherever_the_outline_lies_in_the_image():
    """The fits work relative to the points' rounded mean: shifting an outline by whole pixels
    shifts the circles they find and changes nothing else."""
    a = np.linspace(math.pi, 2 * math.pi, 80)
    xs = np.rint(np.concatenate([40 + 25 * np.cos(a), np.linspace(15, 65, 50)]))
    ys = np.rint(np.concatenate([30 + 25 * np.sin(a), np.full(50, 30.0)]))
    for fit in (lambda x, y: circle_fit.robust_fit_circle(x, y),
                lambda x, y: circle_fit.arc_fit_circle(x, y, 10.0, 60.0)):
        base = fit(xs, ys)
        for dx, dy in ((700, 0), (0, 480), (1234, 567)):
            moved = fit(xs + dx, ys + dy)
            assert moved == pytest.approx((base[0] + dx, base[1] + dy, base[2]), abs=1e-9)


def test_hull_distance_leaves_out_the_inside_of_a_long_straight_cut():
    """A disc with its top cut off by a straight edge: outline points along that hull edge
    (longer than max_chord x the hull's equivalent radius) are left out, but for 1.5 px at
    either end; without max_chord the distances are the plain ones."""
    import cv2
    from vision_pkg.circle_fit import hull_distance
    part = np.zeros((120, 120), np.uint8)
    cv2.circle(part, (60, 60), 40, 1, -1)
    part[:35] = 0                                   # the cut: row 35, about 62 px long
    contours = cv2.findContours(part, cv2.RETR_EXTERNAL, cv2.CHAIN_APPROX_SIMPLE)[-2]
    hull = cv2.convexHull(np.vstack(contours))
    xs = np.array([40.0, 60.0, 80.0, 60.0, 100.0, 30.0])
    ys = np.array([35.0, 35.0, 35.0, 100.0, 60.0, 35.0])
    plain = hull_distance(hull, xs, ys)
    assert np.all(plain < 1.0)                      # all of them on the hull
    cut = hull_distance(hull, xs, ys, max_chord=0.9)
    assert np.all(np.isinf(cut[:3]))                # along the cut
    assert np.allclose(cut[3:5], plain[3:5])        # on the arc
    assert np.isfinite(cut[5])                      # 1.2 px from an end of the cut
    assert np.array_equal(hull_distance(hull, xs, ys, max_chord=0.0), plain)
