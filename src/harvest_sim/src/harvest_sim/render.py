"""Ray-cast renderer of the simulated greenhouse (numpy + OpenCV, no rospy).

Geometry is exact pinhole geometry: every pixel (u, v) is the ray through its centre, and
fruit (spheres), leaves (planar leaflets) and stems (capsules) are intersected with those rays
inside their projected bounding boxes; a depth buffer resolves occlusion. The background is the
canopy behind the row (plane x = track.backdrop_x), the opposite row (x = track.aisle_x), the
floor (z = 0) and the roof (z = ROOF_Z): textured planes ray-cast at half resolution into one
texture atlas and scaled up. Every surface carries texture fixed in 3-D, so block matching
finds the same pattern in both eyes.

Shading: Lambert + ambient with the scenario's light (intensity, colour, direction); fruit
skin is glossy (a sharp highlight of the light, a broad sheen, a soft highlight of the bright
sky/film above and Fresnel brightening at grazing angles), carries a fine surface texture and
ripens unevenly: from the blossom end up and in blotches (turning and pink fruit are mottled,
with green shoulders; mature green fruit have pale shoulders). Every fruit wears a calyx: a
star of thin green sepals (3-D capsules lying on the shoulders, tips lifting off) round the
pedicel. The background planes show the scenario's look.background (dense foliage, foliage
with plastic film and greenhouse equipment between the plants, or film with sparse plants).

Every frame then goes through the camera look of harvest_sim/look.py (white balance, exposure,
tone curve, blur, vignetting, Bayer mosaic with signal-dependent noise, demosaicing, JPEG),
drawn per (scenario seed, camera model) and the scenario's look.kind; the noise comes from a
bank per camera name (eye) seeded by the scenario seed, so a frame is a deterministic function
of (seed, camera name, frame index, scene).

Colour of a fruit by ripeness (display sRGB 0..1, interpolated; see RIPENESS_COLOURS), measured
on real photographs (tools/measure_fruit_colours.py, README): mature green (0-0.2) ->
turning yellow-orange (0.35) -> pink-orange (0.55) -> orange-red (0.7) -> red (1.0).
"""

import math
from collections import namedtuple

import cv2
import numpy as np

from harvest_sim import camera_model, look as camera_look

ROOF_Z = 3.2
NEAR = 0.01
#: (ripeness, RGB albedo): skin colours measured on real photographs (README, "Measured fruit
#: colours"): hue and saturation of the per-stage medians, red chromaticity R/(R+G+B) from
#: 0.36 (green) to 0.55 (0.7, hue 14: the pink/red boundary) and 0.71 (1.0)
RIPENESS_COLOURS = ((0.0, (0.475, 0.60, 0.227)), (0.2, (0.69, 0.69, 0.361)),
                    (0.35, (0.74, 0.64, 0.31)), (0.55, (0.839, 0.627, 0.31)),
                    (0.7, (0.80, 0.471, 0.18)), (0.85, (0.74, 0.30, 0.12)),
                    (1.0, (0.66, 0.18, 0.09)))
_RIPENESS_STOPS = np.array([r for r, _ in RIPENESS_COLOURS], np.float32)
_RIPENESS_BGR = np.array([c[::-1] for _, c in RIPENESS_COLOURS], np.float32)
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

RenderFruit = namedtuple('RenderFruit', 'index position radius ripeness pedicel_top attached '
                                        'cut_point moving', defaults=(False,))
RenderFruit.__doc__ = """A fruit as the renderer needs it (map frame).

index: stable integer (texture and label, label = index + 1); attached: still on its pedicel
(hanging or held); cut_point: where its pedicel was cut (None if attached); moving: held by the
suction sleeve (drawn per frame; the other fruit are cached with the static scene)."""


def fruit_albedo(ripeness):
    """RGB albedo (0..1) of a fruit of a given (uniform) ripeness."""
    r = min(max(float(ripeness), 0.0), 1.0)
    for (r0, c0), (r1, c1) in zip(RIPENESS_COLOURS[:-1], RIPENESS_COLOURS[1:]):
        if r <= r1:
            a = (r - r0) / (r1 - r0)
            return tuple((1 - a) * x0 + a * x1 for x0, x1 in zip(c0, c1))
    return RIPENESS_COLOURS[-1][1]


def _albedo_bgr(ripeness):
    """N x 3 BGR albedo (float32) of an array of local ripeness values."""
    r = np.clip(ripeness, 0.0, 1.0)
    return np.stack([np.interp(r, _RIPENESS_STOPS, _RIPENESS_BGR[:, k]) for k in range(3)],
                    axis=1).astype(np.float32)


def mottle_weight(ripeness):
    """0..1: how unevenly a fruit of this ripeness is coloured (peaks while turning/pink)."""
    r = float(ripeness)
    return float(np.interp(r, (0.12, 0.3, 0.55, 0.8, 0.95), (0.0, 1.0, 1.0, 0.35, 0.0)))


def fruits_from_scenario(scenario):
    """RenderFruit list of a scenario's fruit, all hanging at their scenario positions."""
    return [RenderFruit(i, f.position, f.radius, f.ripeness, f.pedicel_top, True, None)
            for i, f in enumerate(scenario.fruits)]


def _bgr(rgb):
    return np.array([rgb[2], rgb[1], rgb[0]], dtype=np.float32)


def _noise_texture(rng, shape, blur_sigma):
    n = rng.standard_normal(shape).astype(np.float32)
    if blur_sigma > 0:             # blur with wrap-around so the texture tiles seamlessly
        m = int(math.ceil(4 * blur_sigma))
        n = cv2.GaussianBlur(np.pad(n, m, mode='wrap'), (0, 0), blur_sigma)[m:-m, m:-m]
    return n / max(float(n.std()), 1e-6)


def _skin_texture(rng, shape):
    """Tomato skin: smooth, with faint blotches and fine light dots (lenticels), which give
    block matching something to hold on to. Zero mean, unit std, tiles seamlessly."""
    dots = (rng.uniform(0.0, 1.0, shape) > 0.8).astype(np.float32)
    m = 4
    dots = cv2.GaussianBlur(np.pad(dots, m, mode='wrap'), (0, 0), 0.6)[m:-m, m:-m]
    tex = 0.5 * _noise_texture(rng, shape, 2.0) + dots / max(float(dots.std()), 1e-6)
    tex -= tex.mean()
    return tex / max(float(tex.std()), 1e-6)


def _wrapped_leaflet(img, centre, length, aspect, angle, colour, width_px):
    """A serrated leaflet (leaf_profile) with a lighter midrib, wrapped along x."""
    s = np.linspace(-1.0, 1.0, 25)
    half = leaf_profile(s).astype(float) * aspect * length / 2.0
    local = np.concatenate([np.stack([s * length / 2, half], 1),
                            np.stack([s[::-1] * length / 2, -half[::-1]], 1)])
    c, si = math.cos(angle), math.sin(angle)
    pts = local.dot(np.array([[c, si], [-si, c]])) + centre
    rib = np.array([[-c, -si], [c, si]]) * length * 0.45 + centre
    light = tuple(min(v * 1.35, 1.0) for v in colour)
    for dx in (-width_px, 0, width_px):
        off = np.array([dx, 0.0])
        cv2.fillPoly(img, [np.round((pts + off) * 4).astype(np.int32)], colour, cv2.LINE_AA, 2)
        cv2.line(img, tuple(int(v) for v in np.round((rib[0] + off) * 4)),
                 tuple(int(v) for v in np.round((rib[1] + off) * 4)), light, 1, cv2.LINE_AA, 2)


class _Plane(object):
    """Axis-aligned background plane {p: p[axis] == value} and its place in the atlas."""

    def __init__(self, axis, value, kind, origin, size, res):
        self.axis, self.value, self.kind = axis, value, kind
        self.origin = origin           # atlas (col, row) of the tile block's top-left corner
        self.size = size               # (w, h) of one tile in texels
        self.res = res                 # m per texel


class Renderer(object):
    """Renders a scenario from any camera pose; static scene, dynamic fruit passed per call."""

    def __init__(self, scenario, seed=None, noise_sigma=2.0, blur_sigma=None, look=True):
        """noise_sigma scales the look's sensor noise (2.0 = as documented, 0 = none);
        blur_sigma (px) overrides the look's optics blur; look=False renders the clean image
        (no camera look at all)."""
        self.scenario = scenario
        self.seed = int(scenario.seed if seed is None else seed)
        self.noise_sigma = float(noise_sigma)
        self.blur_sigma = blur_sigma
        self.use_look = bool(look)
        self.look_config = getattr(scenario, 'look', None)
        self._looks = {}
        lt = scenario.lighting
        self.light_dir = np.asarray(lt.direction, dtype=float)
        self.light_bgr = _bgr(lt.colour) * np.float32(lt.intensity)
        # ambient = share of diffuse sky light: it dims with the intensity too
        self.ambient_bgr = _bgr(lt.colour) * np.float32(lt.ambient * lt.intensity)
        self.bounce_bgr = _bgr(lt.colour) * np.float32(BOUNCE * lt.intensity)
        # what the glossy skin mirrors from above (sky through the film, lamps)
        self.sky_bgr = _bgr(lt.colour) * np.float32(0.3 + 0.7 * lt.intensity)
        rng = np.random.default_rng(self.seed)
        self.fruit_tex = _skin_texture(rng, (128, 256))
        self.leaf_tex = _noise_texture(rng, (128, 128), 1.0)
        self.fruit_phase = rng.uniform(0.0, 1.0, 4096)
        self.blotch_tex = _noise_texture(rng, (32, 64), 1.5)
        canopy_lit = np.float32((lt.ambient + 0.45) * lt.intensity)
        self._build_atlas(rng, canopy_lit,
                          np.float32((lt.ambient + 0.6) * lt.intensity),
                          np.float32(0.3 + 0.8 * lt.intensity))
        self.planes = [_Plane(0, scenario.track.backdrop_x, 'canopy', *self._atlas_slots[0]),
                       _Plane(0, scenario.track.aisle_x, 'canopy', *self._atlas_slots[1]),
                       _Plane(2, 0.0, 'floor', *self._atlas_slots[2]),
                       _Plane(2, ROOF_Z, 'roof', *self._atlas_slots[3])]
        self.stems = [(s.points, s.radius) for s in scenario.stems]
        self._noise = {}
        self._rays = {}
        self._static = {}          # camera pose -> (image, depth, labels) without the fruit

    # ------------------------------------------------------------------ textures
    def _light(self, img_rgb_float, lit):
        """Bake the scenario light (colour, `lit` = ambient + diffuse share) into a texture."""
        out = img_rgb_float[:, :, ::-1] * (_bgr(self.scenario.lighting.colour) * lit)
        return np.clip(out * 255.0, 0, 255).astype(np.uint8)

    def _build_atlas(self, rng, canopy_lit, floor_lit, roof_lit):
        """One texture atlas for every background plane: each tile is stored 2 x 2 times (the
        canopies 2 x 1: they are clamped in height) so that coordinates taken modulo the tile
        and shifted by half a tile never touch an edge (seamless wrapping with bilinear
        filtering). Slots: (origin, tile size, m/texel)."""
        bg = self.look_config.background if self.look_config is not None else 'foliage'
        tiles = [(self._canopy(rng, canopy_lit, bg), TEX_RES),
                 (self._canopy(rng, canopy_lit * np.float32(0.9), bg), TEX_RES),
                 (self._floor(rng, floor_lit), 0.004),
                 (self._roof(rng, roof_lit), 0.01)]
        blocks = [np.tile(t, (1, 2, 1) if i < 2 else (2, 2, 1))   # canopy: clamped in height
                  for i, (t, _) in enumerate(tiles)]
        # canopies stacked; floor, roof and a sky swatch side by side below them
        width = max(blocks[0].shape[1], blocks[2].shape[1] + blocks[3].shape[1] + 8)
        height = blocks[0].shape[0] + blocks[1].shape[0] + max(blocks[2].shape[0],
                                                               blocks[3].shape[0])
        atlas = np.zeros((height, width, 3), np.uint8)
        origins = [(0, 0), (0, blocks[0].shape[0]),
                   (0, blocks[0].shape[0] + blocks[1].shape[0]),
                   (blocks[2].shape[1], blocks[0].shape[0] + blocks[1].shape[0])]
        for (c, r), b in zip(origins, blocks):
            atlas[r:r + b.shape[0], c:c + b.shape[1]] = b
        sky_c, sky_r = blocks[2].shape[1] + blocks[3].shape[1], origins[2][1]
        atlas[sky_r:sky_r + 8, sky_c:sky_c + 8] = np.clip(210 * roof_lit, 0, 255)
        self._sky = (np.float32(sky_c + 4), np.float32(sky_r + 4))
        self.atlas = atlas
        self._atlas_slots = [(o, (t.shape[1], t.shape[0]), res)
                             for o, (t, res) in zip(origins, tiles)]

    def _canopy(self, rng, lit, background='foliage'):
        """The row behind the fruit: one tile, periodic along the row. 'foliage': dense
        leaves; 'mixed' and 'film': leaves (fewer) in front of a translucent plastic film wall
        with the greenhouse's equipment (growing gutter, grow pipe, drip line, a post, twine
        and truss clips)."""
        w = int(round(CANOPY_TILE[0] / TEX_RES))
        h = int(round(CANOPY_TILE[1] / TEX_RES))
        m = 8

        def wrap_blur(a, sigma):
            return cv2.GaussianBlur(np.concatenate([a[:, -m:], a, a[:, :m]], axis=1), (0, 0),
                                    sigma)[:, m:-m]
        if background == 'foliage':
            img = np.zeros((h, w, 3), np.float32)
            img[:] = (0.05, 0.10, 0.04)
            layers = ((0.5, 0.6, 500, 2.0), (0.75, 0.8, 500, 1.2), (1.0, 1.0, 420, 0.0))
            light_leaves, bare = 0.0, 0.12
        else:
            img = self._film(rng, w, h, lit)
            self._equipment(rng, img)
            dense = background == 'mixed'
            layers = ((0.75, 0.8, 260 if dense else 70, 1.2),
                      (1.0, 1.0, 300 if dense else 120, 0.0))
            light_leaves, bare = 1.0, 0.02         # leaves against the film are lighter
        cover = np.zeros((h, w), np.float32)
        # depth layers of leaflets (colour + coverage): far ones darker, smaller and blurred
        for shade, size, count, blur in layers:
            layer = np.zeros((h, w, 4), np.float32)
            for _ in range(count):
                g = rng.uniform(0.3 + 0.2 * light_leaves, 0.8 + 0.2 * light_leaves) * shade
                col = (0.08 + (0.22 + 0.1 * light_leaves) * g * rng.uniform(0.6, 1.0),
                       0.14 + 0.45 * g, 0.04 + (0.12 + 0.08 * light_leaves) * g *
                       rng.uniform(0.5, 1.0), 1.0)
                _wrapped_leaflet(layer, (rng.uniform(0, w), rng.uniform(0, h)),
                                 rng.uniform(30, 110) * size, rng.uniform(0.35, 0.5),
                                 rng.uniform(0, 2 * math.pi), col, w)
            if shade == 0.75:
                for _ in range(6):       # support twine and plant stems between the layers
                    x = int(rng.uniform(0, w))
                    cv2.line(layer, (x, 0), (x + int(rng.uniform(-20, 20)), h),
                             (0.7, 0.68, 0.56, 1.0), 2, cv2.LINE_AA)
            alpha = layer[:, :, 3:]
            img = img * (1.0 - alpha) + layer[:, :, :3]      # leaves drawn opaque on black
            cover = cover * (1.0 - alpha[:, :, 0]) + alpha[:, :, 0]
            if blur > 0:
                img = wrap_blur(img, blur)
        # fine texture on the leaves (block matching), only a trace of it on film and steel
        fine = _noise_texture(rng, (h, w), 1.0)
        img *= (1.0 + (bare + (0.12 - bare) * cover) * fine)[:, :, None]
        img = wrap_blur(img, 0.8)
        return self._light(img, lit)

    def _film(self, rng, w, h, lit):
        """Translucent white plastic film lit from behind: folds and creases, the blurred
        shadows of plants beyond it, a taped seam. Returned pre-divided by `lit` (the film
        shines with the daylight behind it, not with the light falling on the canopy)."""
        x = np.arange(w, dtype=np.float32)
        fold = np.zeros(w, np.float32)
        for _ in range(6):               # vertical folds: periodic over the tile width
            k = int(rng.integers(2, 14))
            fold += np.float32(rng.uniform(0.01, 0.035)) * \
                np.sin(2 * np.pi * k * x / w + np.float32(rng.uniform(0, 2 * np.pi)))
        z = CANOPY_TILE[1] - 0.2 - np.arange(h, dtype=np.float32) * TEX_RES
        glow = 0.9 + 0.1 * np.clip((z - 0.3) / 2.0, 0.0, 1.0)     # brighter higher up
        base = np.array((0.84, 0.87, 0.86), np.float32)
        img = np.ones((h, w, 3), np.float32) * base
        img *= ((1.0 + fold)[None, :] * glow[:, None])[:, :, None]
        mottle = cv2.resize(_noise_texture(rng, (h // 8, w // 8), 1.5), (w, h),
                            interpolation=cv2.INTER_LINEAR)
        img *= (1.0 + 0.05 * mottle)[:, :, None]
        # plants beyond the film: soft green-grey shadows
        shadow = np.zeros((h, w, 3), np.float32)
        for _ in range(140):
            g = rng.uniform(0.5, 1.0)
            _wrapped_leaflet(shadow, (rng.uniform(0, w), rng.uniform(0, h)),
                             rng.uniform(60, 180), rng.uniform(0.35, 0.5),
                             rng.uniform(0, 2 * math.pi), (0.45 * g, 0.3 * g, 0.5 * g), w)
        for _ in range(4):
            xs = int(rng.uniform(0, w))
            cv2.line(shadow, (xs, 0), (xs + int(rng.uniform(-40, 40)), h), (0.4, 0.3, 0.45), 8)
        pad = 48
        shadow = cv2.GaussianBlur(np.concatenate([shadow[:, -pad:], shadow, shadow[:, :pad]],
                                                 axis=1), (0, 0), 14.0)[:, pad:-pad]
        img = np.clip(img - 0.55 * shadow, 0.0, 1.0)
        for _ in range(10):              # creases: thin bright and dark lines, mostly vertical
            x0 = rng.uniform(0, w)
            y0, y1 = rng.uniform(0, h), rng.uniform(0, h)
            x1 = x0 + rng.uniform(-0.3, 0.3) * abs(y1 - y0)
            v = float(rng.choice([0.93, 0.7]))
            cv2.line(img, (int(x0), int(y0)), (int(x1), int(y1)), (v, v, v), 1, cv2.LINE_AA)
        seam = int((CANOPY_TILE[1] - 0.2 - rng.uniform(1.6, 1.8)) / TEX_RES)
        img[seam:seam + 12] *= np.float32(0.88)
        film_lit = np.float32(0.35 + 0.75 * self.scenario.lighting.intensity)
        return img * (film_lit / max(float(lit), 1e-3))

    def _equipment(self, rng, img):
        """Greenhouse equipment painted on the row's tile (z from the tile's top edge): the
        white growing gutter with its black drip line, a galvanised grow pipe, a steel post,
        and yellow truss clips on twine."""
        h, w = img.shape[:2]

        def row(z):
            return int(round((CANOPY_TILE[1] - 0.2 - z) / TEX_RES))
        # gutter: a white trough, lit lip on top, shaded face, dark shadow below
        top, bottom = row(0.56), row(0.40)
        img[top:bottom] = (0.80, 0.81, 0.80)
        img[top:top + 6] = (0.95, 0.95, 0.94)
        ramp = np.linspace(1.0, 0.75, bottom - top - 6, dtype=np.float32)[:, None, None]
        img[top + 6:bottom] *= ramp
        img[bottom:bottom + 20] *= np.linspace(0.45, 1.0, 20, dtype=np.float32)[:, None, None]
        cv2.line(img, (0, top - 4), (w - 1, top - 4), (0.04, 0.04, 0.04), 5)   # drip line
        # grow pipe: a cylinder (shaded across, with a highlight line)
        c, rad = row(0.66), 7
        prof = np.cos(np.linspace(-1.3, 1.3, 2 * rad + 1, dtype=np.float32))
        pipe = (0.45 + 0.4 * prof)[:, None] * np.array((0.72, 0.74, 0.76), np.float32)
        img[c - rad:c + rad + 1] = pipe[:, None, :]
        img[c - rad // 2] = (0.95, 0.95, 0.95)
        # a steel post, shaded like the pipe, from the floor up
        x0 = int(rng.uniform(0, w - 40))
        prof = np.cos(np.linspace(-1.2, 1.2, 30, dtype=np.float32))
        post = (0.4 + 0.35 * prof)[:, None] * np.array((0.62, 0.63, 0.65), np.float32)
        img[:, x0:x0 + 30] = post[None, :, :]
        # twine with yellow truss clips
        for _ in range(5):
            x = int(rng.uniform(0, w))
            cv2.line(img, (x, 0), (x + int(rng.uniform(-15, 15)), h), (0.78, 0.76, 0.66), 2,
                     cv2.LINE_AA)
            for _ in range(2):
                y = row(rng.uniform(0.7, 1.5))
                cv2.rectangle(img, (x - 4, y - 6), (x + 4, y + 6), (0.93, 0.78, 0.22), -1)

    def _floor(self, rng, lit):
        """White ground cover sheet with soil stains and two heating pipes (the cart's rails)
        along the row, shaded as cylinders."""
        img = np.zeros((500, 500, 3), np.float32)
        img[:] = (0.66, 0.66, 0.63)            # white-ish ground cover sheet
        img *= (1.0 + 0.08 * _noise_texture(rng, (500, 500), 2.0))[:, :, None]
        stains = np.clip(_noise_texture(rng, (500, 500), 6.0) - 1.2, 0.0, 2.0)
        img *= (1.0 - 0.3 * stains)[:, :, None] * np.array((1.0, 0.97, 0.92), np.float32)
        prof = np.cos(np.linspace(-1.3, 1.3, 13, dtype=np.float32))
        pipe = (0.35 + 0.55 * prof)[:, None] * np.array((0.8, 0.8, 0.82), np.float32)
        for x in (75, 150):                   # heating pipe rails along the row
            img[:, x - 6:x + 7] = pipe[None, :, :]
            img[:, x - 2] = (0.97, 0.97, 0.97)
            img[:, x + 7:x + 11] *= np.float32(0.6)      # shadow beside the pipe
        return self._light(img, lit)

    def _roof(self, rng, lit):
        img = np.zeros((400, 400, 3), np.float32)
        img[:] = (0.85, 0.88, 0.92)
        img *= (1.0 + 0.03 * _noise_texture(rng, (400, 400), 3.0))[:, :, None]
        cv2.line(img, (0, 0), (399, 0), (0.3, 0.3, 0.32), 6)
        cv2.line(img, (0, 0), (0, 399), (0.3, 0.3, 0.32), 6)
        return self._light(img, lit)

    # ------------------------------------------------------------------ helpers
    def _ray_grid(self, camera):
        key = (camera.width, camera.height, camera.fx, camera.fy, camera.cx, camera.cy)
        if key not in self._rays:
            xs, ys = camera.ray_grid()
            self._rays[key] = (xs.astype(np.float32), ys.astype(np.float32))
        return self._rays[key]

    def noise_frames(self, name, width, height, count=4):
        """Bank of `count` sensor noise frames of the camera (eye) `name` (look.noise_bank)."""
        key = (name, width, height)
        if key not in self._noise:
            self._noise[key] = camera_look.noise_bank(self.seed, name, width, height, count)
        return self._noise[key]

    def camera_look(self, camera):
        """The CameraLook of a camera model (shared by both eyes of a stereo pair)."""
        w, h = camera.width + camera.width % 2, camera.height + camera.height % 2
        key = (camera_look.camera_key(camera), w, h)
        if key not in self._looks:
            cfg = self.look_config
            params = camera_look.look_params(self.seed, key[0],
                                             cfg.kind if cfg is not None else 'daylight',
                                             cfg.variation if cfg is not None else 1.0)
            if self.blur_sigma is not None:
                params = params._replace(blur_sigma=float(self.blur_sigma))
            self._looks[key] = camera_look.CameraLook(params, w, h, self.noise_sigma / 2.0)
        return self._looks[key]

    def _apply_look(self, img, camera, noise_key):
        look = self.camera_look(camera)
        h, w = img.shape[:2]
        if (w, h) != (look.width, look.height):        # odd size: pad for the Bayer mosaic
            img = cv2.copyMakeBorder(img, 0, look.height - h, 0, look.width - w,
                                     cv2.BORDER_REPLICATE)
        noise = None
        if noise_key is not None and self.noise_sigma > 0:
            bank = self.noise_frames(noise_key[0], look.width, look.height)
            noise = bank[int(noise_key[1]) % len(bank)]
        out = look.apply(img, noise)
        return out if out.shape[:2] == (h, w) else np.ascontiguousarray(out[:h, :w])

    # ------------------------------------------------------------------ main entry
    def render(self, camera, T_map_cam, fruits, noise_key=None, labels=False):
        """BGR uint8 image (and an int16 label image if labels) seen by `camera` at T_map_cam.

        fruits: RenderFruit list (map frame); noise_key: (camera name, frame index) selects the
        deterministic noise frame, None renders without noise.
        """
        T = np.asarray(T_map_cam, dtype=float)
        ctx = _Frame(self, camera, T, labels)
        still = [f for f in fruits if not f.moving]
        key = (camera.width, camera.height, camera.fx, camera.fy, camera.cx, camera.cy,
               T.tobytes(), labels,
               tuple((f.index, tuple(np.round(f.position, 5)), f.attached,
                      None if f.cut_point is None else tuple(np.round(f.cut_point, 5)))
                     for f in still))
        layer = self._static.get(key)
        if layer is None:
            # everything but the moving (held) fruit depends on the camera pose and the still
            # fruit only: keep that layer (image, depth, labels) and draw the moving fruit on a
            # copy of it
            self._background(ctx)
            for points, radius in self.stems:
                for a, b in zip(points[:-1], points[1:]):
                    self._capsule(ctx, a, b, radius, STEM_RGB, LABEL_STEM)
            for i, leaf in enumerate(self.scenario.leaves):
                self._leaf(ctx, leaf, LABEL_LEAF + i)
            self._fruits(ctx, still)
            layer = (ctx.img.copy(), ctx.zbuf.copy(),
                     None if ctx.labels is None else ctx.labels.copy())
            if len(self._static) >= STATIC_CACHE:
                self._static.pop(next(iter(self._static)))
            self._static[key] = layer
        else:
            ctx.img[:], ctx.zbuf[:] = layer[0], layer[1]
            if labels:
                ctx.labels[:] = layer[2]
        self._fruits(ctx, [f for f in fruits if f.moving])
        img = ctx.img
        if self.use_look:
            img = self._apply_look(img, camera, noise_key)
        if labels:
            return img, ctx.labels
        return img

    def _fruits(self, ctx, fruits):
        for f in fruits:
            self._sphere(ctx, f)
        for f in fruits:
            self._sepals(ctx, f)
            top = np.asarray(f.position) + np.array([0.0, 0.0, 0.8 * f.radius])
            if f.attached:
                # the pedicel rises from the calyx to its knuckle, then bends to the truss
                knee = np.asarray(f.position) + np.array([0.0, 0.0, f.radius + PEDICEL_KNEE])
                if f.pedicel_top[2] > knee[2] + 0.005:
                    self._capsule(ctx, top, knee, PEDICEL_RADIUS, STEM_RGB, LABEL_STEM)
                    top = knee
                self._capsule(ctx, top, f.pedicel_top, PEDICEL_RADIUS, STEM_RGB, LABEL_STEM)
            else:
                stub = np.asarray(f.position) + np.array([0.0, 0.0, f.radius + 0.006])
                self._capsule(ctx, top, stub, PEDICEL_RADIUS, STEM_RGB, LABEL_STEM)
                if f.cut_point is not None:
                    self._capsule(ctx, f.cut_point, f.pedicel_top, PEDICEL_RADIUS, STEM_RGB,
                                  LABEL_STEM)

    def _sepals(self, ctx, f):
        """The calyx's star of thin sepals: each follows the shoulder from the pedicel, then
        its tip stands off the fruit (out, a little up or down). Each sepal is a polyline of
        short tapered segments rasterised as thick lines, each with the depth of its nearer
        end, front to back; sepal pixels over the fruit keep the fruit's label (the calyx is
        part of the fruit), the others are labelled as stem."""
        c = np.asarray(f.position, dtype=float)
        r = float(f.radius)
        n = _sepal_count(f.index)
        phases = self.fruit_phase
        phase = phases[int(f.index) % len(phases)]
        length = 0.012 + 0.45 * r                       # cherry ~1.4 r, large fruit ~0.7 r
        th0, th1 = 0.1, 0.1 + 0.45 * length / r
        jitter = phases[(int(f.index) * 7 + np.arange(n) + 11) % len(phases)]
        phi = 2.0 * np.pi * (np.arange(n) / float(n) - phase) + 0.3 * (jitter - 0.5)
        th = np.linspace(th0, th1, 5)
        cp, sp = np.cos(phi)[:, None], np.sin(phi)[:, None]
        arc = c + (r + 0.0012) * np.stack([np.sin(th) * cp, np.sin(th) * sp,
                                           np.cos(th) + 0.0 * cp], axis=2)      # n x 5 x 3
        out = np.stack([np.cos(phi), np.sin(phi), 0.9 * (jitter - 0.45)], axis=1)
        out *= ((0.5 + 0.2 * jitter) * length / np.linalg.norm(out, axis=1))[:, None]
        line = np.concatenate([arc, arc[:, -1:] + 0.5 * out[:, None], arc[:, -1:] +
                               out[:, None]], axis=1)                             # n x 7 x 3
        m = line.shape[1] - 1
        pts = np.stack([line[:, :-1], line[:, 1:]], axis=2).reshape(-1, 3)      # segment ends
        radii = np.tile(SEPAL_RADIUS[0] + (SEPAL_RADIUS[1] - SEPAL_RADIUS[0]) *
                        np.arange(m) / float(m - 1), n)
        # lit like the fruit surface under it: normal ~ the radial direction
        nrm = line[:, :-1] - c
        nrm = (nrm / np.linalg.norm(nrm, axis=2)[:, :, None]).reshape(-1, 3)
        lam = np.maximum(ctx.R.T.dot(nrm.T).T.dot(-ctx.light_cam), 0.0)
        shade = np.repeat(0.85 + 0.3 * jitter, m)
        P = ctx.R.T.dot((pts - ctx.t).T).T                               # camera frame
        if P[:, 2].min() <= NEAR + SEPAL_RADIUS[0]:
            return
        uv = ctx.camera.project(P)
        z = P[:, 2].reshape(-1, 2)
        rad_px = ctx.camera.fx * np.array(radii) / z.min(axis=1)
        pad = int(math.ceil(rad_px.max())) + 2
        box = ctx.clip_box(int(math.floor(uv[:, 0].min())) - pad,
                           int(math.ceil(uv[:, 0].max())) + pad + 1,
                           int(math.floor(uv[:, 1].min())) - pad,
                           int(math.ceil(uv[:, 1].max())) + pad + 1)
        if box is None:
            return
        u0, u1, v0, v1 = box
        patch = np.zeros((v1 - v0, u1 - u0), np.int16)
        depth = z.min(axis=1) - np.array(radii)
        ends = np.round((uv - [u0, v0]) * 16).astype(np.int64).reshape(-1, 2, 2)
        for k in np.argsort(-depth):                      # far first: nearer ones overwrite
            a, b = ends[k]
            cv2.line(patch, (int(a[0]), int(a[1])), (int(b[0]), int(b[1])), int(k) + 1,
                     max(1, int(round(2.0 * rad_px[k]))), cv2.LINE_8, 4)
        iy, ix = np.nonzero(patch)
        if iy.size == 0:
            return
        seg = patch[iy, ix] - 1
        zz = depth[seg].astype(np.float32)
        ok = zz < ctx.zbuf[v0 + iy, u0 + ix]
        iy, ix, seg, zz = iy[ok], ix[ok], seg[ok], zz[ok]
        if iy.size == 0:
            return
        lit = (shade[:, None] * (self.ambient_bgr[None, :] + self.light_bgr[None, :] *
                                 lam[:, None])).astype(np.float32)
        out = _bgr(SEPAL_RGB)[None, :] * lit[seg]
        label = LABEL_STEM
        if ctx.labels is not None:
            fl = int(f.index) + 1
            label = np.where(ctx.labels[v0 + iy, u0 + ix] == fl, fl, LABEL_STEM).astype(np.int16)
        ctx.put(v0 + iy, u0 + ix, zz, out, label)

    # ------------------------------------------------------------------ background planes
    def _background(self, ctx):
        """Canopy, aisle, floor and roof at half resolution (one remap from the atlas), scaled
        up. Scene objects always lie between these planes, so they are drawn over the
        background without a depth test against it."""
        cam = ctx.camera
        key = ('half', cam.width, cam.height, cam.fx, cam.fy, cam.cx, cam.cy)
        if key not in self._rays:
            w2, h2 = (cam.width + 1) // 2, (cam.height + 1) // 2
            xs = ((np.arange(w2) * 2 + 0.5 - cam.cx) / cam.fx).astype(np.float32)
            ys = ((np.arange(h2) * 2 + 0.5 - cam.cy) / cam.fy).astype(np.float32)
            self._rays[key] = (xs, ys)
        xs, ys = self._rays[key]
        R, t = ctx.R, ctx.t
        comp = [np.float32(R[k, 0]) * xs[None, :] + np.float32(R[k, 1]) * ys[:, None] +
                np.float32(R[k, 2]) for k in range(3)]        # map direction of every ray
        depth, which = None, None
        for k, pl in enumerate(self.planes):
            dist = np.float32(pl.value - t[pl.axis])
            with np.errstate(divide='ignore', invalid='ignore'):
                d = dist / comp[pl.axis]
            d[~(d > NEAR)] = np.inf
            if depth is None:
                depth, which = d, np.zeros(d.shape, np.int8)
            else:
                closer = d < depth
                depth[closer] = d[closer]
                which[closer] = k
        mapx = np.full(depth.shape, self._sky[0], np.float32)
        mapy = np.full(depth.shape, self._sky[1], np.float32)
        finite = np.isfinite(depth)
        for k, pl in enumerate(self.planes):
            m = (which == k) & finite
            if not m.any():
                continue
            full = bool(m.all())
            dk = depth if full else depth[m]
            a_axis, b_axis = (1, 2) if pl.axis == 0 else (0, 1)
            ca = comp[a_axis] if full else comp[a_axis][m]
            cb = comp[b_axis] if full else comp[b_axis][m]
            a = np.float32(t[a_axis]) + dk * ca
            b = np.float32(t[b_axis]) + dk * cb
            w, h = pl.size
            if pl.kind == 'canopy':          # along the row wraps; height is clamped
                u = np.mod(a / np.float32(pl.res), w) + np.float32(pl.origin[0] + w / 2)
                v = np.clip((np.float32(CANOPY_TILE[1] - 0.2) - b) / np.float32(pl.res), 0,
                            h - 1) + np.float32(pl.origin[1])
            else:
                u = np.mod(a / np.float32(pl.res), w) + np.float32(pl.origin[0] + w / 2)
                v = np.mod(b / np.float32(pl.res), h) + np.float32(pl.origin[1] + h / 2)
            if full:
                mapx, mapy = u, v
            else:
                mapx[m], mapy[m] = u, v
        half = cv2.remap(self.atlas, mapx, mapy, cv2.INTER_LINEAR)
        ctx.img[:] = cv2.resize(half, (cam.width, cam.height),
                                interpolation=cv2.INTER_LINEAR)

    # ------------------------------------------------------------------ primitives
    def _sphere(self, ctx, f):
        C = ctx.to_cam(f.position)
        r = float(f.radius)
        if C[2] + r <= NEAR:
            return
        box = ctx.bbox_of_points(C + r * _CUBE) if C[2] - r > NEAR else ctx.full_box()
        if box is None:
            return
        u0, u1, v0, v1 = box
        X = ctx.xs[u0:u1][None, :]
        Y = ctx.ys[v0:v1][:, None]
        dC = X * np.float32(C[0]) + Y * np.float32(C[1]) + np.float32(C[2])
        dd = X * X + Y * Y + np.float32(1.0)
        disc = dC * dC - dd * np.float32(C.dot(C) - r * r)
        hit = disc > 0
        if not hit.any():
            return
        z = np.where(hit, (dC - np.sqrt(np.maximum(disc, 0))) / dd, np.inf)
        zb = ctx.zbuf[v0:v1, u0:u1]
        hit &= (z > NEAR) & (z < zb)
        iy, ix = np.nonzero(hit)
        if iy.size == 0:
            return
        zz = z[iy, ix]
        rx, ry = ctx.xs[u0 + ix], ctx.ys[v0 + iy]          # ray (rx, ry, 1) of each pixel
        C32 = C.astype(np.float32)
        ir = np.float32(1.0 / r)
        n = np.stack([(rx * zz - C32[0]) * ir, (ry * zz - C32[1]) * ir, (zz - C32[2]) * ir],
                     axis=1)
        # fruit-fixed frame (the fruit hangs upright): up, and two horizontal axes
        up = ctx.R[2].astype(np.float32)                 # map z in camera coordinates
        e1 = ctx.R[0].astype(np.float32)                 # map x in camera coordinates
        e2 = np.cross(up, e1)
        cos_t = n.dot(up)
        a1, a2 = n.dot(e1), n.dot(e2)
        # fine surface texture, tri-planar: three projections of one noise texture weighted by
        # the squared normal components (which sum to 1); shifted per fruit
        th_n, tw_n = self.fruit_tex.shape
        phase = self.fruit_phase[int(f.index) % len(self.fruit_phase)]
        k = np.float32(min((th_n - 1) * 0.5, float(f.radius) / SKIN_TEXEL))
        off = int(phase * tw_n)
        npx = a1.shape[0]
        rows = -(-npx // 512)                # remap wants 2-D maps below 32767 a side
        f1, f2, f3 = [np.resize(((v + 1.0) * k).astype(np.float32), rows * 512).reshape(rows, 512)
                      for v in (a1, a2, cos_t)]
        T = self.fruit_tex

        def sample(col, row):               # bilinear, wrapping round the texture
            return cv2.remap(T, col, row, cv2.INTER_LINEAR,
                             borderMode=cv2.BORDER_WRAP).reshape(-1)[:npx]
        tex = (a1 * a1 * sample(f3 + off, f2) + a2 * a2 * sample(f3 + (off + th_n), f1) +
               cos_t * cos_t * sample(f2 + (off + 2 * th_n), f1))
        rip = min(max(float(f.ripeness), 0.0), 1.0)
        mottle = mottle_weight(rip)
        if mottle > 0:
            # uneven ripening: riper toward the blossom end (bottom), in blotches
            B = self.blotch_tex
            bh, bw = B.shape
            kb = np.float32((bh - 1) * 0.5)
            j1, j2, j3 = ((a1 + 1.0) * kb).astype(np.int32), ((a2 + 1.0) * kb).astype(np.int32), \
                ((cos_t + 1.0) * kb).astype(np.int32)
            ob = int(phase * bw)
            blotch = (a1 * a1 * B[j2, (j3 + ob) % bw] + a2 * a2 * B[j1, (j3 + ob + bh) % bw] +
                      cos_t * cos_t * B[j1, (j2 + ob + 2 * bh) % bw])
            local = rip + np.float32(mottle) * (np.float32(-0.16) * cos_t +
                                                np.float32(0.05) * blotch)
            out = _albedo_bgr(local)
        else:
            out = np.repeat(_bgr(fruit_albedo(rip))[None, :], cos_t.shape[0], axis=0)
        if rip < 0.3:
            # mature green fruit: pale, yellowish shoulders
            pale = (np.float32(0.55 * (0.3 - rip) / 0.3) * np.maximum(cos_t, 0.0) ** 2)[:, None]
            out = out * (1 - pale) + _bgr(PALE_SHOULDER_RGB)[None, :] * pale
        out *= (1.0 + np.float32(SKIN_TEXTURE) * tex)[:, None]
        # calyx base: a small star round the top (the sepals themselves are 3-D, see _sepals)
        n_sep = _sepal_count(f.index)
        cap = np.nonzero(cos_t > CALYX_COS)[0]
        calyx = np.zeros(cos_t.shape, bool)
        if cap.size:
            theta = np.arccos(np.minimum(cos_t[cap], 1.0))
            phi = np.arctan2(a2[cap], a1[cap]) + np.float32(phase * 2 * math.pi)
            arm = np.abs(np.cos(0.5 * n_sep * phi)) ** 6
            calyx[cap] = theta < (0.13 + 0.30 * arm) * (0.8 + 0.2 * (1.0 - rip))
            out[calyx] = _bgr(CALYX_RGB) * (1.0 + 0.15 * tex[calyx, None])
        rib = min(max((float(f.radius) - RIBS[0]) / (RIBS[1] - RIBS[0]), 0.0), 1.0) * RIBS[2]
        if rib > 0:
            # large fruit are lobed round the stem: tilt the shading normal across the lobes
            # (the silhouette stays the sphere's)
            az = np.arctan2(a2, a1) + np.float32(phase * 2 * math.pi)
            w = (np.float32(rib) * np.sin(RIBS[3] * az) *
                 np.clip(cos_t + 0.3, 0.0, 1.0))[:, None]
            n = n + w * (np.cos(az)[:, None] * e2[None, :] - np.sin(az)[:, None] * e1[None, :])
            n /= np.linalg.norm(n, axis=1)[:, None]
        # Lambert + gloss: n.h = (n.v + n.l) / |v + l|, v = -ray / |ray|
        l = -ctx.light_cam
        nl = n.dot(l)
        inv_len = 1.0 / np.sqrt(rx * rx + ry * ry + 1.0)
        nv = -(n[:, 0] * rx + n[:, 1] * ry + n[:, 2]) * inv_len
        vl = -(rx * l[0] + ry * l[1] + l[2]) * inv_len
        nh = (nv + nl) / np.sqrt(np.maximum(2.0 + 2.0 * vl, 1e-6))
        # diffuse: the light (a large, soft source: wrapped Lambert), the ambient, and light
        # bounced up from the white floor sheet
        wrap = np.maximum((nl + np.float32(WRAP)) / np.float32(1.0 + WRAP), 0.0)
        out *= (self.ambient_bgr + self.light_bgr * wrap[:, None] +
                self.bounce_bgr * np.maximum(-cos_t, 0.0)[:, None])
        skin = np.nonzero(~calyx)[0]
        if skin.size:
            # sharp highlight and broad sheen of the light
            h = np.maximum(nh[skin], 0.0)
            spec = np.float32(SHEEN[0]) * h ** np.float32(SHEEN[1])
            sharp = h > 0.95
            spec[sharp] += np.float32(SPECULAR[0]) * h[sharp] ** np.float32(SPECULAR[1])
            # soft highlight of the bright sky/film above, and Fresnel rim (grazing angles)
            vu = -(rx[skin] * up[0] + ry[skin] * up[1] + up[2]) * inv_len[skin]
            hs = np.maximum((nv[skin] + cos_t[skin]) /
                            np.sqrt(np.maximum(2.0 + 2.0 * vu, 1e-6)), 0.0)
            sky = np.float32(SKY_GLOSS[0]) * hs ** np.float32(SKY_GLOSS[1])
            rim = np.float32(FRESNEL) * (1.0 - np.clip(nv[skin], 0.0, 1.0)) ** 5 * \
                (0.5 + 0.5 * cos_t[skin])
            out[skin] += spec[:, None] * self.light_bgr[None, :] + \
                (sky + rim)[:, None] * self.sky_bgr[None, :]
        ctx.put(v0 + iy, u0 + ix, zz, out, int(f.index) + 1)

    def _leaf(self, ctx, leaf, label):
        Lc = ctx.to_cam(leaf.centre)
        N = ctx.R.T.dot(leaf.normal)
        A = ctx.R.T.dot(leaf.axis)
        B = np.cross(N, A)
        hl, hw = leaf.length / 2.0, leaf.width / 2.0
        outline = np.concatenate([
            Lc + np.outer(_LEAF_S * hl, A) + np.outer(_LEAF_W * hw, B),
            Lc + np.outer(_LEAF_S[::-1] * hl, A) - np.outer(_LEAF_W[::-1] * hw, B)])
        if np.all(outline[:, 2] <= NEAR):
            return
        if np.all(outline[:, 2] > NEAR):
            # rasterise the projected outline (exact for a planar shape up to the polygon's
            # sampling, drawn 1 px wider), then intersect rays only inside it
            uv = ctx.camera.project(outline)
            box = ctx.clip_box(int(math.floor(uv[:, 0].min())) - 2,
                               int(math.ceil(uv[:, 0].max())) + 3,
                               int(math.floor(uv[:, 1].min())) - 2,
                               int(math.ceil(uv[:, 1].max())) + 3)
            if box is None:
                return
            u0, u1, v0, v1 = box
            mask = np.zeros((v1 - v0, u1 - u0), np.uint8)
            poly = np.round((uv - [u0, v0]) * 16).astype(np.int32)
            cv2.fillPoly(mask, [poly], 1, cv2.LINE_8, 4)
            cv2.polylines(mask, [poly], True, 1, 2, cv2.LINE_8, 4)
            iy, ix = np.nonzero(mask)
        else:
            u0, u1, v0, v1 = ctx.full_box()
            iy, ix = np.nonzero(np.ones((v1 - v0, u1 - u0), bool))
        if iy.size == 0:
            return
        X = ctx.xs[u0 + ix]
        Y = ctx.ys[v0 + iy]
        denom = X * np.float32(N[0]) + Y * np.float32(N[1]) + np.float32(N[2])
        with np.errstate(divide='ignore', invalid='ignore'):
            z = np.float32(Lc.dot(N)) / denom
        ok = (z > NEAR) & (z < ctx.zbuf[v0 + iy, u0 + ix])
        iy, ix, z = iy[ok], ix[ok], z[ok]
        if iy.size == 0:
            return
        zz = z
        P = np.stack([ctx.xs[u0 + ix] * zz, ctx.ys[v0 + iy] * zz, zz], axis=1)
        D = P - Lc.astype(np.float32)
        s = D.dot(A.astype(np.float32)) / np.float32(hl)
        w = D.dot(B.astype(np.float32)) / np.float32(hw)
        prof = leaf_profile(s)
        inside = (np.abs(s) <= 1.0) & (np.abs(w) <= prof)
        if not inside.any():
            return
        iy, ix, zz, s, w = iy[inside], ix[inside], zz[inside], s[inside], w[inside]
        th, tw = self.leaf_tex.shape
        tex = self.leaf_tex[((s + 1.0) * 0.5 * (th - 1)).astype(np.int32),
                            ((w + 1.0) * 0.5 * (tw - 1)).astype(np.int32) % tw]
        vein = (np.abs(w) < 0.05) | (np.abs(((s * 4.0 + np.abs(w) * 2.0) % 1.0) - 0.5) < 0.04)
        col = _bgr(leaf.colour)[None, :] * (1.0 + 0.12 * tex)[:, None]
        col[vein] *= 1.25
        nd = float(N.dot(-ctx.light_cam))
        # two-sided leaf: lit face, or light shining through (translucent)
        lit = abs(nd) * (1.0 if nd * N.dot(-Lc) > 0 else 0.45)
        out = col * (self.ambient_bgr + self.light_bgr * np.float32(lit))[None, :]
        ctx.put(v0 + iy, u0 + ix, zz, out, label)

    def _capsule(self, ctx, a_map, b_map, radius, rgb, label):
        A, B = ctx.to_cam(a_map), ctx.to_cam(b_map)
        if A[2] <= NEAR and B[2] <= NEAR:
            return
        if A[2] <= NEAR or B[2] <= NEAR:          # clip the segment at the near plane
            if A[2] <= NEAR:
                A, B = B, A
            s = (A[2] - 2 * NEAR) / (A[2] - B[2])
            B = A + s * (B - A)
        zmin = max(min(A[2], B[2]) - radius, NEAR)
        rp = ctx.camera.fx * radius / zmin + 2.0
        uv = ctx.camera.project(np.array([A, B]))
        u0 = int(math.floor(uv[:, 0].min() - rp))
        u1 = int(math.ceil(uv[:, 0].max() + rp)) + 1
        v0 = int(math.floor(uv[:, 1].min() - rp))
        v1 = int(math.ceil(uv[:, 1].max() + rp)) + 1
        box = ctx.clip_box(u0, u1, v0, v1)
        if box is None:
            return
        u0, u1, v0, v1 = box
        X = ctx.xs[u0:u1][None, :]
        Y = ctx.ys[v0:v1][:, None]
        V = (B - A).astype(np.float32)
        A32 = A.astype(np.float32)
        a = X * X + Y * Y + np.float32(1.0)
        b = X * V[0] + Y * V[1] + V[2]
        c = np.float32(V.dot(V))
        dA = X * A32[0] + Y * A32[1] + A32[2]
        vA = np.float32(V.dot(A32))
        denom = a * c - b * b
        with np.errstate(divide='ignore', invalid='ignore'):
            s = np.where(denom > 1e-12, (b * dA - a * vA) / denom, 0.0)
        s = np.clip(s, 0.0, 1.0)
        t = (b * s + dA) / a                       # ray parameter (= depth) closest to Q(s)
        dx = X * t - (A32[0] + s * V[0])
        dy = Y * t - (A32[1] + s * V[1])
        dz = t - (A32[2] + s * V[2])
        dist2 = dx * dx + dy * dy + dz * dz
        hit = dist2 < np.float32(radius * radius)
        if not hit.any():
            return
        front = np.sqrt(np.maximum(np.float32(radius * radius) - dist2, 0.0) / a)
        z = t - front
        zb = ctx.zbuf[v0:v1, u0:u1]
        hit &= (z > NEAR) & (z < zb)
        iy, ix = np.nonzero(hit)
        if iy.size == 0:
            return
        zz = z[iy, ix]
        # surface normal: from the axis point to the front surface point
        nx = dx[iy, ix] - ctx.xs[u0 + ix] * front[iy, ix]
        ny = dy[iy, ix] - ctx.ys[v0 + iy] * front[iy, ix]
        nz = dz[iy, ix] - front[iy, ix]
        n = np.stack([nx, ny, nz], axis=1)
        n /= np.maximum(np.linalg.norm(n, axis=1), 1e-9)[:, None]
        diff = np.maximum(n.dot(-ctx.light_cam), 0.0)[:, None]
        out = _bgr(rgb)[None, :] * (self.ambient_bgr + self.light_bgr * diff)
        ctx.put(v0 + iy, u0 + ix, zz, out, label)


def _polar(theta, phi):
    """Unit vector at polar angle theta from map +z and azimuth phi."""
    st = math.sin(theta)
    return np.array([st * math.cos(phi), st * math.sin(phi), math.cos(theta)])


def _sepal_count(index):
    """Sepals of a fruit's calyx: 5, every third fruit 6."""
    return 6 if int(index) % 3 == 0 else 5


def leaf_profile(s):
    """Half width (0..1) of a tomato leaflet at s in [-1 (base), 1 (tip)], serrated edge."""
    return np.float32(0.89) * np.sqrt(np.maximum(1.0 - s * s, 0.0)) * (1.0 - 0.3 * s) * \
        (1.0 + 0.07 * np.sin(s * 9.0 * math.pi))


_LEAF_S = np.linspace(-1.0, 1.0, 41)
_LEAF_W = leaf_profile(_LEAF_S).astype(float) * 1.02
_CUBE = np.array([[sx, sy, sz] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)],
                 dtype=float)


class _Frame(object):
    """Per-render state: camera, pose, image, depth buffer, labels."""

    def __init__(self, renderer, camera, T, labels):
        self.camera = camera
        self.R, self.t = T[:3, :3], T[:3, 3]
        self.xs, self.ys = renderer._ray_grid(camera)
        self.img = np.empty((camera.height, camera.width, 3), np.uint8)
        self.zbuf = np.full((camera.height, camera.width), np.inf, np.float32)
        self.labels = np.zeros((camera.height, camera.width), np.int16) if labels else None
        self.light_cam = self.R.T.dot(renderer.light_dir).astype(np.float32)

    def to_cam(self, p):
        return self.R.T.dot(np.asarray(p, dtype=float) - self.t)

    def full_box(self):
        return 0, self.camera.width, 0, self.camera.height

    def clip_box(self, u0, u1, v0, v1):
        u0, v0 = max(u0, 0), max(v0, 0)
        u1, v1 = min(u1, self.camera.width), min(v1, self.camera.height)
        if u0 >= u1 or v0 >= v1:
            return None
        return u0, u1, v0, v1

    def bbox_of_points(self, pts):
        uv = self.camera.project(pts)
        return self.clip_box(int(math.floor(uv[:, 0].min())) - 1,
                             int(math.ceil(uv[:, 0].max())) + 2,
                             int(math.floor(uv[:, 1].min())) - 1,
                             int(math.ceil(uv[:, 1].max())) + 2)

    def put(self, rows, cols, z, bgr, label):
        self.zbuf[rows, cols] = z
        v = bgr * np.float32(255.0)
        np.clip(v, 0.0, 255.0, out=v)
        self.img[rows, cols] = v.astype(np.uint8)
        if self.labels is not None:
            self.labels[rows, cols] = label


def camera_poses(geom, joints):
    """Poses in map of the three cameras for a joint dict (URDF names)."""
    poses = geom.frame_transforms(joints)
    return {k: poses[k] for k in ('stereo_left_optical', 'stereo_right_optical',
                                  'hand_camera_optical')}


__all__ = ['Renderer', 'RenderFruit', 'fruit_albedo', 'fruits_from_scenario', 'camera_poses',
           'camera_model']
