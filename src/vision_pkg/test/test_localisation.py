"""3D pick point from an organized stereo cloud (offline StereoBM on a synthetic pair)."""
import math

import numpy as np
import pytest

import synthetic_scene as scene
from vision_pkg import localisation
from vision_pkg.detection import Detection, TomatoDetector

STEREO = {'prefilter_size': 9, 'prefilter_cap': 31, 'correlation_window_size': 15,
          'min_disparity': 64, 'disparity_range': 192, 'uniqueness_ratio': 10,
          'texture_threshold': 10, 'speckle_size': 100, 'speckle_range': 4}
P_RIGHT = [scene.FOCAL, 0.0, scene.CX, -scene.FOCAL * scene.BASELINE,
           0.0, scene.FOCAL, scene.CY, 0.0, 0.0, 0.0, 1.0, 0.0]


@pytest.fixture(scope='module')
def stereo_scene():
    fruits = [scene.Fruit(-0.12, 0.02, 0.45, 0.035, 0.95),
              scene.Fruit(0.08, -0.05, 0.60, 0.03, 0.9),
              scene.Fruit(0.02, 0.12, 0.75, 0.04, 0.8)]
    right, _, _ = scene.render(fruits, (), 'right', backdrop_depth=0.95)
    left, _, _ = scene.render(fruits, (), 'left', backdrop_depth=0.95)
    cloud = localisation.offline_cloud(left, right, STEREO, scene.FOCAL, scene.FOCAL, scene.CX,
                                       scene.CY, scene.BASELINE)
    dets = TomatoDetector().detect(right)
    pairs = []
    for fruit in fruits:
        u, v = scene.project(fruit.centre)
        det = min(dets, key=lambda d: math.hypot(d.u - u, d.v - v))
        pairs.append((fruit, det))
    return cloud, pairs


def _truth_left(fruit):
    return fruit.centre + np.array([scene.BASELINE, 0.0, 0.0])


def test_pick_points_within_5mm(stereo_scene):
    cloud, pairs = stereo_scene
    for fruit, det in pairs:
        loc = localisation.locate(cloud, det, P_RIGHT)
        assert loc is not None
        err = np.linalg.norm(loc.centre - _truth_left(fruit))
        assert err < 0.005, (fruit.centre, loc, err)
        assert loc.radius == pytest.approx(fruit.radius, abs=0.004)


def test_robust_to_holes_and_outliers(stereo_scene):
    cloud, pairs = stereo_scene
    rng = np.random.RandomState(3)
    holed = cloud.copy()
    holed[rng.random_sample(holed.shape[:2]) < 0.6] = np.nan        # 60 % random holes
    for fruit, det in pairs:
        # a big hole over the fruit's left half in the left image, and 10 % junk depths
        u, v = scene.project(fruit.centre, 'left')
        r = int(det.radius_px)
        holed[int(v) - r:int(v) + r, int(u) - r:int(u)] = np.nan
    junk = rng.random_sample(holed.shape[:2]) < 0.1
    holed[junk, 2] = rng.uniform(0.3, 1.5, junk.sum())
    for fruit, det in pairs:
        loc = localisation.locate(holed, det, P_RIGHT)
        assert loc is not None
        assert np.linalg.norm(loc.centre - _truth_left(fruit)) < 0.008


def test_no_points_no_location(stereo_scene):
    cloud, pairs = stereo_scene
    empty = np.full_like(cloud, np.nan)
    assert localisation.locate(empty, pairs[0][1], P_RIGHT) is None


def test_sphere_ray_recovers_off_axis_centre():
    f, cx, cy = 800.0, 512.0, 384.0
    centre = np.array([0.25, -0.15, 0.5])
    radius = 0.04
    # silhouette edges along the radial direction
    d = centre / np.linalg.norm(centre)
    alpha = math.asin(radius / np.linalg.norm(centre))
    rho_dir = centre[:2] / np.linalg.norm(centre[:2])
    theta = math.atan2(np.linalg.norm(centre[:2]), centre[2])
    e1, e2 = math.tan(theta + alpha), math.tan(theta - alpha)
    mid = 0.5 * (e1 + e2) * f
    u, v = cx + rho_dir[0] * mid, cy + rho_dir[1] * mid
    axis, a = localisation.sphere_ray(u, v, 0.5 * (e1 - e2) * f, f, f, cx, cy)
    assert np.allclose(axis, d, atol=1e-9)
    assert a == pytest.approx(alpha, abs=1e-9)


@pytest.mark.parametrize('point_step', [16, 32])
def test_cloud_array_from_pointcloud2_bytes(point_step):
    h, w = 3, 4
    xyz = np.arange(h * w * 3, dtype=np.float32).reshape(h, w, 3)
    raw = np.zeros((h, w, point_step // 4), np.float32)
    raw[..., :3] = xyz
    out = localisation.cloud_array(raw.tobytes(), h, w, point_step, w * point_step, (0, 4, 8))
    assert np.array_equal(out, xyz)


def test_projection_params():
    fx, fy, cx, cy, b = localisation.projection_params(P_RIGHT)
    assert b == pytest.approx(scene.BASELINE)
    with pytest.raises(ValueError):
        localisation.projection_params([0.0] * 12)


def test_points_on_fruit_only_inside_the_part():
    cloud = np.full((40, 60, 3), np.nan, np.float32)
    cloud[10:20, 20:30] = [0.0, 0.0, 1.0]
    det = Detection(25.0, 15.0, 3.0, 1.0)
    p = [100.0, 0.0, 25.0, 0.0, 0.0, 100.0, 15.0, 0.0, 0.0, 0.0, 1.0, 0.0]
    pts = localisation.points_on_fruit(cloud, det, p)
    assert 0 < len(pts) <= 100


def test_a_fruit_seen_only_by_its_highlight_is_ranged_by_the_highlight_virtual_image():
    """In dim light a glossy fruit's skin has no texture: stereo matches only the highlight, the
    light's virtual image R/2 behind the skin's front, so the skin model put the centre too far.
    Given the image, those points are ranged as the virtual image."""
    import cv2
    radius, centre = 0.035, np.array([0.03, -0.02, 0.55])       # right camera frame
    u0, v0 = scene.project(centre)
    r_px = scene.FOCAL * radius / centre[2]
    image = np.zeros((scene.HEIGHT, scene.WIDTH, 3), np.uint8)
    cv2.circle(image, (int(round(u0)), int(round(v0))), int(r_px), (30, 40, 120), -1)
    gu, gv = u0 - 0.3 * r_px, v0 - 0.35 * r_px          # the highlight, up and left of centre
    cv2.circle(image, (int(round(gu)), int(round(gv))), 5, (200, 210, 250), -1)
    cloud = np.full((scene.HEIGHT, scene.WIDTH, 3), np.nan, np.float32)
    axis = centre / np.linalg.norm(centre)
    virtual = np.linalg.norm(centre) - radius / 2.0      # depth of the virtual image along the axis
    for dv in range(-4, 5):
        for du in range(-4, 5):
            if du * du + dv * dv > 16:
                continue
            u, v = gu + du, gv + dv
            ray = np.array([(u - scene.CX) / scene.FOCAL, (v - scene.CY) / scene.FOCAL, 1.0])
            point = ray * (virtual / ray.dot(axis))          # right frame
            left = point + np.array([scene.BASELINE, 0.0, 0.0])
            ul = int(round(scene.FOCAL * left[0] / left[2] + scene.CX))
            cloud[int(round(v)), ul] = left
    det = Detection(u0, v0, r_px, 0.95)
    truth = centre + np.array([scene.BASELINE, 0.0, 0.0])
    skin_only = localisation.locate(cloud, det, P_RIGHT)
    assert np.linalg.norm(skin_only.centre - truth) > 0.012       # the old bias: about R/2
    ranged = localisation.locate(cloud, det, P_RIGHT, image=image)
    assert np.linalg.norm(ranged.centre - truth) < 0.003, ranged
    # a fruit whose points are all on its ordinary skin is ranged as before
    dull = image.copy()
    cv2.circle(dull, (int(round(gu)), int(round(gv))), 5, (30, 40, 120), -1)
    assert np.allclose(localisation.locate(cloud, det, P_RIGHT, image=dull).centre,
                       skin_only.centre)
