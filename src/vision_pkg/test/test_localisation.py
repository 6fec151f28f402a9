"""3D pick point from an organized stereo cloud (offline StereoBM on a synthetic pair)."""
import functools
import math

import cv2
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


#: the stereo_scene fixture's fruit
STEREO_FRUITS = [scene.Fruit(-0.12, 0.02, 0.45, 0.035, 0.95),
                 scene.Fruit(0.08, -0.05, 0.60, 0.03, 0.9),
                 scene.Fruit(0.02, 0.12, 0.75, 0.04, 0.8)]


@pytest.fixture(scope='module')
def stereo_scene():
    fruits = STEREO_FRUITS
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


def _silhouette(centre, radius, f, cx, cy, samples=720):
    """Image points of a sphere's silhouette (the cone of rays tangent to it), evenly spaced
    along the outline as an outline's pixels are."""
    d = centre / np.linalg.norm(centre)
    alpha = math.asin(radius / np.linalg.norm(centre))
    e1 = np.cross(d, [1.0, 0.0, 0.0] if abs(d[2]) > 0.9 else [0.0, 0.0, 1.0])
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(d, e1)
    phi = np.linspace(0.0, 2.0 * math.pi, 20000, endpoint=False)
    rays = math.cos(alpha) * d + math.sin(alpha) * (np.cos(phi)[:, None] * e1 +
                                                    np.sin(phi)[:, None] * e2)
    u, v = cx + f * rays[:, 0] / rays[:, 2], cy + f * rays[:, 1] / rays[:, 2]
    step = np.hypot(np.diff(np.r_[u, u[0]]), np.diff(np.r_[v, v[0]]))
    along = np.cumsum(step)
    idx = np.searchsorted(along, np.linspace(0.0, along[-1], samples, endpoint=False))
    return u[idx], v[idx], d, alpha


def test_sphere_image_axes_are_the_silhouettes_extents():
    f, cx, cy = 800.0, 512.0, 384.0
    centre = np.array([0.25, -0.15, 0.5])
    u, v, d, alpha = _silhouette(centre, 0.04, f, cx, cy)
    theta = math.acos(d[2])
    mid, a, b = localisation.sphere_image_axes(theta, alpha)
    radial = centre[:2] / np.linalg.norm(centre[:2])
    along = (u - cx) * radial[0] + (v - cy) * radial[1]
    across = -(u - cx) * radial[1] + (v - cy) * radial[0]
    assert 0.5 * (along.max() + along.min()) == pytest.approx(mid * f, abs=0.02)
    assert 0.5 * (along.max() - along.min()) == pytest.approx(a * f, abs=0.02)
    assert 0.5 * (across.max() - across.min()) == pytest.approx(b * f, abs=0.02)
    assert b < 0.95 * a          # 31 degrees off the axis: a tenth longer than wide


@pytest.mark.parametrize('centre', [(0.25, -0.15, 0.5), (-0.3, 0.2, 0.55), (0.02, 0.01, 0.6),
                                    (0.0, 0.0, 0.45)])
def test_sphere_ray_recovers_the_centre_from_the_silhouettes_fitted_circle(centre):
    """The detector's circle is the least-squares circle of the silhouette's outline; from it
    sphere_ray finds the centre ray and the angular radius, on and off the axis."""
    from vision_pkg.circle_fit import fit_circle
    f, cx, cy = 800.0, 512.0, 384.0
    centre = np.array(centre)
    u, v, d, alpha = _silhouette(centre, 0.035, f, cx, cy)
    cu, cv, r = fit_circle(u, v)
    axis, a = localisation.sphere_ray(cu, cv, r, f, f, cx, cy)
    assert math.degrees(math.acos(min(axis.dot(d), 1.0))) < 0.005
    assert a == pytest.approx(alpha, rel=2e-4)
    # the sphere's centre distance from the angular radius: within 0.1 mm at 0.6 m
    dist = np.linalg.norm(centre)
    assert 0.035 / math.sin(a) == pytest.approx(dist, abs=1e-4)


def _silhouette_detection(centre, radius, f, cx, cy, scale, width=1024, height=768):
    """A detection of a sphere whose part is its whole silhouette within the image, as the
    detector keeps it (a mask at `scale` of the image), with the least-squares circle of the
    part's outline; and the true centre ray and angular radius."""
    from vision_pkg.circle_fit import fit_circle
    centre = np.asarray(centre, dtype=np.float64)
    d = centre / np.linalg.norm(centre)
    alpha = math.asin(radius / np.linalg.norm(centre))
    my, mx = np.mgrid[0:int(height * scale), 0:int(width * scale)].astype(np.float64)
    u, v = (mx + 0.5) / scale - 0.5, (my + 0.5) / scale - 0.5
    rays = np.dstack([(u - cx) / f, (v - cy) / f, np.ones_like(u)])
    rays /= np.linalg.norm(rays, axis=2)[..., None]
    mask = rays.dot(d) >= math.cos(alpha)
    m = mask.astype(np.uint8)
    edge = mask & ~(cv2.erode(m, np.ones((3, 3), np.uint8)) > 0)
    cu, cv_, r = fit_circle(u[edge], v[edge])
    # the outline pixels' centres lie half a mask pixel inside the edge (as the detector's)
    return Detection(cu, cv_, r + 0.5 / scale, 0.9, mask=mask, mask_origin=(0, 0),
                     mask_scale=scale), d, alpha


@pytest.mark.parametrize('centre', [(0.25, -0.15, 0.5), (-0.3, 0.2, 0.55), (0.02, 0.01, 0.6)])
def test_silhouette_cone_recovers_the_centre_ray_from_the_outline(centre):
    """The rays through the outline of a sphere's silhouette make one angle with its centre
    ray: fitted to the part's outline pixels (the stereo head's masks are at half
    resolution), the cone gives the centre ray and the angular radius, on and off the axis."""
    f, cx, cy = 788.4, 511.5, 383.5
    det, d, alpha = _silhouette_detection(centre, 0.035, f, cx, cy, 0.5)
    axis, a = localisation.silhouette_cone(det, f, f, cx, cy)
    assert math.degrees(math.acos(min(axis.dot(d), 1.0))) < 0.05
    assert a == pytest.approx(alpha, rel=0.01)
    # without a part mask: the circle's sphere_ray
    bare = Detection(det.u, det.v, det.radius_px, 0.9)
    assert localisation.silhouette_cone(bare, f, f, cx, cy)[1] == \
        localisation.sphere_ray(det.u, det.v, det.radius_px, f, f, cx, cy)[1]


def test_silhouette_cone_of_a_fruit_cut_by_the_image_corner():
    """A fruit held by the suction arm near the stereo head lies in the image's corner, cut by
    two borders (plant_factory_led f02_3: its 3D radius came out 52.6 mm for 44.6, the
    relocation moved it 14 mm and the shear closed 12 mm from its peduncle). The circle of the
    visible arc is not the least-squares circle of the whole ellipse that sphere_ray assumes;
    the cone through the visible outline is still the sphere's."""
    f, cx, cy = 788.4, 511.5, 383.5
    centre = np.array([-0.267, 0.172, 0.43])
    det, d, alpha = _silhouette_detection(centre, 0.0446, f, cx, cy, 0.5)
    assert det.u - det.radius_px < 0 and det.v + det.radius_px > 767, 'cut by two borders'
    axis, a = localisation.silhouette_cone(det, f, f, cx, cy)
    assert a == pytest.approx(alpha, rel=0.01)
    assert math.degrees(math.acos(min(axis.dot(d), 1.0))) < 0.1
    _, a_circle = localisation.sphere_ray(det.u, det.v, det.radius_px, f, f, cx, cy)
    assert abs(a_circle / alpha - 1.0) > 0.03, 'the test needs a circle that misleads'


def test_silhouette_cone_the_circle_contradicts_is_not_taken(monkeypatch):
    """Where the part's outline follows the circle only along a short arc (here a larger
    outline, touching the circle from outside at one side), the cone through that arc is
    poorly constrained: one whose angular radius or axis the circle contradicts gives way to
    the circle's sphere_ray."""
    f, cx, cy, scale = 788.4, 511.5, 383.5, 0.5
    u0, v0, r = 600.0, 400.0, 40.0
    my, mx = np.mgrid[0:int(768 * scale), 0:int(1024 * scale)].astype(np.float64)
    u, v = (mx + 0.5) / scale - 0.5, (my + 0.5) / scale - 0.5
    big = 1.6 * r             # its outline meets the circle at (u0 + r, v0) only
    mask = np.hypot(u - (u0 - 0.6 * r), v - v0) <= big
    det = Detection(u0, v0, r, 0.9, mask=mask, mask_origin=(0, 0), mask_scale=scale)
    circle = localisation.sphere_ray(u0, v0, r, f, f, cx, cy)
    on = localisation.outline_on_circle(det)
    assert on is not None and len(on[0]) >= localisation.MIN_POINTS, 'enough outline on the arc'
    assert len(set(localisation.sector_index(*on).tolist())) <= 6, 'a quarter of the circle at most'
    with monkeypatch.context() as m:
        m.setattr(localisation, '_cone_agrees', lambda cone, circle: True)
        loose = localisation.silhouette_cone(det, f, f, cx, cy)
    assert not localisation._cone_agrees(loose, circle), 'the test needs a cone that misleads'
    axis, alpha = localisation.silhouette_cone(det, f, f, cx, cy)
    assert alpha == circle[1] and np.array_equal(axis, circle[0])
    # the bounds themselves: a cone within them is taken
    assert localisation._cone_agrees((circle[0], circle[1] * 1.2), circle)
    assert not localisation._cone_agrees((circle[0], circle[1] * 1.4), circle)
    assert not localisation._cone_agrees((circle[0], circle[1] / 1.4), circle)


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
    light's virtual image behind the skin, so the skin model put the centre too far. Given the
    image, those points are ranged as the virtual image (at the depth the astigmatic mirror
    puts it for the highlight's place on the disc)."""
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
    # depth at which block matching ranges the highlight along the axis: the centre's, less
    # k R (3/4 of the way from the skin to the light's virtual image)
    k = float(localisation.highlight_factor(gu - u0, gv - v0, r_px))
    virtual = np.linalg.norm(centre) - k * radius
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


# ---------------------------------------------------------------- occluders inside the part
SKIN_BGR = (30, 40, 160)
LEAF_BGR = (40, 140, 60)


def _ray(u, v):
    return np.stack([(u - scene.CX) / scene.FOCAL, (v - scene.CY) / scene.FOCAL,
                     np.ones_like(u)], axis=-1)


def _sphere_hit(rays, centre, radius):
    """Depth scale s of the nearest hit of each ray (right frame) on a sphere, NaN for a miss."""
    dd = (rays * rays).sum(-1)
    b = rays.dot(centre)
    disc = b * b - dd * (centre.dot(centre) - radius * radius)
    return np.where(disc > 0, (b - np.sqrt(np.maximum(disc, 0.0))) / dd, np.nan)


def _cloud_of(u, v, points_right):
    """Organized cloud (left grid, left frame) holding right-frame points seen at right pixels
    (u, v): what stereo_image_proc gives for matched pixels."""
    cloud = np.full((scene.HEIGHT, scene.WIDTH, 3), np.nan, np.float32)
    left = points_right + np.array([scene.BASELINE, 0.0, 0.0])
    ul = np.rint(scene.FOCAL * left[:, 0] / left[:, 2] + scene.CX).astype(int)
    cloud[np.rint(v).astype(int), ul] = left
    return cloud


def _occluded_fruit(occluder_depth=None, behind_depth=None, skin_step=3, rim_depth=None):
    """A red fruit (right frame) whose skin matches only on every `skin_step`-th pixel (it has
    little texture), seen through a circle-shaped part (mask None, as when a stem or leaf is
    bridged into it). occluder_depth: a textured green leaf band across the fruit's middle at
    that depth, matched on every pixel; behind_depth: a patch of the skin mismatched to that
    depth on every pixel (fruit colour). Returns (cloud, image, detection, true centre in the
    left frame)."""
    radius, centre = 0.035, np.array([0.03, -0.02, 0.55])
    u0, v0 = scene.project(centre)
    r_px = scene.FOCAL * radius / centre[2]
    vv, uu = np.mgrid[int(v0 - r_px) - 2:int(v0 + r_px) + 3,
                      int(u0 - r_px) - 2:int(u0 + r_px) + 3].astype(np.float64)
    rays = _ray(uu, vv)
    s = _sphere_hit(rays, centre, radius)
    fruit = np.isfinite(s)
    off = np.hypot(uu - u0, vv - v0) / r_px
    leaf = fruit & (np.abs((uu - u0) + 0.5 * (vv - v0)) < 0.45 * r_px) \
        if occluder_depth is not None else np.zeros_like(fruit)
    skin = fruit & ~leaf
    image = np.full((scene.HEIGHT, scene.WIDTH, 3), 90, np.uint8)
    image[vv[skin].astype(int), uu[skin].astype(int)] = SKIN_BGR
    image[vv[leaf].astype(int), uu[leaf].astype(int)] = LEAF_BGR
    matched = skin & (uu % skin_step == 0) & (vv % skin_step == 0)
    if rim_depth is not None:
        matched &= off > 0.9
        s = np.full_like(s, rim_depth)
    depth = np.where(matched, s, np.nan)
    depth[leaf] = occluder_depth if occluder_depth is not None else np.nan
    if behind_depth is not None:
        patch = skin & (np.hypot(uu - (u0 - 0.4 * r_px), vv - (v0 - 0.3 * r_px)) < 0.3 * r_px)
        depth[patch] = behind_depth
    ok = np.isfinite(depth)
    cloud = _cloud_of(uu[ok], vv[ok], rays[ok] * depth[ok][:, None])
    det = Detection(u0, v0, r_px, 0.95)
    return cloud, image, det, centre + np.array([scene.BASELINE, 0.0, 0.0])


def test_a_leaf_in_front_of_a_fruit_gives_the_fruit_centre_not_the_leafs():
    """Most of a textureless fruit's points can be a textured leaf or stem in front of it that
    its part holds: the median followed them (renders: 70-100 mm too near). The points are two
    depth clusters; the one with the part's colour is the fruit."""
    cloud, image, det, truth = _occluded_fruit(occluder_depth=0.47)
    pts = localisation.points_on_fruit(cloud, det, P_RIGHT)
    leafs = np.sum(np.abs(pts[:, 2] - 0.47) < 1e-3)
    assert leafs > len(pts) / 2, 'the leaf must be most of the points for this test to mean much'
    median_only = localisation.locate(cloud, det, P_RIGHT)          # no image, no colour
    assert np.linalg.norm(median_only.centre - truth) > 0.04
    loc = localisation.locate(cloud, det, P_RIGHT, image=image)
    assert np.linalg.norm(loc.centre - truth) < 0.002, loc
    assert loc.radius == pytest.approx(0.035, abs=0.001)
    assert loc.points < len(pts)            # the leaf's points are not used


def test_a_mismatch_behind_the_fruit_with_its_colour_does_not_win():
    """Points of the skin mismatched far behind it have the skin's colour; the fruit is the
    cluster with a fruit's radius, even when the mismatch has more points."""
    cloud, image, det, truth = _occluded_fruit(behind_depth=1.1, skin_step=4)
    pts = localisation.points_on_fruit(cloud, det, P_RIGHT)
    behind = np.sum(pts[:, 2] > 1.0)
    assert behind > len(pts) / 2
    loc = localisation.locate(cloud, det, P_RIGHT, image=image)
    assert np.linalg.norm(loc.centre - truth) < 0.002, loc
    # its radius (about 0.07 m) is what rules the mismatch out: allow any radius and it wins
    anything = localisation.locate(cloud, det, P_RIGHT, image=image, radius_range=(0.0, 1.0))
    assert anything.centre[2] > 1.0


def test_a_fruit_with_only_rim_points_has_no_3d_point():
    """Block matching smears the rim onto the background; a fruit with no points in the core of
    its silhouette (renders: one outside the left camera's view got 18 background points and
    came out 300 mm too far) has no 3D point."""
    cloud, image, det, truth = _occluded_fruit(rim_depth=0.95, skin_step=1)
    assert len(localisation.points_on_fruit(cloud, det, P_RIGHT)) >= localisation.MIN_POINTS
    assert localisation.locate(cloud, det, P_RIGHT, image=image) is None
    assert localisation.locate(cloud, det, P_RIGHT) is None
    whole, image, det, truth = _occluded_fruit(skin_step=1)
    assert np.linalg.norm(localisation.locate(whole, det, P_RIGHT, image=image).centre - truth) \
        < 0.002


def _two_spheres(centre, radius, other, other_radius, before, after):
    """The pixel grid around a sphere's circle in the right image (from `before` radii up-left
    of its centre to `after` radii down-right) and where its rays hit it and another sphere:
    ((u0, v0, r_px) of its circle, (x0, y0) of the grid, (uu, vv, rays), (depth scale on it,
    on the other), NaN for a miss)."""
    u0, v0 = scene.project(centre)
    r_px = scene.FOCAL * radius / centre[2]
    y0, x0 = int(v0 - before * r_px), int(u0 - before * r_px)
    vv, uu = np.mgrid[y0:int(v0 + after * r_px), x0:int(u0 + after * r_px)].astype(np.float64)
    rays = _ray(uu, vv)
    return (u0, v0, r_px), (x0, y0), (uu, vv, rays), \
        (_sphere_hit(rays, centre, radius), _sphere_hit(rays, other, other_radius))


def _with_part(u0, v0, r_px, score, part, x0, y0):
    """A detection of circle (u0, v0, r_px) whose part is `part` (a bool grid whose pixel
    [0, 0] is the image's (x0, y0)), cropped to the circle's box as the detector keeps it."""
    cx0, cy0 = int(math.floor(u0 - r_px)) - 1, int(math.floor(v0 - r_px)) - 1
    crop = part[cy0 - y0:int(math.ceil(v0 + r_px)) + 2 - y0,
                cx0 - x0:int(math.ceil(u0 + r_px)) + 2 - x0]
    return Detection(u0, v0, r_px, score, mask=crop.copy(), mask_origin=(cx0, cy0),
                     mask_scale=1.0)


def _fruit_behind_a_neighbour(back_step=2, front_step=1):
    """A red fruit (the detection's circle, radius 35 mm at 0.60 m) whose part also holds a
    neighbour of the same colour in front of it (33 mm at 0.53 m, to its left and overlapping
    it by a third), as when the detector's part runs over both: long_row f19_3 behind f19_1.
    The neighbour's skin matches on every `front_step`-th pixel, the fruit's on every
    `back_step`-th one. Returns (cloud, image, detection with the part's mask, true centre of
    the fruit and of the neighbour in the left frame)."""
    back_c, back_r = np.array([0.03, -0.02, 0.60]), 0.035
    front_c, front_r = np.array([-0.012, -0.016, 0.53]), 0.033
    (u0, v0, r_px), (x0, y0), (uu, vv, rays), (s_back, s_front) = _two_spheres(
        back_c, back_r, front_c, front_r, 2.2, 1.6)
    front = np.isfinite(s_front)
    back = np.isfinite(s_back) & ~front
    image = np.full((scene.HEIGHT, scene.WIDTH, 3), 90, np.uint8)
    part = front | back
    image[vv[part].astype(int), uu[part].astype(int)] = SKIN_BGR
    depth = np.full(uu.shape, np.nan)
    sel = front & (uu % front_step == 0) & (vv % front_step == 0)
    depth[sel] = s_front[sel]
    sel = back & (uu % back_step == 0) & (vv % back_step == 0)
    depth[sel] = s_back[sel]
    ok = np.isfinite(depth)
    cloud = _cloud_of(uu[ok], vv[ok], rays[ok] * depth[ok][:, None])
    det = _with_part(u0, v0, r_px, 0.95, part, x0, y0)
    offset = np.array([scene.BASELINE, 0.0, 0.0])
    return cloud, image, det, back_c + offset, front_c + offset


def test_a_neighbour_of_the_same_colour_in_front_does_not_take_the_fruits_place(monkeypatch):
    """The neighbour in front has the part's colour and a fruit's radius, and the most points:
    it was taken for the fruit, 70-76 mm too near (long_row f19_3: the suction cup closed on
    air). The fruit's points lie where the part's outline runs along its circle, the
    neighbour's where it does not: the fruit is the cluster in the outline's sectors."""
    cloud, image, det, truth, neighbour = _fruit_behind_a_neighbour(back_step=3)
    pts = localisation.points_on_fruit(cloud, det, P_RIGHT)
    near = np.sum(pts[:, 2] < 0.56)
    assert near > len(pts) / 2, 'the neighbour must be most of the points for this test'
    sectors = localisation.outline_sectors(det)
    assert 0 < sectors.sum() < len(sectors)
    # the outline follows the circle on the right (angle 0), not on the left (angle 180)
    assert sectors[localisation.sector_index(1.0, 0.0)]
    assert not sectors[localisation.sector_index(-1.0, 0.0)]
    loc = localisation.locate(cloud, det, P_RIGHT, image=image)
    assert np.linalg.norm(loc.centre - truth) < 0.003, loc
    # without the part's outline (no mask), and without the rule of a fruit hidden behind
    # (test_a_fruit_behind_a_neighbour_that_fills_its_whole_circle...), the largest cluster,
    # the neighbour, is taken
    no_mask = Detection(det.u, det.v, det.radius_px, det.score)
    _without_the_behind_rule(monkeypatch)
    old = localisation.locate(cloud, no_mask, P_RIGHT, image=image)
    assert np.linalg.norm(old.centre - truth) > 0.05
    assert old.centre[2] < neighbour[2] + 0.02


def test_a_fruit_in_front_keeps_its_place_over_a_neighbour_behind():
    """The mirror case: the detection is the fruit in front and the part runs over a
    neighbour behind it; the front fruit's points are in its outline's sectors and stay the
    fruit, also when they are fewer."""
    cloud, image, det, back, front = _fruit_behind_a_neighbour(back_step=1, front_step=2)
    u0, v0 = scene.project(front - np.array([scene.BASELINE, 0.0, 0.0]))
    r_px = scene.FOCAL * 0.033 / (front[2])
    # the front fruit's circle, with the same part (both fruit) cropped to its box
    whole = np.zeros((scene.HEIGHT, scene.WIDTH), bool)
    m = det.mask
    whole[det.mask_origin[1]:det.mask_origin[1] + m.shape[0],
          det.mask_origin[0]:det.mask_origin[0] + m.shape[1]] = m
    vv, uu = np.mgrid[0:scene.HEIGHT, 0:scene.WIDTH]
    inside_front = np.hypot(uu - u0, vv - v0) <= r_px
    whole |= inside_front
    cx0, cy0 = int(math.floor(u0 - r_px)) - 1, int(math.floor(v0 - r_px)) - 1
    crop = whole[cy0:int(math.ceil(v0 + r_px)) + 2, cx0:int(math.ceil(u0 + r_px)) + 2]
    front_det = Detection(u0, v0, r_px, 0.95, mask=crop.copy(), mask_origin=(cx0, cy0))
    loc = localisation.locate(cloud, front_det, P_RIGHT, image=image)
    assert np.linalg.norm(loc.centre - front) < 0.003, loc


def _whole_circle_part(det):
    """The detection with a part that fills its whole circle (the neighbour in front covers
    the rest of it): the part's outline runs along the whole circle."""
    vv, uu = np.mgrid[0:scene.HEIGHT, 0:scene.WIDTH]
    disc = np.hypot(uu - det.u, vv - det.v) <= det.radius_px
    x0, y0 = det.mask_origin
    h, w = det.mask.shape
    return Detection(det.u, det.v, det.radius_px, det.score, mask=disc[y0:y0 + h, x0:x0 + w],
                     mask_origin=det.mask_origin, mask_scale=1.0)


def _neighbour_detection(neighbour):
    """The detection of _fruit_behind_a_neighbour's neighbour (its true circle, no mask),
    from its centre in the left frame."""
    front_cam = neighbour - np.array([scene.BASELINE, 0.0, 0.0])
    fu, fv = scene.project(front_cam)
    return Detection(fu, fv, scene.FOCAL * 0.033 / front_cam[2], 0.9)


def test_a_fruit_behind_a_neighbour_that_fills_its_whole_circle_is_found_behind_it(monkeypatch):
    """The fruit's part can run along its whole circle (the neighbour in front covers the rest
    of it): no sector tells them apart, and the neighbour has most points (long_row f19_3
    behind f19_1 in one of the live cameras' noise frames: 27 mm off, the cup on f19_1's side).
    A sphere hides everything behind it inside its silhouette, and the neighbour's centre
    distances tilt across the circle (another sphere): the cluster behind it is the fruit."""
    cloud, image, det, truth, neighbour = _fruit_behind_a_neighbour(back_step=3)
    full = _whole_circle_part(det)
    assert localisation.outline_sectors(full).all()
    pts = localisation.points_on_fruit(cloud, full, P_RIGHT)
    assert np.sum(pts[:, 2] < 0.56) > len(pts) / 2, 'the neighbour must be most of the points'
    loc = localisation.locate(cloud, full, P_RIGHT, image=image)
    assert np.linalg.norm(loc.centre - truth) < 0.003, loc
    # without the rule the neighbour in front is taken
    _without_the_behind_rule(monkeypatch)
    old = localisation.locate(cloud, full, P_RIGHT, image=image)
    assert np.linalg.norm(old.centre - truth) > 0.02


def _without_the_behind_rule(monkeypatch):
    monkeypatch.setattr(localisation, 'fruit_cluster',
                        functools.partial(localisation.fruit_cluster, behind_share=None))


def test_the_points_of_a_fruit_in_front_are_not_the_ones_of_a_fruit_behind_it(monkeypatch):
    """Both fruit detected: where their circles overlap, the one located in front hides the
    other, so its points there are not the other's (locate_all). Here the fruit behind has
    only a thin crescent of points and no cluster of its own large enough for the rule of a
    fruit hidden behind, and the neighbour in front fills its whole circle."""
    cloud, image, det, truth, neighbour = _fruit_behind_a_neighbour(back_step=5)
    back = _whole_circle_part(det)
    front = _neighbour_detection(neighbour)
    alone = localisation.locate(cloud, back, P_RIGHT, image=image)
    assert np.linalg.norm(alone.centre - truth) > 0.02, 'the test needs a wrong first location'
    front_loc, back_loc = localisation.locate_all(cloud, [front, back], P_RIGHT, image=image)
    assert np.linalg.norm(front_loc.centre - neighbour) < 0.003, front_loc
    assert np.linalg.norm(back_loc.centre - truth) < 0.003, back_loc
    # the order of the detections does not matter
    back_loc2, front_loc2 = localisation.locate_all(cloud, [back, front], P_RIGHT, image=image)
    assert np.array_equal(back_loc2.centre, back_loc.centre)
    assert np.array_equal(front_loc2.centre, front_loc.centre)


def test_locate_all_locates_each_detection_at_most_twice(monkeypatch):
    """Its cost is bounded: one first location per detection and at most one more where
    circles overlap (here a pair located at one depth, the worst case of the rule)."""
    cloud, image, det, truth, neighbour = _fruit_behind_a_neighbour(back_step=1000)
    front = _neighbour_detection(neighbour)
    far = Detection(40.0, 40.0, 20.0, 0.9)          # no overlap, no point: located once
    calls = []
    real = localisation.locate

    def counted(*args, **kwargs):
        calls.append(args[1])
        return real(*args, **kwargs)
    monkeypatch.setattr(localisation, 'locate', counted)
    localisation.locate_all(cloud, [front, det, far], P_RIGHT, image=image)
    assert calls.count(far) == 1
    assert calls.count(front) <= 2 and calls.count(det) <= 2
    assert len(calls) <= 2 * 3


def test_a_fruit_whose_points_are_all_a_fruit_in_front_gets_no_3d_point():
    """Nothing of the fruit behind was ranged: every point of its circle lies inside the
    front fruit's, and it has no 3D point rather than the front fruit's depth."""
    cloud, image, det, truth, neighbour = _fruit_behind_a_neighbour(back_step=1000)
    front = _neighbour_detection(neighbour)
    assert localisation.locate(cloud, det, P_RIGHT, image=image) is not None
    front_loc, back_loc = localisation.locate_all(cloud, [front, det], P_RIGHT, image=image)
    assert np.linalg.norm(front_loc.centre - neighbour) < 0.003
    assert back_loc is None


def test_a_fruit_ranged_on_the_crescent_of_a_neighbour_in_front_gets_no_3d_point(
        monkeypatch):
    """The neighbour in front is detected with a circle a little smaller than its silhouette
    (block matching also spreads its disparity past its edge): outside that circle a crescent
    of its points is left in the circle of the fruit behind, which has no points of its own
    there, and the fruit behind was located on it, its sphere deep inside the neighbour's
    (renders: 76-170 mm too near). Two fruit cannot fill the same space, and the one ranged on
    few points per pixel of its circle has no 3D point."""
    cloud, image, det, truth, neighbour = _fruit_behind_a_neighbour(back_step=1000)
    whole = _neighbour_detection(neighbour)
    front = Detection(whole.u, whole.v, whole.radius_px - 4.0, 0.9)
    monkeypatch.setattr(localisation, 'unsupported_overlaps', lambda *args, **kwargs: set())
    front_loc, back_loc = localisation.locate_all(cloud, [front, det], P_RIGHT, image=image)
    assert back_loc is not None, 'the test needs a fruit located on the crescent'
    assert np.linalg.norm(back_loc.centre - truth) > 0.03
    assert np.linalg.norm(back_loc.centre - front_loc.centre) < \
        back_loc.radius + front_loc.radius, 'the two spheres must intersect'
    monkeypatch.undo()
    front_loc2, back_loc2 = localisation.locate_all(cloud, [front, det], P_RIGHT, image=image)
    assert back_loc2 is None
    assert np.array_equal(front_loc2.centre, front_loc.centre)
    # (its circle 4 px small: the cone is narrower and the sphere 3.5 mm nearer)
    assert np.linalg.norm(front_loc2.centre - neighbour) < 0.005


def _located(centre, radius, points):
    return localisation.FruitLocation(np.asarray(centre, dtype=np.float64), radius, points,
                                      np.asarray(centre, dtype=np.float64))


def test_of_two_intersecting_spheres_the_one_on_few_points_is_withdrawn():
    """unsupported_overlaps: only where the circles overlap and the spheres intersect by more
    than touching fruit's, only the one with less than half the other's points per pixel of
    its circle, and only against a location on enough points; a location it withdraws
    withdraws none itself."""
    dets = [Detection(300.0, 240.0, 50.0, 0.9), Detection(360.0, 240.0, 30.0, 0.9),
            Detection(400.0, 240.0, 30.0, 0.9), Detection(600.0, 240.0, 30.0, 0.9)]
    locs = [_located([0.0, 0.0, 0.55], 0.03, 4000),     # 0.51 points per pixel
            _located([0.03, 0.0, 0.56], 0.02, 300),     # 0.11: inside the first
            _located([0.055, 0.0, 0.57], 0.02, 250),    # 0.09: touches only the second
            _located([0.03, 0.0, 0.56], 0.02, 10)]      # its circle is far from the others
    assert localisation.unsupported_overlaps(dets, locs) == {1}
    # alike support: both stay (either could be the wrong one)
    locs[1], locs[2] = _located([0.03, 0.0, 0.56], 0.02, 1200), None
    assert localisation.unsupported_overlaps(dets, locs) == set()
    # spheres apart (the second behind the first): both stay
    locs[1] = _located([0.03, 0.0, 0.62], 0.02, 300)
    assert localisation.unsupported_overlaps(dets, locs) == set()
    # touching, as fruit of a truss do (centres 0.95 of the radii's sum apart): both stay
    locs[1] = _located([0.0475, 0.0, 0.55], 0.02, 300)
    assert localisation.unsupported_overlaps(dets, locs) == set()
    # the better supported one rests on a dim skin's few points (0.1 per pixel): both stay
    locs[0] = _located([0.0, 0.0, 0.55], 0.03, 785)
    locs[1] = _located([0.03, 0.0, 0.56], 0.02, 30)
    assert localisation.unsupported_overlaps(dets, locs) == set()
    # no location, nothing to withdraw
    assert localisation.unsupported_overlaps(dets, [None] * 4) == set()


def test_skin_mismatched_behind_a_fruit_does_not_take_its_place():
    """Block matching ranges patches of a smooth skin 3-4 cm behind it (renders: a fully
    visible fruit's 91 points behind its 685). They pass the colour and radius tests and lie
    behind the fruit, but the fruit's own points give one centre distance across the circle
    (no tilt): the chosen cluster is the skin, and the patch is not a fruit hidden behind it."""
    cloud, image, det, truth = _occluded_fruit(behind_depth=0.55, skin_step=2)
    pts = localisation.points_on_fruit(cloud, det, P_RIGHT)
    patch = np.abs(pts[:, 2] - 0.55) < 1e-3
    assert 0.15 * (~patch).sum() < patch.sum() < (~patch).sum()
    loc = localisation.locate(cloud, det, P_RIGHT, image=image)
    assert np.linalg.norm(loc.centre - truth) < 0.002, loc


def test_surface_tilt_is_zero_on_the_fruits_own_skin_and_large_on_another_sphere():
    sin_a = 0.06
    rng = np.random.RandomState(3)
    offsets = rng.uniform(-0.8, 0.8, size=(300, 2))
    offsets = offsets[np.hypot(offsets[:, 0], offsets[:, 1]) < 0.8]
    own = np.full(len(offsets), 0.6) + rng.normal(0.0, 0.0005, len(offsets))
    assert localisation.surface_tilt(own, offsets, sin_a) < 0.1
    # a sphere whose centre distance grows by half a radius across the circle's radius
    other = 0.55 + 0.5 * 0.55 * sin_a * offsets[:, 0]
    assert localisation.surface_tilt(other, offsets, sin_a) == pytest.approx(0.5, abs=0.01)
    assert localisation.surface_tilt(own[:3], offsets[:3], sin_a) == 0.0


def _tilted_patch_and_one_behind(n_front, n_behind, front_spread):
    """fruit_cluster's inputs: a cluster at 0.57 m whose centre distances climb 4 radii per
    circle radius across a patch of `front_spread` (std of its offsets, circle radii), and
    one at 0.72 m behind it; both pass the colour and radius tests."""
    sin_a = 0.0615
    rng = np.random.RandomState(5)
    front_off = rng.normal(0.0, front_spread, size=(n_front, 2))
    behind_off = rng.normal(0.0, 0.06, size=(n_behind, 2))
    front = 0.57 + 4.0 * 0.57 * sin_a * front_off[:, 0]
    behind = np.full(n_behind, 0.72) + rng.normal(0.0, 0.001, n_behind)
    dist = np.concatenate([front, behind])
    offsets = np.concatenate([front_off, behind_off])
    clusters = [np.arange(n_front), n_front + np.arange(n_behind)]
    return clusters, dist, sin_a, np.zeros(len(dist)), offsets


def test_a_small_steep_patch_of_the_fruits_skin_keeps_it_over_the_backdrop_behind():
    """low_light: on a dim skin block matching ranged the fruit's points as a small patch
    whose centre distances climb steeply (tilt 3-4), and the backdrop showed through the
    circle behind it with half as many points: the fruit was taken 150-210 mm behind. A tilt
    over a patch that spans little of the circle is an extrapolation: the patch stays the
    fruit, unless the cluster behind has more points."""
    clusters, dist, sin_a, colour, offsets = _tilted_patch_and_one_behind(200, 100, 0.08)
    assert localisation.surface_tilt(dist[clusters[0]], offsets[clusters[0]], sin_a) > 3.0
    chosen = localisation.fruit_cluster(clusters, dist, sin_a, colour, offsets=offsets)
    assert chosen is clusters[0]
    # a patch across the circle with that tilt is another sphere in front: the fruit is behind
    clusters, dist, sin_a, colour, offsets = _tilted_patch_and_one_behind(200, 100, 0.3)
    assert localisation.fruit_cluster(clusters, dist, sin_a, colour, offsets=offsets) is clusters[1]
    # a small patch with more points behind it: the one behind
    clusters, dist, sin_a, colour, offsets = _tilted_patch_and_one_behind(40, 250, 0.05)
    assert localisation.fruit_cluster(clusters, dist, sin_a, colour, offsets=offsets) is clusters[1]


def test_a_clean_fruit_is_one_depth_cluster_and_located_as_before(stereo_scene):
    """On a fruit with nothing in front, StereoBM's points are one cluster: the image changes
    nothing but the highlight ranging, and the pick point stays within 5 mm."""
    cloud, pairs = stereo_scene
    for fruit, det in pairs:
        pts = localisation.points_on_fruit(cloud, det, P_RIGHT)
        pr = pts - np.array([scene.BASELINE, 0.0, 0.0])
        axis, alpha = localisation.sphere_ray(det.u, det.v, det.radius_px, scene.FOCAL,
                                              scene.FOCAL, scene.CX, scene.CY)
        t = pr.dot(axis)
        lateral = np.linalg.norm(pr - t[:, None] * axis, axis=1)
        core = lateral < math.tan(localisation.EDGE_FRACTION * alpha) * t
        dist = localisation.centre_distances(t[core], lateral[core], math.sin(alpha))
        assert len(localisation.depth_clusters(dist, math.sin(alpha))) == 1
        flat = np.full((scene.HEIGHT, scene.WIDTH, 3), 120, np.uint8)     # no highlight
        with_image = localisation.locate(cloud, det, P_RIGHT, image=flat)
        assert np.array_equal(with_image.centre, localisation.locate(cloud, det, P_RIGHT).centre)
        assert np.linalg.norm(with_image.centre - _truth_left(fruit)) < 0.005


def test_centre_distances_of_points_on_a_sphere_are_its_centre_distance():
    dist, sin_a = 0.6, 0.06
    radius = dist * sin_a
    rng = np.random.RandomState(5)
    # points on the visible cap, up to 0.8 R off the centre ray (along z)
    rho = 0.8 * radius * np.sqrt(rng.random_sample(50))
    t = dist - np.sqrt(radius * radius - rho * rho)
    assert np.allclose(localisation.centre_distances(t, rho, sin_a), dist, atol=1e-12)
    # a highlight point seen head-on is the light's virtual image R/2 behind the front
    glint = localisation.centre_distances(np.array([dist - radius / 2.0]), np.zeros(1), sin_a,
                                          np.array([True]))
    assert glint[0] == pytest.approx(dist)
    # off-centre, `factor` R in front of the centre (virtual_image_factor)
    glint = localisation.centre_distances(np.array([dist - 0.2 * radius]), np.zeros(1), sin_a,
                                          np.array([True]), np.array([0.2]))
    assert glint[0] == pytest.approx(dist)


def test_the_virtual_image_of_a_highlight_follows_the_mirror_astigmatism():
    """k (the centre lies k R beyond the ranged virtual image): 1/2 head-on; at 45 degrees in a
    vertical plane of incidence (a light above, the highlight at the top) the horizontal
    baseline sees the sagittal focus f / cos 45 behind a mirror point R cos 45 in front of the
    centre, so k = 0; in a horizontal plane the tangential focus f cos 45, k = cos 45 / 2.
    Symmetric, scale-free, and capped at SPECULAR_MAX_SIN off the centre."""
    f = localisation.virtual_image_factor
    s45 = math.sqrt(0.5)
    assert f(0.0, 0.0, 40.0) == pytest.approx(0.5)
    assert f(0.0, -s45 * 40.0, 40.0, max_sin=0.9) == pytest.approx(0.0, abs=1e-12)
    assert f(s45 * 40.0, 0.0, 40.0, max_sin=0.9) == pytest.approx(s45 / 2.0)
    assert f(-s45 * 40.0, 0.0, 40.0, max_sin=0.9) == pytest.approx(s45 / 2.0)
    assert f(3.0, 4.0, 20.0) == pytest.approx(f(6.0, 8.0, 40.0))
    cap = localisation.SPECULAR_MAX_SIN
    assert f(0.0, 39.0, 40.0) == pytest.approx(f(0.0, cap * 40.0, 40.0))
    # an oblique plane lies between the two
    assert f(0.0, -s45 * 40.0, 40.0, 0.9) < f(20.0, -20.0, 40.0, 0.9) < f(s45 * 40.0, 0.0, 40.0, 0.9)


def test_a_highlight_is_ranged_part_of_the_way_to_the_virtual_image():
    """highlight_factor: share 1 is the mirror's virtual image, share 0 the skin (the mirror
    point, R cos theta in front of the centre); the default 3/4 lies between, 5/8 head-on."""
    h, f = localisation.highlight_factor, localisation.virtual_image_factor
    for du, dv in ((0.0, 0.0), (12.0, -9.0), (0.0, -28.0), (30.0, 1.0)):
        cos_t = math.sqrt(1.0 - min(math.hypot(du, dv) / 40.0, localisation.SPECULAR_MAX_SIN) ** 2)
        assert h(du, dv, 40.0, share=1.0) == pytest.approx(f(du, dv, 40.0))
        assert h(du, dv, 40.0, share=0.0) == pytest.approx(cos_t)
        assert f(du, dv, 40.0) < h(du, dv, 40.0) < cos_t
    assert localisation.VIRTUAL_IMAGE_SHARE == 0.75
    assert h(0.0, 0.0, 40.0) == pytest.approx(0.625)


def test_fruit_radius_range_is_image_processings():
    import os
    import yaml
    here = os.path.dirname(os.path.abspath(__file__))
    with open(os.path.join(here, '..', 'config', 'image_processing.yaml')) as f:
        config = yaml.safe_load(f)
    assert localisation.FRUIT_RADIUS_RANGE == (config['min_fruit_radius'],
                                               config['max_fruit_radius'])


def _fruit_whose_part_is_a_fruit_in_front(own_depth_step=2, backdrop=None):
    """A red fruit F (35 mm at 0.55 m) with a turning fruit O in front of it (30 mm at 0.47 m)
    over its upper left, as long_row f19_1 behind f19_0: F's part (the detector's mask) holds
    only O's skin inside F's circle, F's own skin is in no part of F (the detector gave it to
    a neighbour's). O matches on every pixel, F's skin on every `own_depth_step`-th one; with
    `backdrop` (m), what the rest of F's circle shows is the backdrop at that depth instead of
    F (a circle with no fruit behind O). Returns (cloud, image, detection, F's true centre in
    the left frame)."""
    f_c, f_r = np.array([0.03, -0.02, 0.55]), 0.035
    (u0, v0, r_px), (x0, y0), (uu, vv, rays), (s_f, s_o) = _two_spheres(
        f_c, f_r, np.array([0.005, -0.045, 0.47]), 0.03, 2.0, 1.5)
    in_circle = np.hypot(uu - u0, vv - v0) <= r_px
    front = np.isfinite(s_o)
    own = in_circle & ~front & (np.isfinite(s_f) if backdrop is None else True)
    image = np.full((scene.HEIGHT, scene.WIDTH, 3), 90, np.uint8)
    image[vv[front].astype(int), uu[front].astype(int)] = (40, 160, 230)     # orange
    image[vv[own].astype(int), uu[own].astype(int)] = SKIN_BGR if backdrop is None else 90
    depth = np.full(uu.shape, np.nan)
    depth[front] = s_o[front]
    sel = own & (uu % own_depth_step == 0) & (vv % own_depth_step == 0)
    depth[sel] = s_f[sel] if backdrop is None else backdrop
    ok = np.isfinite(depth)
    cloud = _cloud_of(uu[ok], vv[ok], rays[ok] * depth[ok][:, None])
    det = _with_part(u0, v0, r_px, 0.9, in_circle & front, x0, y0)
    return cloud, image, det, f_c + np.array([scene.BASELINE, 0.0, 0.0])


def test_a_fruit_whose_part_holds_only_a_fruit_in_front_is_found_by_its_own_skin():
    """Its part gives the fruit in front's depth (long_row f19_1: 82 mm too near). Its own
    skin, off its part in its circle, lies behind that sphere, where nothing can be seen
    through an opaque fruit (seen_through): the fruit is at its skin's depth."""
    cloud, image, det, truth = _fruit_whose_part_is_a_fruit_in_front()
    alone = localisation.locate(cloud, det, P_RIGHT, image=image)
    assert np.linalg.norm(alone.centre - truth) > 0.04, 'the test needs a wrong first location'
    loc, = localisation.locate_all(cloud, [det], P_RIGHT, image=image)
    assert np.linalg.norm(loc.centre - truth) < 0.003, loc
    assert loc.radius == pytest.approx(0.035, abs=0.002)


def test_a_circle_that_shows_the_backdrop_behind_a_fruit_in_front_has_no_3d_point():
    """The rest of the circle shows the backdrop (0.95 m): no fruit's sphere there, and the
    fruit in front is not this detection's either."""
    cloud, image, det, truth = _fruit_whose_part_is_a_fruit_in_front(backdrop=0.95)
    assert localisation.locate(cloud, det, P_RIGHT, image=image) is not None
    assert localisation.locate_all(cloud, [det], P_RIGHT, image=image) == [None]


def test_a_location_with_nothing_seen_through_it_is_kept_as_it_is(stereo_scene):
    """Fruit whose circles show only their own skin (and points off their parts, if any, in
    front of them or on them) keep the location `locate` gives, unchanged."""
    cloud, pairs = stereo_scene
    for fruit, det in pairs:
        loc = localisation.locate(cloud, det, P_RIGHT)
        assert localisation.seen_through(cloud, det, P_RIGHT, loc) is loc
    cloud, image, det, truth = _occluded_fruit(behind_depth=0.55, skin_step=2)
    loc = localisation.locate(cloud, det, P_RIGHT, image=image)
    assert localisation.seen_through(cloud, det, P_RIGHT, loc, image) is loc


def test_a_fruit_whose_part_is_mostly_a_fruit_in_front_is_graded_by_its_own_skin():
    """The detector graded the part, mostly the orange fruit in front (long_row f19_1: 0.64
    for a fruit of 0.91); depth tells the fruit's own skin, and that is red."""
    cloud, image, det, truth = _fruit_whose_part_is_a_fruit_in_front()
    detector = TomatoDetector()
    part = localisation.part_pixels(image, det)
    det = det.with_score(detector.score_of(part)[0])
    assert det.score < 0.7, 'the test needs a part graded unripe'
    (loc,) = localisation.locate_all(cloud, [det], P_RIGHT, image=image)
    # located by its own skin off its part: (almost) none of the part's points are the fruit
    assert loc.part_share < 0.05
    skin = localisation.own_skin(cloud, det, P_RIGHT, loc, image)
    assert skin is not None and len(skin[0]) >= 2 * localisation.MIN_POINTS
    # every pixel of the sample is the fruit's own red skin, none the orange fruit's
    assert np.all(image[np.rint(skin[1]).astype(int), np.rint(skin[0]).astype(int)] ==
                  SKIN_BGR)
    (graded, same), = localisation.regrade(detector, cloud, [(det, loc)], P_RIGHT, image)
    assert same is loc
    assert graded.score >= 0.7 and graded.stage == 3, graded
    assert graded.score == pytest.approx(detector.grade_at(image, *skin))
    assert (graded.u, graded.v, graded.radius_px) == (det.u, det.v, det.radius_px)
    assert det.score < 0.7                        # a copy: the detection itself is unchanged


def test_a_fruit_whose_part_is_its_own_skin_keeps_the_detectors_grade(stereo_scene):
    cloud, pairs = stereo_scene
    right, _, _ = scene.render(STEREO_FRUITS, (), 'right', backdrop_depth=0.95)
    detector = TomatoDetector()
    found = [(det, localisation.locate(cloud, det, P_RIGHT, image=right)) for _, det in pairs]
    for (det, loc), (out, out_loc) in zip(found, localisation.regrade(
            detector, cloud, found, P_RIGHT, right)):
        assert loc is not None and loc.part_share == 1.0    # regrade does not even look
        assert localisation.own_skin(cloud, det, P_RIGHT, loc, right) is None
        assert out is det and out_loc is loc
    # no location or no image: nothing to grade by
    assert localisation.regrade(detector, cloud, [(pairs[0][1], None)], P_RIGHT, right) == \
        [(pairs[0][1], None)]
    assert localisation.regrade(detector, cloud, found, P_RIGHT, None) == found
