"""Tiny ray-cast stereo scene for the vision tests: shaded tomatoes, leaves, textured backdrop.

Independent of harvest_sim so the unit tests do not depend on another package's renderer.
Coordinates: the RIGHT optical frame (x right, y down, z forward); the left eye sits at
x = -baseline (a rectified pair, as stereo_image_proc produces).
"""
import numpy as np

WIDTH, HEIGHT = 1024, 768
FOCAL = (WIDTH / 2.0) / np.tan(np.radians(66.0) / 2.0)
CX, CY = (WIDTH - 1) / 2.0, (HEIGHT - 1) / 2.0
BASELINE = 0.12

# ripeness colour ramp (0 green .. 1 red) of real fruit skin under neutral light: OpenCV hue
# (0..180) by ripeness, as the detector's documented calibration reads it (vision_pkg README),
# saturation and value of real skin; green fruit are light yellowish green, red ones deep red
_RAMP_RIPENESS = [0.0, 0.06, 0.18, 0.3, 0.42, 0.55, 0.7, 0.88, 1.0]
_RAMP_HUE = [41.0, 35.0, 30.0, 26.0, 22.0, 18.0, 14.0, 9.0, 3.0]
_RAMP_SAT = [150.0, 150.0, 160.0, 170.0, 180.0, 190.0, 200.0, 205.0, 210.0]
_RAMP_VAL = [200.0, 200.0, 205.0, 210.0, 215.0, 215.0, 210.0, 200.0, 190.0]
#: BGR of leaves: the same yellow-green as green fruit (only shape and surface tell them apart)
LEAF_BGR = (60.0, 150.0, 125.0)


def ripeness_colour(r):
    """BGR base colour of a tomato of ripeness r in [0, 1]."""
    import cv2
    r = min(max(float(r), 0.0), 1.0)
    hsv = np.uint8([[[round(np.interp(r, _RAMP_RIPENESS, _RAMP_HUE)),
                      round(np.interp(r, _RAMP_RIPENESS, _RAMP_SAT)),
                      round(np.interp(r, _RAMP_RIPENESS, _RAMP_VAL))]]])
    return cv2.cvtColor(hsv, cv2.COLOR_HSV2BGR).reshape(3).astype(float)


class Fruit(object):
    def __init__(self, x, y, z, radius, ripeness):
        self.centre = np.array([x, y, z], dtype=float)
        self.radius = float(radius)
        self.ripeness = float(ripeness)


class Leaf(object):
    """A flat elliptical leaf facing the camera at depth z; `fruit_green` leaves have the
    colour of green fruit, a serrated edge and veins."""

    def __init__(self, x, y, z, ax, ay, angle=0.0, fruit_green=False):
        self.centre = np.array([x, y, z], dtype=float)
        self.ax, self.ay, self.angle = ax, ay, angle
        self.fruit_green = fruit_green


def project(point, eye='right'):
    x = point[0] + (BASELINE if eye == 'left' else 0.0)
    return np.array([FOCAL * x / point[2] + CX, FOCAL * point[1] / point[2] + CY])


def gt_box(fruit, eye='right'):
    """Pixel box (x0, y0, x1, y1) of the projected sphere (sampled silhouette)."""
    c = fruit.centre.copy()
    if eye == 'left':
        c[0] += BASELINE
    a = np.linspace(0, 2 * np.pi, 64, endpoint=False)
    # silhouette: points on the sphere perpendicular to the viewing ray
    d = c / np.linalg.norm(c)
    e1 = np.cross(d, [0, 1, 0])
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(d, e1)
    dist = np.linalg.norm(c)
    r = fruit.radius
    off = dist - r * r / dist
    rad = r * np.sqrt(1 - (r / dist) ** 2)
    pts = d * off + rad * (np.outer(np.cos(a), e1) + np.outer(np.sin(a), e2))
    u = FOCAL * pts[:, 0] / pts[:, 2] + CX
    v = FOCAL * pts[:, 1] / pts[:, 2] + CY
    return u.min(), v.min(), u.max(), v.max()


def _skin_texture():
    import cv2
    noise = np.random.RandomState(77).standard_normal((96, 192)).astype(np.float32)
    noise = cv2.GaussianBlur(noise, (0, 0), 0.8)
    return noise / noise.std()


_SKIN = _skin_texture()


def _texture(shape, rng, scale):
    noise = rng.standard_normal((shape[0] // scale + 2, shape[1] // scale + 2)).astype(np.float32)
    import cv2
    big = cv2.resize(noise, (shape[1], shape[0]), interpolation=cv2.INTER_CUBIC)
    return big


def render(fruits, leaves=(), eye='right', seed=0, width=WIDTH, height=HEIGHT, focal=None,
           backdrop_depth=1.2, light=1.0, film_above=None, gains=(1.0, 1.0, 1.0)):
    """Render one eye. Returns (bgr uint8 image, depth float32 [m], fruit id map int16).

    film_above: backdrop rows above this world y [m] show white plastic film instead of
    canopy; gains: BGR channel gains of the illuminant/camera white balance."""
    import cv2
    f = FOCAL * width / WIDTH if focal is None else focal
    cx, cy = (width - 1) / 2.0, (height - 1) / 2.0
    shift = BASELINE if eye == 'left' else 0.0
    rng = np.random.RandomState(seed)
    vv, uu = np.mgrid[0:height, 0:width].astype(np.float32)
    dx = (uu - cx) / f
    dy = (vv - cy) / f
    # backdrop: textured leaves far away, texture fixed in the world (so stereo can match)
    depth = np.full((height, width), backdrop_depth, np.float32)
    wx = dx * backdrop_depth + shift
    wy = dy * backdrop_depth
    tex_rng = np.random.RandomState(1234 + seed)
    grid = tex_rng.standard_normal((160, 200)).astype(np.float32)
    gx = np.clip((wx + 1.0) / 2.0 * 199, 0, 199).astype(np.float32)
    gy = np.clip((wy + 0.8) / 1.6 * 159, 0, 159).astype(np.float32)
    t = cv2.remap(grid, gx, gy, cv2.INTER_LINEAR)
    img = np.zeros((height, width, 3), np.float32)
    img[..., 0] = 40 + 12 * t
    img[..., 1] = 95 + 30 * t
    img[..., 2] = 45 + 12 * t
    if film_above is not None:
        film = wy < film_above
        img[film] = (170.0 + 6.0 * t[film])[:, None]      # translucent film, in shade
    ids = np.full((height, width), -1, np.int16)
    light_dir = np.array([0.3, 0.45, 0.85])
    light_dir /= np.linalg.norm(light_dir)
    for i, fr in enumerate(fruits):
        c = fr.centre + np.array([shift, 0.0, 0.0])
        x0, y0, x1, y1 = gt_box(Fruit(c[0], c[1], c[2], fr.radius, 0))
        x0, y0 = max(int(x0) - 2, 0), max(int(y0) - 2, 0)
        x1, y1 = min(int(x1) + 3, width), min(int(y1) + 3, height)
        if x0 >= x1 or y0 >= y1:
            continue
        sx, sy = dx[y0:y1, x0:x1], dy[y0:y1, x0:x1]
        dd = sx * sx + sy * sy + 1.0
        b = sx * c[0] + sy * c[1] + c[2]
        disc = b * b - dd * (c.dot(c) - fr.radius ** 2)
        hit = disc > 0
        tt = (b - np.sqrt(np.maximum(disc, 0))) / dd
        z = tt
        sub_depth = depth[y0:y1, x0:x1]
        hit &= z < sub_depth
        if not hit.any():
            continue
        px, py, pz = sx * tt - c[0], sy * tt - c[1], tt - c[2]
        n = np.stack([px, py, pz], -1) / fr.radius
        lam = np.clip(-(n @ light_dir), 0, 1)
        view = -np.stack([sx, sy, np.ones_like(sx)], -1) / np.sqrt(dd)[..., None]
        half = view - light_dir
        half /= np.linalg.norm(half, axis=-1, keepdims=True)
        spec = np.clip((n * half).sum(-1), 0, 1) ** 40
        base = ripeness_colour(fr.ripeness)
        # skin texture fixed on the fruit (the same in both eyes, so stereo can match it)
        theta = np.arccos(np.clip(-n[..., 1], -1.0, 1.0))
        phi = np.arctan2(n[..., 2], n[..., 0]) + np.pi
        skin = 1.0 + 0.12 * _SKIN[(theta * (_SKIN.shape[0] - 1) / np.pi).astype(int),
                                  (phi * (_SKIN.shape[1] - 1) / (2 * np.pi)).astype(int)]
        col = base[None, None, :] * (0.35 + 0.65 * lam)[..., None] * skin[..., None] * light
        col += 200.0 * spec[..., None]
        sub = img[y0:y1, x0:x1]
        sub[hit] = col[hit]
        sub_depth[hit] = z[hit]
        ids[y0:y1, x0:x1][hit] = i
    for leaf in leaves:
        c = leaf.centre + np.array([shift, 0.0, 0.0])
        lx = dx * c[2] - c[0]
        ly = dy * c[2] - c[1]
        ca, sa = np.cos(leaf.angle), np.sin(leaf.angle)
        ex = (ca * lx + sa * ly) / leaf.ax
        ey = (-sa * lx + ca * ly) / leaf.ay
        rho = np.sqrt(ex * ex + ey * ey)
        if leaf.fruit_green:
            ang = np.arctan2(ey, ex)
            rho = rho * (1.0 + 0.08 * np.abs(np.sin(9.0 * ang)))      # serrated edge
        hit = (rho <= 1.0) & (c[2] < depth)
        shade = 0.8 + 0.2 * ex
        if leaf.fruit_green:
            # midrib and side veins, darker, as on a real leaflet
            vein = (np.abs(ey) < 0.05) | (np.abs(np.sin(6.0 * (ex - 0.6 * np.abs(ey)))) < 0.12)
            shade = shade * np.where(vein, 0.55, 1.0)
            for ch in range(3):
                img[hit, ch] = LEAF_BGR[ch] * shade[hit]
        else:
            img[hit, 0] = 30 * shade[hit]
            img[hit, 1] = 120 * shade[hit]
            img[hit, 2] = 40 * shade[hit]
        depth[hit] = c[2]
        ids[hit] = -1
    img *= np.asarray(gains, dtype=np.float32)[None, None, :]
    img += rng.standard_normal(img.shape).astype(np.float32) * 2.0
    return np.clip(img, 0, 255).astype(np.uint8), depth, ids


def camera_k(width=WIDTH, height=HEIGHT):
    f = FOCAL * width / WIDTH
    return np.array([[f, 0, (width - 1) / 2.0], [0, f, (height - 1) / 2.0], [0, 0, 1.0]])
