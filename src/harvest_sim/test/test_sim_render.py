"""Renderer geometry and behaviour (no ROS master): a fruit at a known 3-D point must appear
where an ideal pinhole camera puts it, in both stereo eyes and in the hand camera."""

import cv2
import numpy as np
import pytest

from sim_fixtures import GEOM, scn, single_fruit_scenario

from harvest_sim import camera_model, render


def silhouette_centre(camera, c_cam, r):
    """Centre of the ellipse a sphere projects to (the cone tangent to the sphere cut by the
    image plane), computed independently of the renderer."""
    c = np.asarray(c_cam, dtype=float)
    M = np.outer(c, c) - (c.dot(c) - r * r) * np.eye(3)
    Kinv = np.linalg.inv(camera.K)
    Q = Kinv.T.dot(M).dot(Kinv)
    return -np.linalg.solve(Q[:2, :2], Q[:2, 2])


def red_blob_centroid(img):
    """Centroid of the convex hull of the largest red blob (fills highlights and the notches
    of the green calyx, as a fruit detector would)."""
    hsv = cv2.cvtColor(img, cv2.COLOR_BGR2HSV)
    mask = (((hsv[:, :, 0] < 12) | (hsv[:, :, 0] > 170)) & (hsv[:, :, 1] > 120) &
            (hsv[:, :, 2] > 40)).astype(np.uint8)
    contours, _ = cv2.findContours(mask, cv2.RETR_EXTERNAL, cv2.CHAIN_APPROX_NONE)
    assert contours, 'no red blob in the image'
    filled = np.zeros_like(mask)
    hull = cv2.convexHull(max(contours, key=cv2.contourArea))
    cv2.drawContours(filled, [hull], -1, 1, -1)
    m = cv2.moments(filled, binaryImage=True)
    return np.array([m['m10'] / m['m00'], m['m01'] / m['m00']]), m['m00']


def label_centroid(labels, label):
    ys, xs = np.nonzero(labels == label)
    return np.array([xs.mean(), ys.mean()]), xs.size


def eye_poses(cart=0.0, **joints):
    j = {'cart_joint': cart}
    j.update(joints)
    return render.camera_poses(GEOM, j)


CASES = [  # fruit centre in map frame for the stereo head at cart 0, waist 0
    (0.45, 0.12, 1.00),   # straight ahead of the left eye, 0.5 m
    (0.40, 0.00, 0.92),   # straight ahead of the right eye, below
    (0.55, 0.20, 1.05),   # off-axis in both eyes
    (0.60, -0.10, 0.88),
]


@pytest.mark.parametrize('pos', CASES)
@pytest.mark.parametrize('eye', ['stereo_left_optical', 'stereo_right_optical'])
def test_fruit_renders_at_its_pinhole_projection_in_stereo(pos, eye):
    s = single_fruit_scenario(pos)
    r = render.Renderer(s)
    cam = camera_model.stereo_camera()
    T = eye_poses()[eye]
    img, labels = r.render(cam, T, render.fruits_from_scenario(s), ('x', 0), labels=True)
    c_cam = camera_model.to_camera(T, pos)[0]
    expect = silhouette_centre(cam, c_cam, 0.035)
    centre_proj = cam.project(c_cam)[0]
    got_label, n = label_centroid(labels, 1)
    assert n > 1000
    assert np.linalg.norm(got_label - expect) < 0.5
    got_colour, _ = red_blob_centroid(img)
    assert np.linalg.norm(got_colour - expect) < 1.0, (got_colour, expect)
    # the silhouette centre and the projected sphere centre differ by the perspective offset
    # only; where that is small the blob is also within 1 px of the projected centre
    if np.linalg.norm(expect - centre_proj) < 0.3:
        assert np.linalg.norm(got_colour - centre_proj) < 1.0


def test_stereo_disparity_matches_depth():
    pos = (0.45, 0.06, 1.0)
    s = single_fruit_scenario(pos)
    r = render.Renderer(s)
    cam = camera_model.stereo_camera()
    poses = eye_poses()
    fr = render.fruits_from_scenario(s)
    uv, sil = {}, {}
    for eye in ('stereo_left_optical', 'stereo_right_optical'):
        _, labels = r.render(cam, poses[eye], fr, labels=True)
        uv[eye], _ = label_centroid(labels, 1)
        sil[eye] = silhouette_centre(cam, camera_model.to_camera(poses[eye], pos)[0], 0.035)
    z = camera_model.to_camera(poses['stereo_left_optical'], pos)[0][2]
    L, R = 'stereo_left_optical', 'stereo_right_optical'
    disparity = uv[L][0] - uv[R][0]
    assert disparity == pytest.approx(sil[L][0] - sil[R][0], abs=0.5)
    # the sphere centre's disparity is fx B / Z; silhouette centres add a perspective offset
    assert disparity == pytest.approx(cam.fx * GEOM.stereo_baseline / z, abs=2.0)
    assert abs(uv[L][1] - uv[R][1]) < 0.2


@pytest.mark.parametrize('offset', [(0.0, 0.0, 0.0), (0.0, 0.03, -0.02), (0.0, -0.04, 0.03)])
def test_fruit_renders_at_its_pinhole_projection_in_hand_camera(offset):
    # left arm reaching forward: the fruit sits 16-20 cm in front of the hand camera
    ik = GEOM.inverse('left', (0.55, 0.05, 1.0))
    assert ik.reachable
    joints = dict(zip(('left_lift_joint', 'left_boom_joint', 'left_forearm_joint'), ik.joints))
    T = eye_poses(**joints)['hand_camera_optical']
    pos = T[:3, 3] + T[:3, :3].dot(np.array([0.0, 0.0, 0.18]) + np.array(offset))
    s = single_fruit_scenario(pos, radius=0.03)
    r = render.Renderer(s)
    cam = camera_model.hand_camera()
    img, labels = r.render(cam, T, render.fruits_from_scenario(s), ('hand', 0), labels=True)
    expect = silhouette_centre(cam, camera_model.to_camera(T, pos)[0], 0.03)
    got_label, n = label_centroid(labels, 1)
    assert n > 5000
    assert np.linalg.norm(got_label - expect) < 0.5
    got_colour, _ = red_blob_centroid(img)
    assert np.linalg.norm(got_colour - expect) < 1.0, (got_colour, expect)


def test_render_is_deterministic_and_noise_follows_the_frame_index():
    s = scn.load_scenario(scn.resolve_scenario('three_targets', _scenarios()))
    cam = camera_model.stereo_camera()
    T = eye_poses(cart=s.track.picking_points[0])['stereo_left_optical']
    fr = render.fruits_from_scenario(s)
    a = render.Renderer(s).render(cam, T, fr, ('left', 3))
    b = render.Renderer(s).render(cam, T, fr, ('left', 3))
    c = render.Renderer(s).render(cam, T, fr, ('left', 4))
    assert np.array_equal(a, b)
    assert not np.array_equal(a, c)
    noise = a.astype(float) - c.astype(float)
    assert 1.0 < noise.std() < 5.0


def test_leaf_in_front_occludes_the_fruit():
    pos = np.array([0.45, 0.12, 1.0])
    leaf = scn.Leaf('l0', pos + [-0.06, 0.02, 0.0], [-1.0, 0.0, 0.0], [0.0, 0.0, 1.0], 0.12,
                    0.06)
    cam = camera_model.stereo_camera()
    T = eye_poses()['stereo_left_optical']
    counts = []
    for leaves in ((), (leaf,)):
        s = single_fruit_scenario(pos, leaves=leaves)
        _, labels = render.Renderer(s).render(cam, T, render.fruits_from_scenario(s),
                                              labels=True)
        counts.append(np.count_nonzero(labels == 1))
    assert 0 < counts[1] < 0.8 * counts[0]


def test_lighting_intensity_changes_brightness():
    pos = (0.45, 0.12, 1.0)
    cam = camera_model.stereo_camera()
    T = eye_poses()['stereo_left_optical']
    means = []
    for intensity in (1.0, 0.3):
        s = single_fruit_scenario(pos, intensity=intensity)
        img, labels = render.Renderer(s).render(cam, T, render.fruits_from_scenario(s),
                                                labels=True)
        means.append(img[labels == 1].mean())
    assert means[1] < 0.6 * means[0]


def test_ripeness_colours_are_ordered_green_to_red():
    hues = []
    for ripeness in (0.0, 0.3, 0.6, 0.8, 1.0):
        rgb = np.array([[render.fruit_albedo(ripeness)]], dtype=np.float32)
        hsv = cv2.cvtColor(rgb, cv2.COLOR_RGB2HSV)
        hues.append(float(hsv[0, 0, 0]))
    assert hues == sorted(hues, reverse=True)
    assert hues[0] > 80 and hues[-1] < 10        # degrees: green ... red


def test_camera_info_geometry():
    cam = camera_model.stereo_camera()
    assert (cam.width, cam.height) == (1024, 768)
    assert cam.hfov_deg() == pytest.approx(66.0)
    P = cam.P(-cam.fx * 0.12)
    assert P[0, 3] == pytest.approx(-cam.fx * 0.12)
    hand = camera_model.hand_camera()
    assert (hand.width, hand.height) == (640, 480) and hand.hfov_deg() == pytest.approx(60.0)


def _scenarios():
    from sim_fixtures import SCENARIOS
    return SCENARIOS


def test_cached_layer_gives_the_same_image_as_a_fresh_render():
    s = scn.load_scenario(scn.resolve_scenario('dense_cluster', _scenarios()))
    cam = camera_model.stereo_camera()
    T = eye_poses(cart=s.track.picking_points[0])['stereo_left_optical']
    fr = render.fruits_from_scenario(s)
    moved = list(fr)
    f = moved[2]
    moved[2] = f._replace(position=f.position + [-0.05, 0.0, 0.02], moving=True)
    r = render.Renderer(s)
    r.render(cam, T, fr, ('left', 1))                   # fills the cache with the still scene
    a = r.render(cam, T, moved, ('left', 1))            # layer reused, one fruit moving
    b = render.Renderer(s).render(cam, T, [m._replace(moving=False) for m in moved],
                                  ('left', 1))
    assert np.array_equal(a, b)
    assert not np.array_equal(a, r.render(cam, T, fr, ('left', 1)))
