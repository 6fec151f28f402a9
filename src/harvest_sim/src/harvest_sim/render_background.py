"""Background of harvest_sim's renderer (mixin of render.Renderer; numpy + OpenCV, no rospy)."""

import math

import cv2
import numpy as np

from harvest_sim import render_cache
from harvest_sim.render_materials import (CANOPY_TILE, NEAR, TEX_RES, noise_texture, rgb_to_bgr,
                                          wrapped_leaflet)


class Plane(object):
    """Axis-aligned background plane {p: p[axis] == value} and its place in the atlas."""

    def __init__(self, axis, value, kind, origin, size, res):
        self.axis, self.value, self.kind = axis, value, kind
        self.origin = origin           # atlas (col, row) of the tile block's top-left corner
        self.size = size               # (w, h) of one tile in texels
        self.res = res                 # m per texel


class BackgroundPainter(object):
    """Renderer methods: the textured background planes (canopy, opposite row, floor, roof),
    baked into one texture atlas, and their ray-cast per frame."""

    def _light(self, img_rgb_float, lit):
        """Bake the scenario light (colour, `lit` = ambient + diffuse share) into a texture."""
        out = img_rgb_float[:, :, ::-1] * (rgb_to_bgr(self.scenario.lighting.colour) * lit)
        return np.clip(out * 255.0, 0, 255).astype(np.uint8)

    def _build_atlas(self, rng, canopy_lit, floor_lit, roof_lit):
        """One texture atlas for every background plane: each tile is stored 2 x 2 times (the
        canopies 2 x 1: they are clamped in height) so that coordinates taken modulo the tile
        and shifted by half a tile never touch an edge (seamless wrapping with bilinear
        filtering). Slots: (origin, tile size, m/texel). The tiles are baked once per scenario
        and painting code (render_cache: later starts load them)."""
        bg = self.look_config.background if self.look_config is not None else 'foliage'
        lt = self.scenario.lighting
        names = ('canopy', 'aisle', 'floor', 'roof')
        key = render_cache.entry_key(
            'atlas', rng.bit_generator.state, bg, tuple(float(v) for v in lt.colour),
            float(lt.intensity), float(canopy_lit), float(floor_lit), float(roof_lit))
        baked = render_cache.load(key, names)
        if baked is None:
            baked = [self._canopy(rng, canopy_lit, bg),
                     self._canopy(rng, canopy_lit * np.float32(0.9), bg),
                     self._floor(rng, floor_lit), self._roof(rng, roof_lit)]
            render_cache.store(key, dict(zip(names, baked)))
        tiles = list(zip(baked, (TEX_RES, TEX_RES, 0.004, 0.01)))
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
                wrapped_leaflet(layer, (rng.uniform(0, w), rng.uniform(0, h)),
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
        fine = noise_texture(rng, (h, w), 1.0)
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
        mottle = cv2.resize(noise_texture(rng, (h // 8, w // 8), 1.5), (w, h),
                            interpolation=cv2.INTER_LINEAR)
        img *= (1.0 + 0.05 * mottle)[:, :, None]
        # plants beyond the film: soft green-grey shadows
        shadow = np.zeros((h, w, 3), np.float32)
        for _ in range(140):
            g = rng.uniform(0.5, 1.0)
            wrapped_leaflet(shadow, (rng.uniform(0, w), rng.uniform(0, h)),
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
        img *= (1.0 + 0.08 * noise_texture(rng, (500, 500), 2.0))[:, :, None]
        stains = np.clip(noise_texture(rng, (500, 500), 6.0) - 1.2, 0.0, 2.0)
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
        img *= (1.0 + 0.03 * noise_texture(rng, (400, 400), 3.0))[:, :, None]
        cv2.line(img, (0, 0), (399, 0), (0.3, 0.3, 0.32), 6)
        cv2.line(img, (0, 0), (0, 399), (0.3, 0.3, 0.32), 6)
        return self._light(img, lit)

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
