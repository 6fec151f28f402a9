"""What harvest_sim's renderer paints with (numpy + OpenCV, no rospy): scene constants, fruit
colours by ripeness (measured on real photographs, see render.py), skin gloss and texture,
leaflet and sepal shapes, procedural textures."""

import math

import cv2
import numpy as np

ROOF_Z = 3.2
NEAR = 0.01
#: (ripeness, RGB albedo): skin colours measured on real photographs (README, "Measured fruit
#: colours"): hue and saturation of the per-stage medians, red chromaticity R/(R+G+B) from
#: 0.36 (green) to 0.55 (0.7, hue 14: the pink/red boundary) and 0.71 (1.0)
RIPENESS_COLOURS = ((0.0, (0.475, 0.60, 0.227)), (0.2, (0.69, 0.69, 0.361)),
                    (0.35, (0.74, 0.64, 0.31)), (0.55, (0.839, 0.627, 0.31)),
                    (0.7, (0.80, 0.471, 0.18)), (0.85, (0.74, 0.30, 0.12)),
                    (1.0, (0.66, 0.18, 0.09)))
RIPENESS_STOPS = np.array([r for r, _ in RIPENESS_COLOURS], np.float32)
RIPENESS_BGR = np.array([c[::-1] for _, c in RIPENESS_COLOURS], np.float32)
PALE_SHOULDER_RGB = (0.80, 0.84, 0.58)   # the pale top of mature green fruit
CALYX_RGB = (0.20, 0.36, 0.11)
CALYX_COS = math.cos(0.45)       # the painted calyx base lies within 0.45 rad of the top
SEPAL_RGB = (0.20, 0.35, 0.11)
SEPAL_RADIUS = (0.0015, 0.0008)  # m: base and tip segment of a sepal
#: gloss of the skin: (strength, Blinn-Phong exponent) of the sharp highlight and the sheen,
#: strength and exponent of the soft highlight of the sky/film above, Fresnel rim strength
SPECULAR = (1.2, 400.0)
SHEEN = (0.10, 14.0)
SKY_GLOSS = (0.45, 30.0)
FRESNEL = 0.35
SKIN_TEXEL = 0.0012              # m: scale of the fine skin texture (stereo matching needs it)
SKIN_TEXTURE = 0.11              # its contrast
#: lobes of large fruit: from radius [0] (none) to [1] (full), tilt [2], lobes round [3]
RIBS = (0.034, 0.045, 0.22, 6.0)
WRAP = 0.25                      # wrapped Lambert of the fruit (the light is a large source)
BOUNCE = 0.3                     # light bounced up from the floor onto the fruit bottoms
STEM_RGB = (0.42, 0.55, 0.28)
PEDICEL_RADIUS = 0.0025
PEDICEL_KNEE = 0.02              # m above the fruit top: the pedicel's knuckle
TEX_RES = 0.002                  # m per texel of the canopy textures
CANOPY_TILE = (1.6, 3.4)         # m: width along the row, height (z from -0.2)
LABEL_LEAF, LABEL_STEM = 1000, 2000
STATIC_CACHE = 4                 # camera poses whose fruit-free layer is kept


def fruit_albedo(ripeness):
    """RGB albedo (0..1) of a fruit of a given (uniform) ripeness."""
    r = min(max(float(ripeness), 0.0), 1.0)
    for (r0, c0), (r1, c1) in zip(RIPENESS_COLOURS[:-1], RIPENESS_COLOURS[1:]):
        if r <= r1:
            a = (r - r0) / (r1 - r0)
            return tuple((1 - a) * x0 + a * x1 for x0, x1 in zip(c0, c1))
    return RIPENESS_COLOURS[-1][1]


def albedo_bgr(ripeness):
    """N x 3 BGR albedo (float32) of an array of local ripeness values."""
    r = np.clip(ripeness, 0.0, 1.0)
    return np.stack([np.interp(r, RIPENESS_STOPS, RIPENESS_BGR[:, k]) for k in range(3)],
                    axis=1).astype(np.float32)


def mottle_weight(ripeness):
    """0..1: how unevenly a fruit of this ripeness is coloured (peaks while turning/pink)."""
    r = float(ripeness)
    return float(np.interp(r, (0.12, 0.3, 0.55, 0.8, 0.95), (0.0, 1.0, 1.0, 0.35, 0.0)))


def rgb_to_bgr(rgb):
    return np.array([rgb[2], rgb[1], rgb[0]], dtype=np.float32)


def noise_texture(rng, shape, blur_sigma):
    n = rng.standard_normal(shape).astype(np.float32)
    if blur_sigma > 0:             # blur with wrap-around so the texture tiles seamlessly
        m = int(math.ceil(4 * blur_sigma))
        n = cv2.GaussianBlur(np.pad(n, m, mode='wrap'), (0, 0), blur_sigma)[m:-m, m:-m]
    return n / max(float(n.std()), 1e-6)


def skin_texture(rng, shape):
    """Tomato skin: smooth, with faint blotches and fine light dots (lenticels), which give
    block matching something to hold on to. Zero mean, unit std, tiles seamlessly."""
    dots = (rng.uniform(0.0, 1.0, shape) > 0.8).astype(np.float32)
    m = 4
    dots = cv2.GaussianBlur(np.pad(dots, m, mode='wrap'), (0, 0), 0.6)[m:-m, m:-m]
    tex = 0.5 * noise_texture(rng, shape, 2.0) + dots / max(float(dots.std()), 1e-6)
    tex -= tex.mean()
    return tex / max(float(tex.std()), 1e-6)


def wrapped_leaflet(img, centre, length, aspect, angle, colour, width_px):
    """A serrated leaflet (leaf_profile) with a lighter midrib, wrapped along x."""
    s = np.linspace(-1.0, 1.0, 25)
    half = leaf_profile(s).astype(float) * aspect * length / 2.0
    local = np.concatenate([np.stack([s * length / 2, half], 1),
                            np.stack([s[::-1] * length / 2, -half[::-1]], 1)])
    c, si = math.cos(angle), math.sin(angle)
    pts = local.dot(np.array([[c, si], [-si, c]])) + centre
    rib = np.array([[-c, -si], [c, si]]) * length * 0.45 + centre
    light = tuple(min(v * 1.35, 1.0) for v in colour)
    lo = min(float(pts[:, 0].min()), float(rib[:, 0].min())) - 2.0   # anti-aliased edge
    hi = max(float(pts[:, 0].max()), float(rib[:, 0].max())) + 2.0
    for dx in (-width_px, 0, width_px):
        if hi + dx < 0.0 or lo + dx > width_px:
            continue        # this copy lies wholly outside the tile: it would draw nothing
        off = np.array([dx, 0.0])
        cv2.fillPoly(img, [np.round((pts + off) * 4).astype(np.int32)], colour, cv2.LINE_AA, 2)
        cv2.line(img, tuple(int(v) for v in np.round((rib[0] + off) * 4)),
                 tuple(int(v) for v in np.round((rib[1] + off) * 4)), light, 1, cv2.LINE_AA, 2)


def polar(theta, phi):
    """Unit vector at polar angle theta from map +z and azimuth phi."""
    st = math.sin(theta)
    return np.array([st * math.cos(phi), st * math.sin(phi), math.cos(theta)])


def sepal_count(index):
    """Sepals of a fruit's calyx: 5, every third fruit 6."""
    return 6 if int(index) % 3 == 0 else 5


def leaf_profile(s):
    """Half width (0..1) of a tomato leaflet at s in [-1 (base), 1 (tip)], serrated edge."""
    return np.float32(0.89) * np.sqrt(np.maximum(1.0 - s * s, 0.0)) * (1.0 - 0.3 * s) * \
        (1.0 + 0.07 * np.sin(s * 9.0 * math.pi))


LEAF_S = np.linspace(-1.0, 1.0, 41)
LEAF_W = leaf_profile(LEAF_S).astype(float) * 1.02
CUBE = np.array([[sx, sy, sz] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)],
                 dtype=float)
